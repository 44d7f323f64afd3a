// CPolylineMap: inserting laser scans -- the core's scan insertion (scan_insertion.h: §3.1
// extraction by ExtractScanShapes, §5.2 map update) at the caller's pose, as the mapper inserts
// a keyframe.
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose3D.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/scan_insertion.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {

bool CPolylineMap::internal_insertObservation(
    const mrpt::obs::CObservation& obs,
    const std::optional<const mrpt::poses::CPose3D>& robotPose) {
  const auto* observation = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&obs);
  if (observation == nullptr) return false;
  const std::string what = "shape_slam::CPolylineMap: cannot insert the laser scan '" +
                           observation->sensorLabel + "'";
  LaserScan scan;
  try {
    scan = ToLaserScan(*observation);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(what + ": " + e.what());
  }
  const Pose2 T_map_robot = robotPose ? ToPose2(*robotPose) : Pose2();
  if (!std::isfinite(T_map_robot.x) || !std::isfinite(T_map_robot.y) ||
      !std::isfinite(T_map_robot.theta)) {
    throw std::invalid_argument(what + " at a non-finite robot pose");
  }
  const ScanInsertionResult inserted =
      InsertScan(map_, scan, T_map_robot, /*pose_trusted=*/true, options_.insertion);
  if (inserted.polylines == 0) return false;
  last_update_ = inserted.map_update;
  InvalidateGeometry();
  return true;
}

}  // namespace shape_slam
