// The one conversion of an MRPT laser scan (mrpt::obs::CObservation2DRangeScan) to the core's
// LaserScan, used by the rawlog reader (rawlog_reader.h) and the MRPT map classes
// (shape_slam_mrpt/conversions.h), so a scan is the same LaserScan whichever way it comes in.
// Only available when ShapeSLAM is built with MRPT; this header itself does not need MRPT.
//
// Rules:
//  - ranges: getScanRange(i); getScanRangeValidity(i) false -> NaN; a valid reading that is NaN,
//    inf or negative -> NaN, counted in invalid_ranges. Readings at or beyond maxRange are kept
//    as they are (the core treats them as no return: polyline_extraction.h).
//  - beam order and angles as CObservation2DRangeScan::getScanAngle, in double: beam i at
//    -aperture/2 + i * aperture / (n - 1), negated when !rightToLeft (a one-beam scan points at
//    0). The beams are not reordered (the core makes scans counter-clockwise where it needs to).
//  - max_range_m = maxRange; T_robot_sensor = (x, y, yaw) of sensorPose (z, pitch, roll are
//    dropped: the scan is taken as planar); timestamp_s = mrpt::Clock::toDouble(timestamp)
//    (seconds since the UNIX epoch), 0 when the scan has none; no odometry.
//  - std::invalid_argument, naming the problem, for a scan with no beam, a non-finite or
//    non-positive aperture or maxRange, or a non-finite sensor pose.
#pragma once

#include <cstddef>

#include "shape_slam/types.h"

namespace mrpt::obs {
class CObservation2DRangeScan;
}  // namespace mrpt::obs

namespace shape_slam::io {

struct ConvertedMrptScan {
  LaserScan scan;
  /// Readings flagged valid that were NaN, inf or negative (made NaN).
  std::size_t invalid_ranges = 0;
};

/// See the file comment. Throws std::invalid_argument.
ConvertedMrptScan FromMrptScan(const mrpt::obs::CObservation2DRangeScan& observation);

}  // namespace shape_slam::io
