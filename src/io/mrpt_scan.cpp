#include "shape_slam_io/mrpt_scan.h"

#include <mrpt/core/Clock.h>
#include <mrpt/obs/CObservation2DRangeScan.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "log_reader_internal.h"

namespace shape_slam::io {
namespace {

void CheckScan(const mrpt::obs::CObservation2DRangeScan& obs) {
  if (obs.getScanSize() == 0) throw std::invalid_argument("laser scan with no beam");
  if (!std::isfinite(obs.aperture) || obs.aperture <= 0.0f) {
    throw std::invalid_argument("laser scan aperture " + internal::FormatNumber(obs.aperture) +
                                " is not > 0");
  }
  if (!std::isfinite(obs.maxRange) || obs.maxRange <= 0.0f) {
    throw std::invalid_argument("laser scan maxRange " + internal::FormatNumber(obs.maxRange) +
                                " is not > 0");
  }
  const mrpt::poses::CPose3D& pose = obs.sensorPose;
  if (!std::isfinite(pose.x()) || !std::isfinite(pose.y()) || !std::isfinite(pose.yaw())) {
    throw std::invalid_argument("laser scan sensorPose is not finite");
  }
}

// Beam i direction as CObservation2DRangeScan::getScanAngle defines it, in double.
std::vector<double> BeamAngles(const mrpt::obs::CObservation2DRangeScan& obs) {
  const std::size_t n = obs.getScanSize();
  std::vector<double> angles_rad(n, 0.0);
  if (n < 2) return angles_rad;
  const double aperture_rad = obs.aperture;
  double first_rad = -0.5 * aperture_rad;
  double step_rad = aperture_rad / static_cast<double>(n - 1);
  if (!obs.rightToLeft) {
    first_rad = -first_rad;
    step_rad = -step_rad;
  }
  for (std::size_t i = 0; i < n; ++i) angles_rad[i] = first_rad + step_rad * static_cast<double>(i);
  return angles_rad;
}

}  // namespace

ConvertedMrptScan FromMrptScan(const mrpt::obs::CObservation2DRangeScan& obs) {
  CheckScan(obs);
  ConvertedMrptScan converted;
  LaserScan& scan = converted.scan;
  const std::size_t n = obs.getScanSize();
  scan.ranges_m.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    double range_m = obs.getScanRange(i);
    if (!obs.getScanRangeValidity(i)) {
      range_m = std::numeric_limits<double>::quiet_NaN();
    } else if (!std::isfinite(range_m) || range_m < 0.0) {
      range_m = std::numeric_limits<double>::quiet_NaN();
      ++converted.invalid_ranges;
    }
    scan.ranges_m[i] = range_m;
  }
  scan.angles_rad = BeamAngles(obs);
  scan.timestamp_s =
      obs.timestamp == mrpt::Clock::time_point() ? 0.0 : mrpt::Clock::toDouble(obs.timestamp);
  scan.max_range_m = obs.maxRange;
  const mrpt::poses::CPose3D& pose = obs.sensorPose;
  scan.T_robot_sensor = Pose2(pose.x(), pose.y(), NormalizeAngle(pose.yaw()));
  return converted;
}

}  // namespace shape_slam::io
