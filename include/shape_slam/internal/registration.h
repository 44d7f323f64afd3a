// Internal (not installed): registering a scan against a model (RegisterCandidates, one
// RegistrationResult) and its building blocks, shared by every stage that does it -- per-scan
// tracking (internal/localization.h), loop closure (loop_closure.h), scan-to-scan matching
// (scan_matcher.h) and the localizer (localizer.h, through the per-scan tracking).
// The scan enters as samples of its alignment polylines (§5.1, 10 cm apart), the model as
// polylines; nothing here knows the mapper, so these stages include this header, not
// pipeline.h.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "shape_slam/alignment_refinement.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/internal/model_icp.h"
#include "shape_slam/internal/model_segments.h"
#include "shape_slam/types.h"

namespace shape_slam::internal {

/// What a registration of a scan against a model found: the one result every stage reads
/// (tracking, loop closure, `match`, the localizer).
struct RegistrationResult {
  Pose2 T_model_scan;  ///< the scan's pose in the model frame (the start when not converged)
  /// Covariance of (x, y, theta) of T_model_scan (RefinementResult::covariance).
  Eigen::Matrix3d covariance = kUnconstrainedVariance * Eigen::Matrix3d::Identity();
  double fit = 0.0;  ///< scan -> model: fraction of the scan's samples within inlier distance
  /// model -> scan: fraction of the model's samples the scan explains, when the stage measures
  /// it (loop closure's verification); -1 otherwise.
  double reverse_fit = -1.0;
  bool converged = false;  ///< a candidate's refinement was accepted
  int candidate = -1;      ///< which candidate won: its index in the candidates given
  double rms_error_m = 0.0;
  int iterations = 0;      ///< outer iterations of the winning refinement
};

/// A refined candidate (and the candidate it came from) as a RegistrationResult, with its fit.
RegistrationResult ToResult(const RankedCandidate& candidate, const RefinementResult& refined,
                            double fit);

/// The registration shared by every stage: each candidate pose finished by the selector's
/// quick ICP and ranked (candidate_selection.h: best fit, then nearest `reference` among equal
/// fits; candidates that `accept` refuses are dropped), then refined in that order, at most
/// max_refinements of them, by `refine`, which returns nullopt when the stage's own checks
/// (prior, gates, convergence) refuse the estimate. The first accepted one wins; converged is
/// false when none is.
RegistrationResult RegisterCandidates(
    const std::vector<Point2>& samples, const CandidateSelector& selector,
    const std::vector<Pose2>& candidates, const Pose2& reference, int max_refinements,
    const std::function<std::optional<RefinementResult>(const RankedCandidate&)>& refine,
    const std::function<bool(const Pose2&)>& accept = nullptr);

/// Samples of the alignment polylines every spacing_m (§5.1).
std::vector<Point2> AlignmentSamples(const std::vector<Polyline>& fine, double spacing_m);

/// Every k-th sample, k = to_m / from_m: samples spaced from_m apart thinned to about to_m.
std::vector<Point2> Thinned(const std::vector<Point2>& samples, double from_m, double to_m);

/// Refines an estimate against every model polyline: with a wide gate first (coarse_gate_m, for
/// odometry-size errors), then with the configured one.
RefinementResult RefineAgainstMap(const std::vector<Point2>& samples,
                                  const std::vector<Polyline>& model, const Pose2& init,
                                  const std::optional<PosePrior>& prior,
                                  const RefinementParams& refinement, double coarse_gate_m);

/// How far ModelIcp::KnownInlierRatio must look past a model wall's open end for
/// WidenedAlongRidge's shifts of up to max_shift_m: samples a shift carries past the end of a
/// wall are unknown space, not misfits.
inline double RidgeOpenEndM(double max_shift_m) { return 1.5 * max_shift_m; }

/// A registration's covariance widened along a ridge of fits (not in the paper). Shifted from
/// T_model_scan along the direction its covariance constrains least, by max_shift_m / 2 or
/// max_shift_m either way, the scan may still fit the model over known space
/// (model.KnownInlierRatio; `model` built with open_end_m = RidgeOpenEndM(max_shift_m)) within
/// fit_margin of its fit at T_model_scan: along a featureless stretch of corridor the
/// registration cannot tell those positions apart (and the overlap of the two views pulls it
/// short). The standard deviation along that direction then becomes at least the largest such
/// shift. The covariance is returned as it is otherwise, or when max_shift_m is 0.
Eigen::Matrix3d WidenedAlongRidge(const std::vector<Point2>& samples, const ModelIcp& model,
                                  const Pose2& T_model_scan, const Eigen::Matrix3d& covariance,
                                  double max_shift_m, double fit_margin);

/// How far the samples move between two poses of the scan: the median over the samples, metres
/// (0 without samples).
double MedianShift(const std::vector<Point2>& samples, const Pose2& from, const Pose2& to);

/// Whether a refinement (alignment_refinement.h) from `start` stayed a refinement. Each of its
/// outer rounds associates the samples within the gate (max_correspondence_distance_m), so a
/// result that moved the scan's median sample farther than all rounds together could have
/// (outer_iterations times the gate) did not follow its associations: with few of them, in a
/// corner, the solver can turn the scan by tens of degrees. Measured on the mapper's
/// scan-to-scan edges (ShapeSlam's consecutive keyframes; notebook, 2026-12-07): right
/// corrections moved the median sample at most 0.32 m; two jumps, in corners of a 120-degree
/// scan, 3.2 m (75 deg, which then bent a whole map) and 4.5 m (118 deg).
bool RefinementStayedNear(const std::vector<Point2>& samples, const Pose2& start,
                          const Pose2& refined, const RefinementParams& params);

/// Fraction of the samples within the grid's radius of the model at an estimate.
double InlierRatio(const std::vector<Point2>& samples, const SegmentGrid& grid,
                   const Pose2& T_model_scan);

}  // namespace shape_slam::internal
