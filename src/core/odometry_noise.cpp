#include "shape_slam/odometry_noise.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "shape_slam/internal/median.h"
#include "shape_slam/internal/validation.h"

namespace shape_slam {
namespace {

// Medians of the chi-square distribution with one and two degrees of freedom.
constexpr double kChi2Median1 = 0.454936;
constexpr double kChi2Median2 = 1.386294;

double Median(std::vector<double> values) { return internal::MedianInPlace(values); }

}  // namespace

void OdometryNoiseParams::Validate() const {
  internal::Positive(sigma_xy_m, "OdometryNoiseParams::sigma_xy_m");
  internal::Positive(sigma_theta_rad, "OdometryNoiseParams::sigma_theta_rad");
  internal::NonNegative(sigma_xy_per_m, "OdometryNoiseParams::sigma_xy_per_m");
  internal::NonNegative(sigma_theta_per_rad, "OdometryNoiseParams::sigma_theta_per_rad");
  internal::NonNegative(sigma_theta_per_m, "OdometryNoiseParams::sigma_theta_per_m");
  if (learn_window < 1 || learn_min_samples < 1 || learn_min_samples > learn_window) {
    throw std::invalid_argument(
        "OdometryNoiseParams::learn_window and learn_min_samples must be >= 1, "
        "learn_min_samples <= learn_window");
  }
  internal::Positive(learn_min_scale, "OdometryNoiseParams::learn_min_scale");
  if (!(learn_max_scale >= learn_min_scale)) {
    throw std::invalid_argument("OdometryNoiseParams::learn_max_scale must be >= learn_min_scale");
  }
  internal::NonNegative(loss_sigmas, "OdometryNoiseParams::loss_sigmas");
  internal::Positive(learn_max_scan_sigma_m, "OdometryNoiseParams::learn_max_scan_sigma_m");
  internal::Positive(learn_max_scan_sigma_rad, "OdometryNoiseParams::learn_max_scan_sigma_rad");
}

std::optional<Pose2> ScanOwnCorrection(const Pose2& fused_correction,
                                       const Eigen::Matrix3d& fused_covariance,
                                       const Eigen::Matrix3d& prior_covariance, double max_sigma_m,
                                       double max_sigma_rad) {
  const Eigen::LLT<Eigen::Matrix3d> fused(fused_covariance);  // fails unless positive definite
  const Eigen::LLT<Eigen::Matrix3d> prior(prior_covariance);
  if (fused.info() != Eigen::Success || prior.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d scan_information = fused.solve(I) - prior.solve(I);
  scan_information = (0.5 * (scan_information + scan_information.transpose())).eval();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scan_information);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0.0)) return std::nullopt;
  const Eigen::Matrix3d scan_covariance = eig.eigenvectors() *
                                          eig.eigenvalues().cwiseInverse().asDiagonal() *
                                          eig.eigenvectors().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> xy(scan_covariance.topLeftCorner<2, 2>());
  if (!(std::sqrt(xy.eigenvalues().maxCoeff()) <= max_sigma_m) ||
      !(std::sqrt(scan_covariance(2, 2)) <= max_sigma_rad)) {
    return std::nullopt;
  }
  const Eigen::Vector3d x(fused_correction.x, fused_correction.y, fused_correction.theta);
  const Eigen::Vector3d own = scan_covariance * fused.solve(x);
  if (!own.allFinite()) return std::nullopt;
  return Pose2(own.x(), own.y(), own.z());
}

std::optional<Pose2> ScanOwnCorrection(const Pose2& fused_correction,
                                       const Eigen::Matrix3d& fused_covariance,
                                       const Pose2& odometry_delta,
                                       const OdometryNoiseParams& noise) {
  return ScanOwnCorrection(fused_correction, fused_covariance,
                           OdometryCovariance(odometry_delta, noise), noise.learn_max_scan_sigma_m,
                           noise.learn_max_scan_sigma_rad);
}

Eigen::Matrix3d OdometryCovariance(const Pose2& delta, const OdometryNoiseParams& noise) {
  const double distance = delta.Translation().norm();
  const double turn = std::abs(delta.theta);
  const double sxy = noise.sigma_xy_m + noise.sigma_xy_per_m * distance;
  const double sth =
      noise.sigma_theta_rad + noise.sigma_theta_per_rad * turn + noise.sigma_theta_per_m * distance;
  return Eigen::Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
}

OdometryNoiseLearner::OdometryNoiseLearner(const OdometryNoiseParams& configured)
    : configured_(configured), current_(configured) {}

