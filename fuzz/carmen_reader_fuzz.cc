// Fuzz target of CarmenReader (carmen_reader.h): the input is the content of a log file (plain
// text or gzip), read whole in lenient and in strict mode. The reader must deliver scans or
// throw LogError; any other exception, a crash, a sanitizer report or a failed check of what
// the header promises (fuzz/log_reader_checks.h and below) is a finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "fuzz_support.h"
#include "log_reader_checks.h"
#include "shape_slam_io/carmen_reader.h"

namespace {

using shape_slam::LaserScan;
using shape_slam::fuzz::Check;

// FLASER and ROBOTLASER1 records both carry the odometry pose, and a non-finite pose makes a
// record malformed.
void CheckCarmenScan(const LaserScan& scan) {
  Check(scan.T_odom_robot.has_value(), "CARMEN scans carry the odometry pose");
  Check(shape_slam::fuzz::IsFinitePose(*scan.T_odom_robot), "the odometry pose is finite");
  Check(shape_slam::fuzz::IsNormalised(scan.T_odom_robot->theta), "odometry theta in (-pi, pi]");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static shape_slam::fuzz::TempFile file("carmen");
  file.Write(data, size);
  using shape_slam::io::CarmenReader;
  const auto lenient = shape_slam::fuzz::ReadAll<CarmenReader>(file.path(), false, CheckCarmenScan);
  const auto strict = shape_slam::fuzz::ReadAll<CarmenReader>(file.path(), true, CheckCarmenScan);
  shape_slam::fuzz::CheckModesAgree(lenient, strict);
  // Every NaN, inf or negative reading becomes NaN and is counted (there is no other NaN).
  if (lenient) {
    Check(lenient->stats.invalid_ranges == lenient->nan_ranges,
          "invalid_ranges counts the NaN readings delivered");
  }
  return 0;
}
