// The visible map shape from a viewpoint (paper §3: "for any given viewpoint, perceivable
// objects can be ordered in a counter-clockwise manner"; §4: the shape perceivable according
// to the map).
//
// Method: an angular sweep with a z-buffer. The field of view is divided into bins of
// `angular_resolution_rad` (comparable to a laser's beam spacing); every segment near the
// viewpoint (a SegmentIndex disc query, so the cost follows what is near) is rasterised into
// the bins it spans, keeping per bin the nearest depth along the bin's centre ray. A segment is
// visible in the bins where it is within `depth_tolerance_m` of that nearest depth (the
// tolerance stops a polyline from hiding itself at its own vertices); its visible parts are
// clipped exactly at the bin edge rays and at the max-range circle, so the geometry is not
// quantised, only the occlusion boundaries are (by one bin at most).
#pragma once

#include <unordered_map>
#include <vector>

#include "shape_slam/spatial_index.h"
#include "shape_slam/types.h"

namespace shape_slam {

struct VisibilityParams {
  double max_range_m = 30.0;  ///< parts farther from the viewpoint are cut at this circle, m
  double fov_rad = 2.0 * M_PI;  ///< field of view centred on the sensor's x axis, rad
  double angular_resolution_rad = 0.25 * M_PI / 180.0;  ///< sweep bin width, rad
  double min_piece_length_m = 0.05;  ///< shorter visible pieces are dropped, m
  double depth_tolerance_m = 0.05;   ///< occlusion tolerance, m
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// A visible part of a map polyline.
struct VisiblePolyline {
  Polyline points_sensor;  ///< sensor frame, bearing increasing along it (counter-clockwise)
  PolylineId source = 0;   ///< the map polyline it is part of
  double source_from_m = 0.0;  ///< arc-length interval on the source polyline (from <= to)
  double source_to_m = 0.0;
  bool reversed = false;   ///< the source runs clockwise here, so the piece was reversed
};

/// The visible map shape from `T_map_sensor`: the visible parts of the polylines, ordered
/// counter-clockwise by the bearing of their first vertex starting at the right edge of the
/// field of view (-fov/2; -pi for 360 deg). `index` must hold exactly `polylines_map`'s
/// polylines. Deterministic.
/// The visibility parameters for the map shape a scan is matched against or merged with: `base`
/// with max_range_m cut to as far as the scan reaches (its farthest valid reading beyond
/// min_range_m, plus 1 m; at least 1 m: what the scan cannot see cannot match it, and the
/// sweep's cost grows with range) and fov_rad = the scan's field of view (span of its beams plus
/// one beam step) widened by fov_margin_rad on each side, at most 2 pi.
VisibilityParams VisibilityForScan(const LaserScan& scan, const VisibilityParams& base,
                                   double min_range_m, double fov_margin_rad);

/// What a scan saw from the viewpoint, for a sweep that knows what is not there: the beams'
/// bearings (sensor frame, increasing) and ranges (NaN: unknown). A map part nearer than the
/// beam of its bin (the beam within one beam step of the bin's centre ray) by more than
/// margin_m was seen through: the beam went past it, so it is not there now (a person, the
/// wall of a wrong loop closure) and neither hides what is behind it nor is matched.
struct SeenRays {
  std::vector<double> bearings_rad;
  std::vector<double> ranges_m;
  double margin_m = 0.5;
};

/// SeenRays of a scan (sensor frame): its valid readings; "no return" (>= max_range_m) and
/// missing readings (NaN, <= 0) are unknown, since a beam also finds no return on glass or a
/// dark surface that is there (aces copy 1 in its own map, localized within 0.10 m: 94.3 % with
/// no return as +inf, 96.1 % as unknown, at margin 0.5 m).
SeenRays SeenRaysOf(const LaserScan& scan, double margin_m);

/// `seen` (optional): parts the scan saw through neither occlude nor are visible (SeenRays).
std::vector<VisiblePolyline> ComputeVisibleShape(
    const std::unordered_map<PolylineId, Polyline>& polylines_map, const SegmentIndex& index,
    const Pose2& T_map_sensor, const VisibilityParams& params, const SeenRays* seen = nullptr);

}  // namespace shape_slam
