#include "app_common.h"

#include <iostream>
#include <stdexcept>

#include "shape_slam_io/params_ini.h"

namespace shape_slam::app {

std::unique_ptr<io::LogReader> OpenLogForApp(const std::string& path, bool strict) {
  io::LogReaderOptions options;
  options.strict = strict;
  return io::OpenLog(path, options);
}

void ReportLogIssues(const io::LogReader& reader) {
  const io::LogReaderStats& stats = reader.Stats();
  constexpr std::size_t kMaxLines = 10;
  for (std::size_t i = 0; i < stats.issues.size() && i < kMaxLines; ++i) {
    std::cerr << "warning: " << stats.issues[i].where << ": " << stats.issues[i].message << "\n";
  }
  if (stats.skipped_records > 0) {
    std::cerr << "warning: " << reader.Path() << ": skipped " << stats.skipped_records
              << " malformed record(s); use --strict to stop at the first one\n";
  }
  if (stats.invalid_ranges > 0) {
    std::cerr << "warning: " << reader.Path() << ": " << stats.invalid_ranges
              << " NaN/inf/negative range reading(s) treated as no reading\n";
  }
}

LaserScan ReadScanAt(const std::string& path, long long index, bool strict) {
  const std::unique_ptr<io::LogReader> reader = OpenLogForApp(path, strict);
  long long count = 0;
  while (std::optional<LaserScan> scan = reader->Next()) {
    if (count++ == index) {
      ReportLogIssues(*reader);
      return *scan;
    }
  }
  ReportLogIssues(*reader);
  throw std::runtime_error(path + ": scan " + std::to_string(index) + " does not exist (the log has " +
                           std::to_string(count) + " laser scans, indices 0.." +
                           std::to_string(count - 1) + ")");
}

ShapeSlamParams LoadParamsForApp(const std::optional<std::string>& ini_path) {
  return ini_path ? io::LoadParamsIni(*ini_path) : ShapeSlamParams{};
}

}  // namespace shape_slam::app
