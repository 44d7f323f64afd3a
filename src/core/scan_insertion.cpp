#include "shape_slam/scan_insertion.h"

#include <cmath>
#include <stdexcept>

#include "shape_slam/polyline_extraction.h"

namespace shape_slam {

void ScanInsertionParams::Validate() const {
  shapes.Validate();
  visibility.Validate();
  if (!(visibility_fov_margin_rad >= 0.0) || !std::isfinite(visibility_fov_margin_rad)) {
    throw std::invalid_argument("ScanInsertionParams::visibility_fov_margin_rad must be >= 0");
  }
  map_update.Validate();
}

std::vector<VisiblePolyline> VisibleForInsertion(const PolylineMap& map, const LaserScan& scan,
                                                 const Pose2& T_map_sensor,
                                                 const ScanInsertionParams& params) {
  return map.Visible(T_map_sensor,
                     VisibilityForScan(scan, params.visibility, params.shapes.extraction.min_range_m,
                                       params.visibility_fov_margin_rad));
}

// §5.2: the polylines in the map frame, merged with the map shape visible from the sensor.
MapUpdateStats InsertScanShapes(PolylineMap& map, const std::vector<Polyline>& fine_sensor,
                                const LaserScan& scan, const Pose2& T_map_sensor,
                                bool pose_trusted, const ScanInsertionParams& params) {
  if (fine_sensor.empty()) return {};
  std::vector<Polyline> perceived_map;
  perceived_map.reserve(fine_sensor.size());
  for (const Polyline& p : fine_sensor) perceived_map.push_back(Transform(T_map_sensor, p));
  const std::vector<VisiblePolyline> visible =
      VisibleForInsertion(map, scan, T_map_sensor, params);
  return UpdateMap(map, perceived_map, T_map_sensor, visible, scan, pose_trusted,
                   params.map_update);
}

ScanInsertionResult InsertScan(PolylineMap& map, const LaserScan& scan, const Pose2& T_map_robot,
                               bool pose_trusted, const ScanInsertionParams& params) {
  if (!std::isfinite(T_map_robot.x) || !std::isfinite(T_map_robot.y) ||
      !std::isfinite(T_map_robot.theta)) {
    throw std::invalid_argument("InsertScan: the robot pose is not finite");
  }
  params.Validate();
  const LaserScan ccw = CounterClockwiseScan(scan);
  const ScanShapes shapes = ExtractScanShapes(ccw, params.shapes);  // §3.1
  ScanInsertionResult result;
  result.polylines = static_cast<int>(shapes.fine.size());
  result.map_update = InsertScanShapes(map, shapes.fine, ccw, T_map_robot * ccw.T_robot_sensor,
                                       pose_trusted, params);
  return result;
}

}  // namespace shape_slam
