// Log readers: every supported log format delivered as one stream of shape_slam::LaserScan.
//
// Formats (detected from the content, not from the file name):
//  - CARMEN text logs (.log/.clf, plain or gzip): FLASER and ROBOTLASER1 records; see
//    carmen_reader.h for the record formats, the beam angles and the max-range rule.
//  - MRPT rawlogs (.rawlog, gzip or plain), both the actions/sensory-frames and the
//    observations-only layouts; see rawlog_reader.h. Only when built with MRPT.
// Only laser scans are delivered; other records and observation types are skipped silently.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam::io {

/// A log that cannot be read; what() names the file and the line (CARMEN) or entry (rawlog).
class LogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LogReaderOptions {
  /// When true, the first malformed record throws LogError. When false (default), a malformed
  /// record is skipped, counted and recorded in Stats().issues (the app prints them as
  /// warnings); a file that yields no laser scan at all, or is not a log of a known format
  /// (binary garbage, empty file, truncated gzip header...), still throws LogError.
  bool strict = false;
};

/// One thing worth a warning: a skipped malformed record, a timestamp going backwards...
struct LogIssue {
  std::string where;    ///< "file:line" (CARMEN) or "file: entry N" (rawlog, N from 0)
  std::string message;  ///< what is wrong, in plain words
};

/// At most this many issues are kept in LogReaderStats::issues (the counters go on counting).
inline constexpr std::size_t kMaxLogIssues = 100;

struct LogReaderStats {
  std::size_t scans = 0;                     ///< laser scans delivered so far
  std::size_t skipped_records = 0;           ///< malformed records skipped (non-strict)
  std::size_t invalid_ranges = 0;            ///< NaN/inf/negative readings turned into NaN
  std::size_t non_monotonic_timestamps = 0;  ///< scans whose timestamp is < the previous one's
  std::vector<LogIssue> issues;              ///< the first kMaxLogIssues issues, in order
};

/// A forward-only stream of the laser scans of one log file.
class LogReader {
 public:
  virtual ~LogReader() = default;
  /// The next laser scan, or std::nullopt at the end of the log. Throws LogError.
  virtual std::optional<LaserScan> Next() = 0;
  /// Counters and issues so far (they grow as Next() advances).
  virtual const LogReaderStats& Stats() const = 0;
  /// "carmen" or "rawlog".
  virtual std::string Format() const = 0;
  /// The path the reader was opened with.
  virtual const std::string& Path() const = 0;
};

/// Opens a CARMEN log (.log/.clf, optionally .gz) or an MRPT rawlog (.rawlog, gzip or plain).
/// Detects the format from the content (gzip magic, then text vs MRPT binary), not only the
/// extension. Throws LogError for a missing/unreadable path, a directory, an empty file or an
/// unknown format; throws LogError for rawlogs when built without MRPT.
std::unique_ptr<LogReader> OpenLog(const std::string& path, const LogReaderOptions& options = {});

/// Reads every laser scan of a log (convenience over OpenLog). The reader's issues are not
/// returned: use OpenLog and LogReader::Stats() to see them, or options.strict to make the
/// first malformed record an error.
std::vector<LaserScan> ReadAllScans(const std::string& path, const LogReaderOptions& options = {});

}  // namespace shape_slam::io
