// Shared by the commands: opening logs (reader warnings printed to stderr, scan lookup by
// index) and loading parameters.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "shape_slam/localizer.h"
#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"
#include "shape_slam_io/log_reader.h"

namespace shape_slam::app {

/// Installs handlers of fatal signals (SIGSEGV, SIGBUS, SIGFPE, SIGILL) that print what the
/// tool was doing (SetFatalContext) and exit with code 1 instead of dumping core. They exist for
/// crashes in third-party decoders on corrupt input (MRPT 2.5.8's rawlog deserialization can
/// dereference garbage). Not installed in sanitizer builds, whose own reports say more.
void InstallFatalSignalHandlers();

/// What the tool is doing, for the fatal-signal message (truncated to 400 characters).
void SetFatalContext(const std::string& context);

/// Opens a log; in non-strict mode malformed records are skipped and reported by
/// ReportLogIssues.
std::unique_ptr<io::LogReader> OpenLogForApp(const std::string& path, bool strict);

/// Prints the reader's skipped records and oddities to stderr as warnings (at most 10 lines
/// and a count).
void ReportLogIssues(const io::LogReader& reader);

/// The laser scans with the given 0-based indices (in that order), in one pass over the log.
/// Throws std::runtime_error naming the log and how many scans it has when an index is out of
/// range.
std::vector<LaserScan> ReadScansAt(const std::string& path, const std::vector<long long>& indices,
                                   bool strict);

/// The laser scan with 0-based index `index` of the log. Throws std::runtime_error naming the
/// log and how many scans it has when the index is out of range.
LaserScan ReadScanAt(const std::string& path, long long index, bool strict);

/// The mapper's parameters: the defaults, overridden by an ini file when one is given (every
/// key validated; see config/default.ini).
ShapeSlamParams LoadParamsForApp(const std::optional<std::string>& ini_path);

/// The same with the localizer's own settings ([localizer]), for localize and run --map.
LocalizerParams LoadLocalizerParamsForApp(const std::optional<std::string>& ini_path);

/// The q-quantile (0..1, linear interpolation) of the values; 0 when there are none.
double Percentile(std::vector<double> values, double q);

}  // namespace shape_slam::app
