// Internal (not installed): the localization step of the pipeline (pipeline.h) -- the scan's
// shapes, the local model it is matched against, and the choice among the candidate estimates
// that shape matching (§4.2, §4.3) and the prediction provide -- shared by pipeline.cpp (the
// per-scan step), localizer.cpp and their tests. The registration blocks it is made of
// (internal/registration.h) are shared more widely.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "shape_slam/internal/model_segments.h"
#include "shape_slam/internal/registration.h"
#include "shape_slam/pipeline.h"

namespace shape_slam::internal {

using Shapes = ScanShapes;

/// What a scan is localized against, in the sensor frame of the prediction.
struct LocalModel {
  /// Visible map shape, CCW ordered. Localize derives the shape-matching view of it
  /// (ForShapeMatching) only if shape matching runs (not for a scan the fast track places).
  std::vector<Polyline> map;
  bool map_cyclic = false;
  std::vector<Polyline> recent_coarse;  ///< last keyframe's polylines (shape matching)
  std::vector<Polyline> recent_fine;    ///< the same, finer (refinement)
};

/// The estimated correction T_pred_sensor (sensor frame at the prediction -> at the estimate).
struct Localization {
  Pose2 correction;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool trusted = false;
  int matched_pairs = 0;
  double inlier_ratio = 0.0;
  double rms_error_m = 0.0;
  /// Fraction of the scan within new_territory_distance_m of the model; computed only for a scan
  /// without a trusted match (0 otherwise), the only case that reads it.
  double coverage = 0.0;
  /// Without a trusted match: the correction of the best candidate a refinement reached, before
  /// `correction` falls back to the prediction (none converged: empty).
  std::optional<Pose2> best_untrusted;
  bool fast_track = false;  ///< taken from the prediction without shape matching
  bool odometry_overridden = false;  ///< matched without the odometry, which it contradicts
};

/// The visibility of the model a scan is matched against from a predicted sensor pose
/// (VisibilityForScan). `no_estimate`: the prediction is only the last pose (no odometry, §4.3),
/// so the model is seen all around, and max_motion_per_scan_m farther than the scan reaches: a
/// robot that drove that far towards a wall since the last scan sees it at the scan's farthest
/// reading, that much beyond it from the last pose.
VisibilityParams ModelVisibility(const LaserScan& scan, bool no_estimate,
                                 const ShapeSlamParams& params);

/// The registration model of a map's visible shape (§3), as PolylineMap::Visible gives it with
/// `visibility`: its polylines in the sensor frame of the prediction, cyclic when seen all around.
LocalModel VisibleModel(const std::vector<VisiblePolyline>& visible,
                        const VisibilityParams& visibility);

/// Candidates from shape matching against the map and against the last keyframe, the
/// prediction and (without odometry) the window search, ranked by the candidate selection and
/// refined in that order. `lost_scans`: consecutive scans before this one that found no trusted
/// match; without odometry the motion bound, the prior and the window grow with it.
Localization Localize(const Shapes& shapes, const LocalModel& model,
                      const std::optional<Pose2>& odometry_delta,
                      const std::optional<Pose2>& velocity_hint, int lost_scans,
                      const ShapeSlamParams& params);

/// The keyframe track (ShapeSlamParams::keyframe_track): the fast track of the odometry
/// prediction against the last keyframe's alignment polylines alone (in the sensor frame of the
/// prediction). fast_track is false, and nothing else set, when it falls short.
Localization TrackKeyframe(const Shapes& shapes, const std::vector<Polyline>& keyframe_fine,
                           const Pose2& odometry_delta, const ShapeSlamParams& params);

}  // namespace shape_slam::internal
