// Fuzz target of RawlogReader (rawlog_reader.h): the input is the content of a rawlog file
// (MRPT serialized objects, plain or gzip), read whole in lenient and in strict mode. The
// reader must deliver scans or throw LogError; any other exception, a crash, a sanitizer report
// or a failed check of what the header promises (fuzz/log_reader_checks.h and below) is a
// finding. Allocations above 256 MiB fail here (bounded_operator_new.cc says why).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "fuzz_support.h"
#include "log_reader_checks.h"
#include "shape_slam_io/rawlog_reader.h"

namespace {

using shape_slam::LaserScan;
using shape_slam::fuzz::Check;

// Scans with a non-finite aperture or sensor pose are malformed records, so beam angles and
// the sensor mounting of a delivered scan are finite.
void CheckRawlogScan(const LaserScan& scan) {
  for (const double a : scan.angles_rad) Check(std::isfinite(a), "beam angles are finite");
  Check(shape_slam::fuzz::IsFinitePose(scan.T_robot_sensor), "the sensor pose is finite");
  Check(shape_slam::fuzz::IsNormalised(scan.T_robot_sensor.theta), "sensor yaw in (-pi, pi]");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static shape_slam::fuzz::TempFile file("rawlog");
  file.Write(data, size);
  using shape_slam::io::RawlogReader;
  const auto lenient = shape_slam::fuzz::ReadAll<RawlogReader>(file.path(), false, CheckRawlogScan);
  const auto strict = shape_slam::fuzz::ReadAll<RawlogReader>(file.path(), true, CheckRawlogScan);
  shape_slam::fuzz::CheckModesAgree(lenient, strict);
  // Readings that are NaN, inf or negative are counted; readings MRPT flags invalid are NaN
  // without being counted.
  if (lenient) {
    Check(lenient->stats.invalid_ranges <= lenient->nan_ranges,
          "invalid_ranges counts only NaN readings");
  }
  return 0;
}
