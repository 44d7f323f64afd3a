// Odometry as a prior (not in the paper, which leaves odometry aside): its noise model, the
// covariance it gives an odometry increment, and the learning of that model from the log
// itself. A log's odometry may be far better than the configured model (the prior is then too
// weak to hold the scans along a featureless corridor) or far worse (a good scan match is then
// beyond the prior's gate); the corrections that trusted scan registrations make to the
// odometry's predictions say which.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

/// Odometry noise model, giving the covariance of the prior on each scan's pose: the standard
/// deviation grows with the distance travelled and the angle turned since the last scan.
struct OdometryNoiseParams {
  double sigma_xy_m = 0.05;                ///< floor, metres
  double sigma_xy_per_m = 0.20;            ///< metres per metre travelled
  double sigma_theta_rad = 0.10;           ///< floor, radians
  double sigma_theta_per_rad = 0.50;       ///< radians per radian turned
  double sigma_theta_per_m = 0.05;         ///< radians per metre travelled
  /// Learn the log's odometry noise (OdometryNoiseLearner): the sigmas above are scaled, the
  /// translation ones and the rotation ones each by one factor in [learn_min_scale,
  /// learn_max_scale], once learn_min_samples trusted registrations are in.
  bool learn = false;
  int learn_window = 100;       ///< the last this many registrations count
  int learn_min_samples = 20;
  double learn_min_scale = 0.25;
  double learn_max_scale = 4.0;
  /// The odometry prior's tail (PosePrior::loss_sigmas): 0 Gaussian; > 0 a Cauchy loss of this
  /// many standard deviations, so that a glitch or a poor odometry bends a clear scan match
  /// little (issue 22). Off by default while measured: docs/design.md, "Odometry as a prior".
  double loss_sigmas = 0.0;
  void Validate() const;
};

/// Covariance of an odometry increment T_prev_cur (x, y, theta) under the noise model.
Eigen::Matrix3d OdometryCovariance(const Pose2& delta, const OdometryNoiseParams& noise);

/// The noise model scaled to the log: each trusted registration's correction of the odometry
/// prediction, normalised by the configured model's sigmas, is one sample; the scale of the
/// translation (rotation) sigmas is the one that makes the median of the last learn_window
/// squared normalised corrections that of a chi-square with two (one) degrees of freedom.
/// Medians: a glitch or a wrong match among them moves nothing.
class OdometryNoiseLearner {
 public:
  explicit OdometryNoiseLearner(const OdometryNoiseParams& configured);
  /// One registration: the odometry increment and the correction T_pred_estimate it needed.
  void Add(const Pose2& odometry_delta, const Pose2& correction);
  /// The configured model, scaled once enough samples are in (unscaled when learn is false).
  const OdometryNoiseParams& Current() const { return current_; }
  double TranslationScale() const { return scale_xy_; }
  double RotationScale() const { return scale_theta_; }

 private:
  OdometryNoiseParams configured_, current_;
  std::vector<double> xy2_, theta2_;  // ring buffers of squared normalised corrections
  int next_ = 0;
  double scale_xy_ = 1.0, scale_theta_ = 1.0;
};

}  // namespace shape_slam
