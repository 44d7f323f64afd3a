// MRPT types to the core's and back: laser scans, poses, point clouds.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "shape_slam/types.h"

namespace mrpt::obs {
class CObservation2DRangeScan;
}  // namespace mrpt::obs
namespace mrpt::poses {
class CPose2D;
class CPose3D;
}  // namespace mrpt::poses
namespace mrpt::maps {
class CPointsMap;
}  // namespace mrpt::maps

namespace shape_slam {

/// (x, y, yaw) of a 3D pose: the planar part the core works with.
Pose2 ToPose2(const mrpt::poses::CPose3D& pose);
Pose2 ToPose2(const mrpt::poses::CPose2D& pose);
mrpt::poses::CPose2D ToCPose2D(const Pose2& pose);

/// A CObservation2DRangeScan as the core's LaserScan: the rawlog reader's conversion
/// (shape_slam_io/mrpt_scan.h, FromMrptScan), one set of rules for validity, NaN and negative
/// ranges, beam angles and order, maxRange and sensor pose; timestamp_s is 0 when the scan has
/// none; no odometry. Throws std::invalid_argument naming the problem for a scan without beams,
/// with a non-finite or non-positive aperture or maxRange, or a non-finite sensor pose.
LaserScan ToLaserScan(const mrpt::obs::CObservation2DRangeScan& observation);

/// The (x, y) of every point of a points map, in the map's frame, metres.
std::vector<Point2> PointsOf(const mrpt::maps::CPointsMap& points);

/// A point cloud seen as a laser scan from `T_frame_viewpoint` (a pose in the cloud's frame):
/// the points are ordered by bearing from the viewpoint, and of the points falling into the same
/// bearing bin of `bearing_bin_rad` only the nearest is kept (what a scanner there would have
/// seen, roughly). Each kept point becomes one beam at its exact bearing and range; the scan
/// covers the full circle. T_robot_sensor = T_frame_viewpoint, so the "robot" frame of the scan
/// is the cloud's frame. max_range_m is just beyond the farthest point. Points at the viewpoint
/// are dropped. Throws std::invalid_argument unless bearing_bin_rad > 0.
LaserScan PointsAsScan(const std::vector<Point2>& points_frame, const Pose2& T_frame_viewpoint,
                       double bearing_bin_rad);

}  // namespace shape_slam
