// Map update (paper §5.2): merging a perceived polyline into a corresponding map polyline
// (head / body / tail, bodies averaged by simulating a range finder at the current pose,
// weighted by support), adding unmatched polylines, and dropping polylines that later scans
// contradict.
#pragma once

#include <vector>

#include "shape_slam/polyline_map.h"
#include "shape_slam/types.h"

namespace shape_slam {

struct MapUpdateParams {
  /// DCE threshold applied to merged and added polylines so the map stays compact (metres, the
  /// relevance K of eq. 1).
  double dce_threshold_m = 0.03;
  /// ... without moving a polyline farther than this from the points it was made of (metres;
  /// see SimplifyDceBounded).
  double max_deviation_m = 0.03;
  /// Spacing of the points at which the bodies are averaged, metres.
  double merge_sample_spacing_m = 0.05;
  /// Rays that meet a body at less than this angle (radians) are ill-conditioned: there the
  /// body points are paired along the map body's normal instead of along the simulated ray.
  double min_incidence_rad = 0.35;
  /// Cap of the per-vertex support: a wall seen this often moves by at most 1/(cap+1) of a new
  /// observation's offset, so one scan cannot bend it, yet it can still adapt.
  double max_support = 20.0;
  /// A perceived polyline merges into a map polyline when, over their overlap, the RMS distance
  /// is at most this (metres) ...
  double merge_max_misfit_m = 0.10;
  /// ... the RMS direction difference at most this (radians) ...
  double merge_max_angle_rad = 0.35;
  /// ... and the overlap is at least this long (metres) or covers this fraction of the shorter.
  double merge_min_overlap_m = 0.30;
  double merge_min_overlap_fraction = 0.5;
  /// When the scan's pose is not confirmed by a match, only perceived polylines that lie mostly
  /// farther than this from the map are added (new territory); nothing is merged (metres) ...
  double untrusted_clearance_m = 0.5;
  /// ... "mostly": more than this fraction of its samples.
  double untrusted_near_fraction = 0.5;
  /// A perceived polyline that merges nowhere is still not added when more than
  /// explained_fraction of it lies within explained_distance_m (metres) of the map: the map
  /// already holds it (clutter seen from another side, fragments of a known wall).
  double explained_distance_m = 0.10;
  double explained_fraction = 0.8;
  /// Perceived polylines shorter than this are not added to the map (metres).
  double min_new_length_m = 0.10;
  /// A map polyline is contradicted by a scan when most of its visible samples lie in front of
  /// the scan's readings by more than this margin (the rays pass through it), metres.
  double contradiction_margin_m = 0.30;
  /// Drop rule: a polyline seen at most `drop_max_observations` times and contradicted at least
  /// `drop_min_contradictions` times is removed (people, doors, other moving things).
  int drop_max_observations = 1;
  int drop_min_contradictions = 3;
  /// Spacing of the samples of the checks above (new territory, contradiction), metres ...
  double check_sample_spacing_m = 0.10;
  /// ... and of the check that a merge stays near its inputs (merge_max_deviation_m), metres.
  double merge_check_spacing_m = 0.05;

  void Validate() const;
};

/// A polyline with per-vertex weights, the unit of merging.
struct WeightedPolyline {
  Polyline points;
  std::vector<double> weights;
};

/// §5.2: merges `perceived` into `model` (both map frame) seen from `viewpoint`. The bodies are
/// the parts between the projections of the other polyline's end points; head and tail are
/// taken from whichever polyline extends further; bodies are averaged point by point with the
/// weights, pairing points along simulated laser rays from the viewpoint (along the model's
/// normal where rays graze). The result is simplified by DCE. The model's orientation is kept.
WeightedPolyline MergePolylines(const WeightedPolyline& model, const WeightedPolyline& perceived,
                                const Point2& viewpoint, const MapUpdateParams& params);

/// What one map update did.
struct MapUpdateStats {
  int merged = 0;   ///< perceived polylines merged into existing ones
  int added = 0;    ///< new map polylines
  int joined = 0;   ///< map polylines absorbed into another by a merge
  int dropped = 0;  ///< map polylines removed by the contradiction rule
  int unsound = 0;  ///< merges rejected because the result strayed from its inputs
  int explained = 0;  ///< perceived polylines the map already held (not added)
  std::vector<PolylineId> touched;  ///< the map polylines it added or merged into
};

/// One scan's map update at the final pose: every perceived polyline (map frame) merges into
/// the map polylines it overlaps (by the misfit test above, which after alignment confirms the
/// shape matcher's correspondences and catches overlaps that grouping differences left
/// unmatched); the rest are added. The scan and the visible shape used for matching (sensor
/// frame at the final pose) feed the contradiction rule. With `pose_trusted` false (no match
/// confirmed the pose) the map only grows into new territory (see untrusted_clearance_m): a
/// misplaced scan must not blur or contradict what is there.
MapUpdateStats UpdateMap(PolylineMap& map, const std::vector<Polyline>& perceived_map,
                         const Pose2& T_map_sensor, const std::vector<VisiblePolyline>& visible,
                         const LaserScan& scan, bool pose_trusted, const MapUpdateParams& params);

}  // namespace shape_slam
