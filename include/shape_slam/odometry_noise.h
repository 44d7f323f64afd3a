// Odometry as a prior (not in the paper, which leaves odometry aside): its noise model, the
// covariance it gives an odometry increment, and the learning of that model from the log
// itself. A log's odometry may be far better than the configured model (the prior is then too
// weak to hold the scans along a featureless corridor) or far worse (a good scan match is then
// beyond the prior's gate); the corrections that trusted scan registrations make to the
// odometry's predictions say which.
#pragma once

#include <Eigen/Core>
#include <optional>
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
  /// A registration teaches the learner only where the scan alone fixes the pose to this
  /// standard deviation (metres in every direction, radians): along a featureless corridor
  /// the scan says nothing about the odometry. See ScanOwnCorrection.
  double learn_max_scan_sigma_m = 0.05;
  double learn_max_scan_sigma_rad = 0.05;
  /// The odometry prior's tail (PosePrior::loss_sigmas): 0 Gaussian; > 0 a Cauchy loss of this
  /// many standard deviations, so that a glitch or a poor odometry bends a clear scan match
  /// little (issue 22). Off by default while measured: docs/design.md, "Odometry as a prior".
  double loss_sigmas = 0.0;
  void Validate() const;
};

/// The odometry's systematic heading error, learned from the log (not in the paper). A wheel-base
/// error turns every increment by a share of its turn, unequal wheel radii by an angle per metre
/// travelled; either bends a whole trajectory. The trusted registrations' heading corrections
/// of the odometry's predictions measure both, and the next increments are corrected by them.
struct OdometryCalibrationParams {
  bool enabled = true;    ///< read by the mapper and the localizer
  int window = 300;       ///< the last this many registrations count
  int min_samples = 30;   ///< no correction before this many are in
  /// A coefficient t of its standard errors from zero is applied shrunk by (1 - (min_t/t)^2),
  /// not at all within min_t: a log with good odometry, or with large random errors, keeps its
  /// increments as they are.
  double min_t = 4.0;
  double max_per_m = 0.1;    ///< radians per metre travelled, at most (either sign)
  double max_per_rad = 0.2;  ///< radians per radian turned, at most (either sign)
  void Validate() const;
};

/// Learns the heading error model e = per_rad * turn + per_m * distance of the raw odometry
/// increments by robust least squares (Huber weights, scale from the median absolute residual)
/// over the last `window` samples, and corrects the increments by it.
class OdometryCalibrator {
 public:
  explicit OdometryCalibrator(const OdometryCalibrationParams& params);
  /// The raw increment T_prev_cur with the learned heading error added.
  Pose2 Correct(const Pose2& odometry_delta) const;
  /// One registration: the raw increment, and the heading the robot turned beyond it (the
  /// scan's own correction plus what Correct added).
  void Add(const Pose2& odometry_delta, double heading_error_rad);
  /// One registration of a scan predicted by Correct(raw_delta) = `corrected_delta`: the heading
  /// error is the scan's own correction (ScanOwnCorrection) plus what Correct added.
  void AddRegistration(const Pose2& raw_delta, const Pose2& corrected_delta,
                       const Pose2& scan_own_correction) {
    Add(raw_delta, corrected_delta.theta - raw_delta.theta + scan_own_correction.theta);
  }
  double HeadingPerMetre() const { return per_m_; }
  double HeadingPerRadian() const { return per_rad_; }

 private:
  void Fit();
  OdometryCalibrationParams params_;
  std::vector<Eigen::Vector3d> samples_;  // ring buffer of (distance, turn, heading error)
  int next_ = 0;
  double per_m_ = 0.0, per_rad_ = 0.0;
};

/// Covariance of an odometry increment T_prev_cur (x, y, theta) under the noise model.
Eigen::Matrix3d OdometryCovariance(const Pose2& delta, const OdometryNoiseParams& noise);

/// The correction the scan alone would make to the odometry prediction, from the registration
/// that fused it with the prior: with the scan's information I_s = C^-1 - P^-1 (C the fused
/// covariance, P the prior's, Gaussian model, prior mean the prediction) the fused correction is
/// x = C I_s x_s, so x_s = I_s^-1 C^-1 x. The learner must see x_s, not x: the prior pulls x
/// towards the prediction by I_s / (I_s + P^-1), a learner fed x learns a smaller noise, which
/// pulls the next x closer still, and the learned noise collapses to learn_min_scale whenever
/// the odometry is not several times worse than the scan (measured on infinite-corridor:
/// the scale fell to the floor whatever the floor). nullopt where the scan alone leaves a
/// direction looser than max_sigma_m / max_sigma_rad, or the covariances are not usable.
std::optional<Pose2> ScanOwnCorrection(const Pose2& fused_correction,
                                       const Eigen::Matrix3d& fused_covariance,
                                       const Eigen::Matrix3d& prior_covariance, double max_sigma_m,
                                       double max_sigma_rad);

