// CPolylineMap: inserting laser scans (the pipeline's extraction, simplification and map update
// at the caller's pose).
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/map_update.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/visibility.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

// The visible map shape over the scan's field of view plus a margin, as far as it reaches plus
// 1 m (as the pipeline does).
VisibilityParams VisibilityFor(const LaserScan& scan, const InsertionOptions& options) {
  return VisibilityForScan(scan, options.visibility, options.extraction.min_range_m,
                           options.visibility_fov_margin_rad);
}

// §3.1: the scan's polylines, simplified as the pipeline simplifies its alignment polylines,
// in the map frame.
std::vector<Polyline> PerceivedPolylines(const LaserScan& scan, const Pose2& T_map_sensor,
                                         const InsertionOptions& options) {
  std::vector<Polyline> perceived_map;
  for (const Polyline& raw : ExtractPolylines(scan, options.extraction)) {
    const Polyline fine = SimplifyDceBounded(raw, options.alignment_dce_threshold_m,
                                             options.alignment_max_deviation_m);
    perceived_map.push_back(Transform(T_map_sensor, fine));
  }
  return perceived_map;
}

}  // namespace

bool CPolylineMap::internal_insertObservation(
    const mrpt::obs::CObservation& obs,
    const std::optional<const mrpt::poses::CPose3D>& robotPose) {
  const auto* observation = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&obs);
  if (observation == nullptr) return false;
  LaserScan scan;
  try {
    scan = CounterClockwiseScan(ToLaserScan(*observation));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("shape_slam::CPolylineMap: cannot insert the laser scan '" +
                                observation->sensorLabel + "': " + e.what());
  }
  const Pose2 T_map_robot = robotPose ? ToPose2(*robotPose) : Pose2();
  if (!std::isfinite(T_map_robot.x) || !std::isfinite(T_map_robot.y) ||
      !std::isfinite(T_map_robot.theta)) {
    throw std::invalid_argument("shape_slam::CPolylineMap: cannot insert the laser scan '" +
                                observation->sensorLabel + "' at a non-finite robot pose");
  }
  const Pose2 T_map_sensor = T_map_robot * scan.T_robot_sensor;
  const std::vector<Polyline> perceived_map =
      PerceivedPolylines(scan, T_map_sensor, options_.insertion);
  if (perceived_map.empty()) return false;
  const std::vector<VisiblePolyline> visible =
      map_.Visible(T_map_sensor, VisibilityFor(scan, options_.insertion));
  last_update_ = UpdateMap(map_, perceived_map, T_map_sensor, visible, scan,
                           /*pose_trusted=*/true, options_.insertion.map_update);
  InvalidateGeometry();
  return true;
}

}  // namespace shape_slam
