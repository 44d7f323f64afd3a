// What every log reader promises of the scans it delivers (log_reader.h), checked on the output
// of a fuzzed log, and a loop reading a whole log in one mode.
#pragma once

#include <cmath>
#include <cstddef>
#include <optional>
#include <string>

#include "fuzz_support.h"
#include "shape_slam/types.h"
#include "shape_slam_io/log_reader.h"

namespace shape_slam::fuzz {

/// Checks of one delivered scan common to the readers.
inline void CheckCommonScan(const LaserScan& scan) {
  Check(!scan.ranges_m.empty(), "a delivered scan has at least one beam");
  Check(scan.ranges_m.size() == scan.angles_rad.size(), "one angle per range");
  for (const double r : scan.ranges_m) {
    Check(std::isnan(r) || (std::isfinite(r) && r >= 0.0),
          "a reading is NaN (no reading) or finite and >= 0");
  }
  Check(std::isfinite(scan.timestamp_s), "the timestamp is finite");
  Check(std::isfinite(scan.max_range_m) && scan.max_range_m > 0.0, "max_range_m is finite, > 0");
}

inline bool IsFinitePose(const Pose2& pose) {
  return std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta);
}

/// True when theta is normalised into (-pi, pi] (NormalizeAngle).
inline bool IsNormalised(double theta_rad) { return theta_rad > -M_PI && theta_rad <= M_PI; }

struct ReadSummary {
  std::size_t scans = 0;       ///< scans delivered by Next()
  std::size_t nan_ranges = 0;  ///< NaN readings in them
  io::LogReaderStats stats;    ///< the reader's counters at the end
};

/// Opens `path` with a Reader and reads every scan, checking each with `check_scan`. Returns
/// nullopt when the reader throws LogError, the only exception the readers document; anything
/// else propagates and is a finding.
template <typename Reader, typename ScanCheck>
std::optional<ReadSummary> ReadAll(const std::string& path, bool strict,
                                   const ScanCheck& check_scan) {
  io::LogReaderOptions options;
  options.strict = strict;
  try {
    Reader reader(path, options);
    ReadSummary summary;
    while (const std::optional<LaserScan> scan = reader.Next()) {
      CheckCommonScan(*scan);
      check_scan(*scan);
      ++summary.scans;
      for (const double r : scan->ranges_m) summary.nan_ranges += std::isnan(r) ? 1 : 0;
    }
    Check(reader.Next() == std::nullopt, "Next() stays at the end once it returned nullopt");
    summary.stats = reader.Stats();
    Check(summary.stats.scans == summary.scans, "Stats().scans counts the delivered scans");
    Check(summary.scans >= 1, "a reader that opened without LogError delivers a scan");
    Check(summary.stats.issues.size() <= io::kMaxLogIssues, "at most kMaxLogIssues issues kept");
    if (strict) Check(summary.stats.skipped_records == 0, "strict mode skips no record");
    return summary;
  } catch (const io::LogError&) {
    return std::nullopt;
  }
}

/// The two modes agree: a log that strict mode reads whole reads the same without it.
inline void CheckModesAgree(const std::optional<ReadSummary>& lenient,
                            const std::optional<ReadSummary>& strict) {
  if (!strict) return;
  Check(lenient.has_value(), "a log readable in strict mode is readable without it");
  Check(lenient->scans == strict->scans, "strict and lenient deliver the same scans");
  Check(lenient->stats.skipped_records == 0, "nothing skipped in a log strict mode accepts");
}

}  // namespace shape_slam::fuzz
