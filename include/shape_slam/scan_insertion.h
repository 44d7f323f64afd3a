// Inserting one laser scan into a polyline map at a given pose (paper §3.1 then §5.2): the scan's
// shapes (scan_shapes.h), the visible map shape over the scan's field of view, and the map
// update. The step the mapper takes for a keyframe once its pose is known, as one call for the
// clients that bring their own poses (the MRPT map classes, map building from known poses).
#pragma once

#include <vector>

#include "shape_slam/map_update.h"
#include "shape_slam/polyline_map.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam/types.h"
#include "shape_slam/visibility.h"

namespace shape_slam {

struct ScanInsertionParams {
  ScanShapesParams shapes;  ///< §3.1 extraction and simplification (the `fine` polylines merge)
  /// The visible map shape at the scan's pose (feeds the contradiction rule of §5.2); its
  /// max_range_m and fov_rad are set per scan (VisibilityForScan).
  VisibilityParams visibility;
  /// The visible shape covers the scan's field of view widened by this on each side, radians.
  double visibility_fov_margin_rad = 0.35;
  MapUpdateParams map_update;  ///< §5.2

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// The visible map shape a scan at `T_map_sensor` is merged with: the scan's field of view plus
/// the margin, as far as it reaches plus 1 m (VisibilityForScan).
std::vector<VisiblePolyline> VisibleForInsertion(const PolylineMap& map, const LaserScan& scan,
                                                 const Pose2& T_map_sensor,
                                                 const ScanInsertionParams& params);

/// §5.2 for polylines already extracted from `scan` (`fine_sensor`: ScanShapes::fine, sensor
/// frame) with the sensor at `T_map_sensor`. `scan` must be counter-clockwise like the
/// polylines (CounterClockwiseScan). With `pose_trusted` false only new territory is added
/// (UpdateMap).
MapUpdateStats InsertScanShapes(PolylineMap& map, const std::vector<Polyline>& fine_sensor,
                                const LaserScan& scan, const Pose2& T_map_sensor,
                                bool pose_trusted, const ScanInsertionParams& params);

/// What InsertScan did.
struct ScanInsertionResult {
  int polylines = 0;           ///< polylines extracted from the scan (0: the map is unchanged)
  MapUpdateStats map_update;   ///< what the map update did with them
};

/// The whole step for a raw scan with the robot at `T_map_robot`: counter-clockwise beam order,
/// ExtractScanShapes, then InsertScanShapes at T_map_robot * scan.T_robot_sensor. A scan without
/// polylines leaves the map as it is. Throws std::invalid_argument for a pose that is not
/// finite, a scan whose ranges and angles differ in size, or invalid params.
ScanInsertionResult InsertScan(PolylineMap& map, const LaserScan& scan, const Pose2& T_map_robot,
                               bool pose_trusted, const ScanInsertionParams& params);

}  // namespace shape_slam