void OdometryNoiseLearner::Add(const Pose2& odometry_delta, const Pose2& correction) {
  if (!configured_.learn) return;
  const Eigen::Matrix3d covariance = OdometryCovariance(odometry_delta, configured_);
  const double xy2 = correction.Translation().squaredNorm() / covariance(0, 0);
  const double theta2 = correction.theta * correction.theta / covariance(2, 2);
  if (static_cast<int>(xy2_.size()) < configured_.learn_window) {
    xy2_.push_back(xy2);
    theta2_.push_back(theta2);
  } else {
    xy2_[next_] = xy2;
    theta2_[next_] = theta2;
    next_ = (next_ + 1) % configured_.learn_window;
  }
  if (static_cast<int>(xy2_.size()) < configured_.learn_min_samples) return;
  const auto bounded = [&](double scale) {
    return std::clamp(scale, configured_.learn_min_scale, configured_.learn_max_scale);
  };
  scale_xy_ = bounded(std::sqrt(Median(xy2_) / kChi2Median2));
  scale_theta_ = bounded(std::sqrt(Median(theta2_) / kChi2Median1));
  current_ = configured_;
  current_.sigma_xy_m *= scale_xy_;
  current_.sigma_xy_per_m *= scale_xy_;
  current_.sigma_theta_rad *= scale_theta_;
  current_.sigma_theta_per_rad *= scale_theta_;
  current_.sigma_theta_per_m *= scale_theta_;
}

void OdometryCalibrationParams::Validate() const {
  if (window < 1 || min_samples < 2 || min_samples > window) {
    throw std::invalid_argument(
        "OdometryCalibrationParams::window must be >= 1, min_samples in [2, window]");
  }
  internal::NonNegative(min_t, "OdometryCalibrationParams::min_t");
  internal::NonNegative(max_per_m, "OdometryCalibrationParams::max_per_m");
  internal::NonNegative(max_per_rad, "OdometryCalibrationParams::max_per_rad");
}

OdometryCalibrator::OdometryCalibrator(const OdometryCalibrationParams& params)
    : params_(params) {}

Pose2 OdometryCalibrator::Correct(const Pose2& odometry_delta) const {
  const double error =
      per_rad_ * odometry_delta.theta + per_m_ * odometry_delta.Translation().norm();
  return Pose2(odometry_delta.x, odometry_delta.y, odometry_delta.theta + error);
}

void OdometryCalibrator::Add(const Pose2& odometry_delta, double heading_error_rad) {
  if (!params_.enabled || !std::isfinite(heading_error_rad)) return;
  const Eigen::Vector3d sample(odometry_delta.Translation().norm(), odometry_delta.theta,
                               heading_error_rad);
  if (static_cast<int>(samples_.size()) < params_.window) {
    samples_.push_back(sample);
  } else {
    samples_[next_] = sample;
    next_ = (next_ + 1) % params_.window;
  }
  if (static_cast<int>(samples_.size()) >= params_.min_samples) Fit();
}

// Iteratively reweighted least squares with Huber weights (k = 1.345 robust standard
// deviations): a glitch or a wrong match among the samples moves the fit little. A coefficient
// counts only when it stands min_t standard errors from zero (a regressor the log never
// exercises, such as turns for a robot that only drives straight, has a huge one).
void OdometryCalibrator::Fit() {
  constexpr double kHuber = 1.345;
  constexpr double kRidge = 1e-9;  // keeps the normal matrix invertible
  Eigen::Vector2d coef = Eigen::Vector2d::Zero();
  Eigen::Matrix2d normal;
  double scale = 0.0;
  std::vector<double> residuals(samples_.size());
  for (int iteration = 0; iteration < 5; ++iteration) {
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const Eigen::Vector3d& s = samples_[i];
      residuals[i] = std::abs(s.z() - coef.x() * s.x() - coef.y() * s.y());
    }
    scale = std::max(1.4826 * Median(residuals), 1e-6);
    normal = kRidge * Eigen::Matrix2d::Identity();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const Eigen::Vector2d x = samples_[i].head<2>();
      const double w = std::min(1.0, kHuber * scale / std::max(residuals[i], 1e-12));
      normal += w * x * x.transpose();
      rhs += w * samples_[i].z() * x;
    }
    coef = normal.inverse() * rhs;
  }
  const Eigen::Matrix2d covariance = scale * scale * normal.inverse();
  // Shrunk by (1 - (min_t / t)^2) (zero within min_t standard errors): a coefficient near the
  // threshold is applied in part, so that one sample more or less never switches a whole
  // correction on or off.
  const auto significant = [&](int i, double bound) {
    const double se = std::sqrt(std::max(covariance(i, i), 0.0));
    const double t = std::abs(coef[i]) / std::max(se, 1e-12);
    if (!(t > params_.min_t)) return 0.0;
    const double shrink = 1.0 - (params_.min_t / t) * (params_.min_t / t);
    return std::clamp(shrink * coef[i], -bound, bound);
  };
  per_m_ = significant(0, params_.max_per_m);
  per_rad_ = significant(1, params_.max_per_rad);
}

