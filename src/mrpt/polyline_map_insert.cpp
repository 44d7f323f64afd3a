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
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

// The scan with its beams in increasing angle, so that polylines run counter-clockwise like
// the visible map shape (as the pipeline does, §3).
LaserScan CounterClockwise(LaserScan scan) {
  if (scan.angles_rad.size() < 2 || scan.angles_rad.front() <= scan.angles_rad.back()) return scan;
  std::reverse(scan.ranges_m.begin(), scan.ranges_m.end());
  std::reverse(scan.angles_rad.begin(), scan.angles_rad.end());
  return scan;
}

// Angular coverage of a scan: span of its beams plus one beam step.
double FieldOfView(const LaserScan& scan) {
  const std::size_t n = scan.angles_rad.size();
  if (n < 2) return 0.0;
  const double span = scan.angles_rad.back() - scan.angles_rad.front();
  return span + span / static_cast<double>(n - 1);
}

double FarthestReading(const LaserScan& scan, double min_range_m) {
  double farthest = 0.0;
  for (const double r : scan.ranges_m) {
    if (std::isfinite(r) && r > min_range_m && r < scan.max_range_m)
      farthest = std::max(farthest, r);
  }
  return farthest;
}

// The visible map shape is computed over the scan's field of view plus a margin and as far as
// the scan reaches plus 1 m (as the pipeline does).
VisibilityParams VisibilityFor(const LaserScan& scan, const InsertionOptions& options) {
  VisibilityParams visibility = options.visibility;
  const double reach_m = FarthestReading(scan, options.extraction.min_range_m) + 1.0;
  visibility.max_range_m = std::max(1.0, std::min(visibility.max_range_m, reach_m));
  visibility.fov_rad =
      std::min(2.0 * M_PI, FieldOfView(scan) + 2.0 * options.visibility_fov_margin_rad);
  return visibility;
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
    scan = CounterClockwise(ToLaserScan(*observation));
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
