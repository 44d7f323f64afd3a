// Alignment of the perceived shape with the map (paper §5.1): the paper's adaptation of the scan
// matching of Cox [3] / Gutmann [7], restricted to the shapes the matcher of §4.2 put in
// correspondence.
//
// Every perceived polyline is sampled every 10 cm along its arc length with at least one sample
// per segment (§5.1). Each sample is matched with the nearest point of the model polylines of
// its own pair only -- correspondences come from shape matching, proximity only picks the point
// on the already matched shape -- and the closed-form rigid motion that best aligns the samples
// with their nearest points (weighted 2D Procrustes, Umeyama without scale) is applied. Matching
// and aligning alternate until the motion no longer changes significantly (§5.1).
//
// Beyond the paper, which assumes clean correspondences and a good start:
//  * trimming: samples farther than a gate from their pair are ignored. The ICP first converges
//    with the gate at max_correspondence_distance_m; then, each time it converges, the gate is
//    tightened to 3 robust standard deviations of the used distances (3 * 1.4826 * median), not
//    below min_correspondence_distance_m, and the ICP goes on, until the gate would shrink by
//    less than 10%. Tightening only after convergence keeps the samples that still have to pull
//    (a shrinking gate during convergence would cut exactly the far ones);
//  * boundary rejection: samples whose nearest point is an end of a model polyline, reached by a
//    projection falling beyond that end, are ignored (reject_end_projections). A shape seen
//    further than the map knows it then neither pulls the scan back nor biases the fit;
//  * acceleration (Besl & McKay, PAMI 1992, §IV-C): point-to-point ICP against lines creeps
//    along weakly constrained directions (a corridor held only by its door jambs). When three
//    successive updates point the same way, the pose is extrapolated along them.
#pragma once

#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

/// One correspondence of the shape matcher (§4.2): a perceived polyline and the model
/// polyline(s) it matches.
struct ShapePair {
  Polyline perceived;           ///< scan frame, metres
  std::vector<Polyline> model;  ///< map frame, metres; one, or several for a 1-to-many grouping
  double weight = 1.0;          ///< relative weight of the pair's samples, unitless, >= 0
};

struct AlignmentParams {
  /// Arc-length spacing of the samples of a perceived polyline, metres (§5.1: 10 cm).
  double sample_spacing_m = 0.10;
  /// Largest number of match-and-align iterations, >= 1.
  int max_iterations = 50;
  /// Convergence: the last update moved the scan origin by less than this, metres ...
  double convergence_translation_m = 1e-4;
  /// ... and rotated the scan by less than this, radians.
  double convergence_rotation_rad = 1e-5;
  /// Initial gate: samples farther than this from the nearest point of their pair are ignored,
  /// metres.
  double max_correspondence_distance_m = 1.0;
  /// Floor of the shrinking gate, metres (set it to max_correspondence_distance_m for a fixed
  /// gate). Keep it a few times the sensor noise.
  double min_correspondence_distance_m = 0.05;
  /// Ignore samples that project beyond an open end of a model polyline (see the file comment).
  bool reject_end_projections = true;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

struct AlignmentResult {
  Pose2 T_map_scan;             ///< the aligned pose (the initial one when nothing could be used)
  bool converged = false;       ///< the update fell below both thresholds with samples in use
  int iterations = 0;           ///< match-and-align iterations performed
  int num_correspondences = 0;  ///< samples used at the final pose
  /// Point-to-polyline RMS of those samples at the final pose, m. Samples outside the final
  /// (tightened) gate do not count: read it together with num_correspondences.
  double rms_error_m = 0.0;
};

/// Samples of a polyline every spacing_m of arc length from its first vertex, both end vertices
/// included, and at least one sample on every segment: a segment that no regular sample falls on
/// gets its midpoint (the last segment always holds the end vertex). Zero-length segments carry
/// no direction and get no extra sample. A one-vertex polyline (or one whose vertices all
/// coincide) yields one sample, an empty one none. Samples are in arc-length order.
/// Throws std::invalid_argument unless spacing_m is finite and > 0, the vertices are finite and
/// the polyline would yield at most 10^7 samples.
std::vector<Point2> SamplePolyline(const Polyline& polyline, double spacing_m);

/// ICP restricted to matched shapes (§5.1), from T_map_scan_init. Pairs without samples or
/// without model vertices, or with weight 0, are ignored; no usable pair gives the initial pose
/// with converged = false. Throws std::invalid_argument on invalid params, a negative or
/// non-finite weight, or non-finite coordinates.
AlignmentResult AlignShapes(const std::vector<ShapePair>& pairs, const Pose2& T_map_scan_init,
                            const AlignmentParams& params = {});

}  // namespace shape_slam