bool OdometryMotionCheck::Moved(const Pose2& T_odom_robot) {
  if (moved_) return true;
  if (!first_) first_ = T_odom_robot;
  const Pose2 moved = first_->Inverse() * T_odom_robot;
  constexpr double kUnchanged = 1e-9;  // metres, radians: the same pose up to rounding
  moved_ = moved.Translation().norm() > kUnchanged || std::abs(moved.theta) > kUnchanged;
  return moved_;
}

bool OdometryStalled(const Pose2& T_odom_robot, const Pose2& last_T_odom_robot,
                     double longest_recent_step_m, double min_step_m) {
  return T_odom_robot.x == last_T_odom_robot.x && T_odom_robot.y == last_T_odom_robot.y &&
         T_odom_robot.theta == last_T_odom_robot.theta && longest_recent_step_m >= min_step_m;
}

void OdometryEdgeParams::Validate() const {
  internal::NonNegative(variance_scale, "OdometryEdgeParams::variance_scale");
  internal::Positive(position_variance_factor, "OdometryEdgeParams::position_variance_factor");
  internal::NonNegative(loss_sigmas, "OdometryEdgeParams::loss_sigmas");
  internal::NonNegative(straight_below_rad, "OdometryEdgeParams::straight_below_rad");
  internal::Positive(distance_floor_m, "OdometryEdgeParams::distance_floor_m");
  if (window < 1 || min_samples < 1 || min_group < 1) {
    throw std::invalid_argument("OdometryEdgeParams: window, min_samples and min_group must be >= 1");
  }
  if (variance_scale == 0.0 && enabled) {
    throw std::invalid_argument("OdometryEdgeParams::variance_scale must be > 0 when enabled");
  }
}

OdometryEdgeNoise::OdometryEdgeNoise(const OdometryEdgeParams& params) : params_(params) {
  params_.Validate();
}

void OdometryEdgeNoise::Add(const Pose2& odometry_step, const Pose2& scan_step) {
  const Pose2 e = odometry_step.Inverse() * scan_step;
  samples_.push_back({odometry_step.Translation().norm(), std::abs(odometry_step.theta),
                      e.theta * e.theta, e.Translation().squaredNorm()});
  // Only the last `window` count: the older ones go (a long log's keyframes would pile up).
  if (samples_.size() > static_cast<std::size_t>(params_.window)) samples_.erase(samples_.begin());
}

std::optional<Eigen::Matrix3d> OdometryEdgeNoise::Covariance(const Pose2& odometry_step) const {
  if (Samples() < params_.min_samples) return std::nullopt;
  const double eps = params_.distance_floor_m;
  // Squared errors per metre (straight steps) and per radian (turning ones).
  std::vector<double> straight_theta, straight_xy, turning_theta, turning_xy;
  for (const Sample& q : samples_) {  // the last `window` (Add)
    if (q.turn_rad < params_.straight_below_rad) {
      straight_theta.push_back(q.theta2 / (q.distance_m + eps));
      straight_xy.push_back(q.xy2 / (q.distance_m + eps));
    } else {
      turning_theta.push_back(q.theta2 / q.turn_rad);
      turning_xy.push_back(q.xy2 / q.turn_rad);
    }
  }
  const std::size_t min_group = static_cast<std::size_t>(params_.min_group);
  if (straight_theta.size() < min_group) {  // too few straight steps: every step per metre
    straight_theta.clear();
    straight_xy.clear();
    for (const Sample& q : samples_) {
      straight_theta.push_back(q.theta2 / (q.distance_m + q.turn_rad + eps));
      straight_xy.push_back(q.xy2 / (q.distance_m + q.turn_rad + eps));
    }
  }
  const double scale = params_.variance_scale;
  const double theta_per_m = scale * internal::MedianInPlace(straight_theta) / kChi2Median1;
  const double xy_per_m = scale * internal::MedianInPlace(straight_xy) / kChi2Median2;
  const bool turning = turning_theta.size() >= min_group;
  const double theta_per_rad =
      turning ? scale * internal::MedianInPlace(turning_theta) / kChi2Median1 : theta_per_m;
  const double xy_per_rad = turning ? scale * internal::MedianInPlace(turning_xy) / kChi2Median2 : xy_per_m;
  const double d = odometry_step.Translation().norm(), turn = std::abs(odometry_step.theta);
  // Floors: 1 mrad and 5 mm, so that a log whose odometry and scans agree exactly (a
  // simulation) still gives a usable covariance.
  const double var_theta = std::max(theta_per_m * (d + eps) + theta_per_rad * turn, 1e-6);
  const double var_xy = params_.position_variance_factor *
                        std::max(xy_per_m * (d + eps) + xy_per_rad * turn, 2.5e-5);
  return Eigen::Vector3d(var_xy, var_xy, var_theta).asDiagonal().toDenseMatrix();
}

}  // namespace shape_slam