/// ScanOwnCorrection of a registration whose prior was the odometry increment `odometry_delta`
/// under `noise` (OdometryCovariance), within noise.learn_max_scan_sigma_*.
std::optional<Pose2> ScanOwnCorrection(const Pose2& fused_correction,
                                       const Eigen::Matrix3d& fused_covariance,
                                       const Pose2& odometry_delta,
                                       const OdometryNoiseParams& noise);

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

/// Odometry edges in the pose graph (issue 22's "odometry as a robust prior", Cartographer's
/// odometry constraints; not in the paper): between consecutive keyframes that both have fresh
/// odometry, the odometry's increment beside the scan-to-scan edge, mostly for its heading. A
/// long corridor holds the scans' heading poorly (infinite-corridor's tracking drifts 1.3 deg
/// per 10 scans, its wheels 0.4: docs/notebook.md, 2026-12-07), and the closures of a large
/// loop then disagree by more than they may. The noise is learned from the log (OdometryEdgeNoise);
/// a Cauchy loss keeps a glitch from bending the graph.
struct OdometryEdgeParams {
  bool enabled = true;
  /// The learned variances are multiplied by this: the differences it learns from hold the
  /// scan edges' noise too, and the edges are correlated with the tracking that used the
  /// odometry as its prior. Measured (notebook, 2026-12-08): 4 held infinite-corridor best but
  /// cost aces and its variants 4-7 mm; 16 costs them nothing measurable.
  double variance_scale = 16.0;
  /// The position variance is this many times the learned one: the heading is what the wheels
  /// add (their position cost aces 0.5-2.5 cm of ATE; notebook, 2026-12-07 night).
  double position_variance_factor = 100.0;
  double loss_sigmas = 3.0;   ///< Cauchy loss scale, standard deviations
  int window = 300;           ///< the last this many keyframe steps count
  int min_samples = 30;       ///< no edge before this many are in
  /// A step turning less than this is straight (its variance per metre), else turning (per
  /// radian); with fewer than min_group of either kind, both rates come from all steps.
  double straight_below_rad = 0.1;
  int min_group = 10;
  double distance_floor_m = 0.05;  ///< added to each step's length: a step on the spot
  void Validate() const;
};

/// The noise of the odometry's keyframe-to-keyframe increments, learned from the keyframe steps
/// that scans matched: the squared difference between the odometry's step and the scan edge's,
/// in heading and in position, over the step's length (straight steps) or its turn (turning
/// ones); the medians of the last `window`, converted to variances as those of chi-square
/// variables with one (heading) and two (position) degrees of freedom. Medians: a glitch or a
/// wrong match among them moves nothing.
class OdometryEdgeNoise {
 public:
  explicit OdometryEdgeNoise(const OdometryEdgeParams& params);
  /// One matched keyframe step: the odometry's increment and the scan edge's relative pose.
  void Add(const Pose2& odometry_step, const Pose2& scan_step);
  /// The covariance of an odometry increment between keyframes (x, y, theta), once min_samples
  /// steps are in (else none). Samples() counts the steps kept (at most `window`).
  std::optional<Eigen::Matrix3d> Covariance(const Pose2& odometry_step) const;
  int Samples() const { return static_cast<int>(samples_.size()); }

 private:
  struct Sample {
    double distance_m, turn_rad, theta2, xy2;
  };
  OdometryEdgeParams params_;
  std::vector<Sample> samples_;  // the last `window`, in order
};

/// Odometry that has not moved since the first scan is no odometry (logs without any carry
/// zeros). Moved is false until a pose differs from the first one seen beyond rounding, then
/// true for good.
class OdometryMotionCheck {
 public:
  bool Moved(const Pose2& T_odom_robot);

 private:
  std::optional<Pose2> first_;
  bool moved_ = false;
};

/// Odometry that stalled for a scan (ShapeSlamParams::stale_odometry_min_step_m): its pose is
/// the last scan's to the bit while the robot's longest recent step reached min_step_m (a
/// message late, or published less often than the scans; a robot at rest is not stalled).
bool OdometryStalled(const Pose2& T_odom_robot, const Pose2& last_T_odom_robot,
                     double longest_recent_step_m, double min_step_m);

}  // namespace shape_slam
