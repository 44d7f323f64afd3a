#include "shape_slam_mrpt/conversions.h"

#include <mrpt/maps/CPointsMap.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "shape_slam_io/mrpt_scan.h"

namespace shape_slam {

Pose2 ToPose2(const mrpt::poses::CPose3D& pose) {
  return {pose.x(), pose.y(), NormalizeAngle(pose.yaw())};
}

Pose2 ToPose2(const mrpt::poses::CPose2D& pose) {
  return {pose.x(), pose.y(), NormalizeAngle(pose.phi())};
}

mrpt::poses::CPose2D ToCPose2D(const Pose2& pose) { return {pose.x, pose.y, pose.theta}; }

LaserScan ToLaserScan(const mrpt::obs::CObservation2DRangeScan& obs) {
  return io::FromMrptScan(obs).scan;
}

std::vector<Point2> PointsOf(const mrpt::maps::CPointsMap& points) {
  const auto& xs = points.getPointsBufferRef_x();
  const auto& ys = points.getPointsBufferRef_y();
  std::vector<Point2> out;
  out.reserve(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) out.emplace_back(xs[i], ys[i]);
  return out;
}

LaserScan PointsAsScan(const std::vector<Point2>& points_frame, const Pose2& T_frame_viewpoint,
                       double bearing_bin_rad) {
  if (!(bearing_bin_rad > 0.0) || !std::isfinite(bearing_bin_rad)) {
    throw std::invalid_argument("PointsAsScan: bearing_bin_rad must be > 0");
  }
  // Nearest point per bearing bin, bins in increasing bearing.
  const PointTransform T_viewpoint_frame(T_frame_viewpoint.Inverse());
  std::map<long long, std::pair<double, double>> nearest;  // bin -> (range, bearing)
  for (const Point2& p_frame : points_frame) {
    const Point2 p = T_viewpoint_frame(p_frame);
    const double range_m = p.norm();
    if (!std::isfinite(range_m) || range_m <= 1e-9) continue;
    const double bearing_rad = std::atan2(p.y(), p.x());
    const auto bin = static_cast<long long>(std::floor((bearing_rad + M_PI) / bearing_bin_rad));
    const auto it = nearest.find(bin);
    if (it == nearest.end() || range_m < it->second.first) nearest[bin] = {range_m, bearing_rad};
  }
  LaserScan scan;
  scan.T_robot_sensor = T_frame_viewpoint;
  double farthest_m = 0.0;
  for (const auto& [bin, reading] : nearest) {
    scan.ranges_m.push_back(reading.first);
    scan.angles_rad.push_back(reading.second);
    farthest_m = std::max(farthest_m, reading.first);
  }
  scan.max_range_m = farthest_m + 1.0;
  return scan;
}

}  // namespace shape_slam
