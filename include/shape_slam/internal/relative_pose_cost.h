// Internal (not installed): the residual of a pose-graph edge in 2D -- the measured relative
// pose T_i_j against the one the two node estimates imply -- for pose_graph.cpp.
#pragma once

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>
#include <cmath>

#include "shape_slam/types.h"

namespace shape_slam::internal {

/// r = S * (R_i^T (t_j - t_i) - t_ij, wrap(theta_j - theta_i - theta_ij)), with S^T S the
/// edge's information matrix: the error of the implied relative pose in the frame of node i.
/// Parameters: pose_i, pose_j = {x (m), y (m), theta (rad)}.
class RelativePoseCost {
 public:
  static constexpr int kNumResiduals = 3;

  static ceres::CostFunction* Create(const Pose2& T_i_j, const Eigen::Matrix3d& sqrt_information) {
    return new ceres::AutoDiffCostFunction<RelativePoseCost, kNumResiduals, 3, 3>(
        new RelativePoseCost(T_i_j, sqrt_information));
  }

  template <typename T>
  bool operator()(const T* const pose_i, const T* const pose_j, T* residual) const {
    using std::atan2;
    using std::cos;
    using std::sin;
    const T c = cos(pose_i[2]), s = sin(pose_i[2]);
    const T dx = pose_j[0] - pose_i[0], dy = pose_j[1] - pose_i[1];
    const T dtheta = pose_j[2] - pose_i[2] - T(T_i_j_.theta);
    const Eigen::Matrix<T, 3, 1> error(c * dx + s * dy - T(T_i_j_.x), -s * dx + c * dy - T(T_i_j_.y),
                                       atan2(sin(dtheta), cos(dtheta)));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> r(residual);
    r = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  RelativePoseCost(const Pose2& T_i_j, const Eigen::Matrix3d& sqrt_information)
      : T_i_j_(T_i_j), sqrt_information_(sqrt_information) {}

  Pose2 T_i_j_;
  Eigen::Matrix3d sqrt_information_;
};

}  // namespace shape_slam::internal
