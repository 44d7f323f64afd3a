// Internal (not installed): a Gaussian prior on a 2D pose (x, y, theta), for the Ceres
// refinement of the alignment (alignment_refinement.h).
#pragma once

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <cmath>

#include "shape_slam/types.h"

namespace shape_slam::internal {

/// r = S * (x - x_prior, y - y_prior, wrap(theta - theta_prior)), with S the square root of the
/// prior's information (S^T S = covariance^-1), so that |r|^2 is the Mahalanobis distance. The
/// angle difference is wrapped through atan2(sin, cos), smooth with unit derivative.
/// Parameters: pose = {x (m), y (m), theta (rad)}.
class PosePriorCost {
 public:
  static constexpr int kNumResiduals = 3;

  /// sqrt_information: upper-triangular or full 3x3, units 1/m (x, y) and 1/rad (theta).
  static ceres::CostFunction* Create(const Pose2& prior, const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PosePriorCost, kNumResiduals, 3>(
        new PosePriorCost(prior, sqrt_information));
  }

  template <typename T>
  bool operator()(const T* const pose, T* residual) const {
    using std::atan2;
    using std::cos;
    using std::sin;
    const T dtheta = pose[2] - T(prior_.theta);
    const Eigen::Matrix<T, 3, 1> error(pose[0] - T(prior_.x), pose[1] - T(prior_.y),
                                       atan2(sin(dtheta), cos(dtheta)));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  PosePriorCost(const Pose2& prior, const Eigen::Matrix3d& sqrt_information)
      : prior_(prior), sqrt_information_(sqrt_information) {}

  Pose2 prior_;
  Eigen::Matrix3d sqrt_information_;
};

}  // namespace shape_slam::internal
