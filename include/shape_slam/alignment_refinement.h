// Refinement of the alignment (after the restricted ICP of §5.1) by robust nonlinear least
// squares with Ceres: point-to-segment residuals of the scan samples against the model
// segments, an optional Gaussian prior on the pose (e.g. odometry), and the pose covariance.
//
// This goes beyond the paper, whose alignment is the ICP of §5.1 alone: the paper defers "the
// coupling with a state-of-the-art stochastic model" to future work (§7); a robust
// point-to-line fit with a covariance is that model's measurement.
//
// Each outer iteration associates every sample with the nearest segment within
// max_correspondence_distance_m (at the current pose) and runs a small Ceres solve; the loop
// stops after outer_iterations or when the association no longer changes.
//  * Residual (internal/point_to_segment_cost.h): the 2-vector distance of the sample to the
//    segment -- perpendicular to its line between the ends, to the end point beyond them --
//    divided by point_sigma_m. Samples whose nearest point lies beyond an open end of a model
//    polyline are not associated (reject_end_projections, as in alignment.h).
//  * Robust loss: Cauchy (default) or Huber on that distance, scale loss_scale_m.
//  * Prior: r = S (pose - prior), S^T S = covariance^-1 (internal/pose_prior_cost.h); Gaussian,
//    or heavy-tailed (PosePrior::loss_sigmas): a Cauchy loss on the part of r in the directions
//    the samples constrain better than the prior, Gaussian in the others; the loss's weight rho'
//    scales that part's information in the covariance.
//  * Covariance of (x, y, theta) [m^2, m*rad, rad^2]: the inverse of the Gauss-Newton
//    information J^T W J of the final problem at the solution (W: the robust loss's weights
//    rho'(s) of the samples; plus the prior's information), computed here from the residual
//    Jacobians rather than with ceres::Covariance: that takes about 50 us for 200 residuals
//    (DENSE_SVD) against about 10 us here, and on a rank-deficient problem (a corridor of
//    straight walls) it fails and logs an error through glog, which the library must not. It
//    assumes independent samples with standard deviation point_sigma_m, hence is optimistic when
//    the samples' errors are correlated (a polyline approximating a curved wall, or fine
//    polylines whose small kinks follow the range noise). Directions the
//    data do not constrain get the variance kUnconstrainedVariance (the information's
//    eigenvalues are floored at its inverse), so the result is always finite, symmetric and
//    positive definite.
//
// Speed: samples are associated through a uniform grid over the model segments (cells of
// max_correspondence_distance_m, at most 256 per side) in the unrestricted variant and by a
// linear scan over the pair's few segments in the restricted one; Ceres runs Levenberg-Marquardt
// with dense normal equations (3 parameters) on one thread, silently. About 1.3 us per residual
// (bench/alignment_bench.cc: 0.24 ms for 173 samples against 30 segments).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "shape_slam/alignment.h"
#include "shape_slam/types.h"

namespace shape_slam {

/// Variance (m^2 or rad^2) reported along directions the data and prior leave unconstrained.
inline constexpr double kUnconstrainedVariance = 1e6;

enum class RobustLoss {
  kHuber,   ///< quadratic up to loss_scale_m, linear beyond: convex, outliers keep some pull
  kCauchy,  ///< log(1 + (d / scale)^2): outliers' pull fades out; needs a good start (the ICP's)
};

struct RefinementParams {
  /// Scale of the robust loss, metres: samples farther than this from their segment count less.
  double loss_scale_m = 0.05;
  /// Shape of the robust loss.
  RobustLoss loss = RobustLoss::kCauchy;
  /// Standard deviation of a sample's distance to its wall (sensor noise plus polyline
  /// approximation), metres. Weighs the samples against the prior and scales the covariance.
  double point_sigma_m = 0.02;
  /// Gate of the association: a sample farther than this from every segment is not used, m.
  double max_correspondence_distance_m = 0.3;
  /// Largest number of association + solve rounds, >= 1.
  int outer_iterations = 3;
  /// Largest number of Levenberg-Marquardt iterations per Ceres solve, >= 1.
  int max_solver_iterations = 20;
  /// `converged` requires at least this many associated samples, >= 1.
  int min_correspondences = 10;
  /// Arc-length spacing of the samples of the perceived polylines (ShapePair overload), m.
  double sample_spacing_m = 0.10;
  /// Do not associate samples whose nearest point lies beyond an open end of a model polyline.
  bool reject_end_projections = true;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// A prior on T_map_scan: its mean and the 3x3 covariance of (x [m], y [m], theta [rad]),
/// symmetric positive definite.
struct PosePrior {
  Pose2 T_map_scan;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  /// 0: Gaussian. > 0: heavy-tailed in the directions the samples constrain better than the
  /// prior, a Cauchy loss of scale loss_sigmas standard deviations: within that distance the
  /// prior holds about as a Gaussian does, beyond it its pull fades (a prior far from the
  /// scan's evidence, e.g. an odometry glitch, bends the estimate little). In the directions
  /// the samples leave weaker than the prior (along a featureless corridor) it stays Gaussian.
  double loss_sigmas = 0.0;
};

struct RefinementResult {
  Pose2 T_map_scan;  ///< refined pose (the initial one when nothing was associated)
  /// Covariance of (x, y, theta) of T_map_scan: m^2, m*rad, rad^2 (see the file comment).
  Eigen::Matrix3d covariance = kUnconstrainedVariance * Eigen::Matrix3d::Identity();
  bool converged = false;    ///< Ceres reported convergence and enough correspondences
  int num_residuals = 0;     ///< samples associated in the last solve
  double rms_error_m = 0.0;  ///< RMS distance of those samples to their segments at the end
  int iterations = 0;        ///< outer iterations (association + Ceres solve) performed
};

/// Unrestricted refinement: every sample (scan frame) is associated with the nearest segment of
/// ANY of the model polylines (map frame) within the gate. Empty input gives the initial pose
/// with converged = false. Throws std::invalid_argument on invalid params, non-finite
/// coordinates, or a prior covariance that is not symmetric positive definite.
RefinementResult RefineAlignment(const std::vector<Point2>& samples_scan,
                                 const std::vector<Polyline>& model_map,
                                 const Pose2& T_map_scan_init,
                                 const std::optional<PosePrior>& prior,
                                 const RefinementParams& params = {});

/// Restricted variant: samples of each pair (SamplePolyline of its perceived polyline at
/// params.sample_spacing_m) only associate with that pair's model polylines, and the pair's
/// weight multiplies their (robustified) cost. Throws as above, and on a negative weight.
RefinementResult RefineAlignment(const std::vector<ShapePair>& pairs, const Pose2& T_map_scan_init,
                                 const std::optional<PosePrior>& prior,
                                 const RefinementParams& params = {});

}  // namespace shape_slam
