// Internal (not installed): the residual of one scan sample against one model segment, for the
// Ceres refinement of the alignment (alignment_refinement.h).
#pragma once

#include <ceres/sized_cost_function.h>

#include <cmath>

#include "shape_slam/types.h"

namespace shape_slam::internal {

/// Distance of a scan sample, moved into the map frame by the pose (x, y, theta), to a model
/// segment [a, b], as a 2-vector in the segment's frame divided by the sample noise sigma:
///   r = (perpendicular offset from the segment's line, excess along the line beyond the
///        nearer end (0 between the ends)) / sigma.
/// Between the ends |r| is the distance to the line; beyond them it is the distance to the end
/// point, so a short segment cannot attract far points. The residual is continuous everywhere
/// and smooth except where the projection crosses an end, where only the along-line component
/// switches on (its Jacobian jumps from 0 to the line direction): Gauss-Newton and autodiff
/// handle that kink without trouble, unlike a scalar distance whose square root is singular on
/// the segment. A segment with a == b is a point (r = (q - a) / sigma in an arbitrary frame).
/// Parameters: pose = {x (m), y (m), theta (rad)} of T_map_scan.
/// The Jacobian is analytic (one cost per sample and per solve: autodiff's jets and its two
/// allocations per cost were a measurable part of every refinement).
class PointToSegmentCost final : public ceres::SizedCostFunction<2, 3> {
 public:
  static constexpr int kNumResiduals = 2;

  PointToSegmentCost(const Point2& sample_scan, const Point2& a_map, const Point2& b_map,
                     double sigma_m)
      : sample_(sample_scan),
        a_(a_map),
        length_((b_map - a_map).norm()),
        inv_sigma_(1.0 / sigma_m) {
    direction_ = length_ > 0.0 ? Point2((b_map - a_map) / length_) : Point2(1.0, 0.0);
  }

  /// A new cost (the caller or the ceres::Problem owns it).
  static ceres::CostFunction* Create(const Point2& sample_scan, const Point2& a_map,
                                     const Point2& b_map, double sigma_m) {
    return new PointToSegmentCost(sample_scan, a_map, b_map, sigma_m);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* pose = parameters[0];
    const double c = std::cos(pose[2]), s = std::sin(pose[2]);
    // The sample rotated into the map frame, and relative to a once shifted.
    const double rx = c * sample_.x() - s * sample_.y(), ry = s * sample_.x() + c * sample_.y();
    const double dx = rx + pose[0] - a_.x(), dy = ry + pose[1] - a_.y();
    const double ux = direction_.x(), uy = direction_.y();
    const double along = dx * ux + dy * uy;
    const double across = dy * ux - dx * uy;
    const bool before = along < 0.0, after = along > length_;
    const double excess = before ? along : (after ? along - length_ : 0.0);
    residuals[0] = across * inv_sigma_;
    residuals[1] = excess * inv_sigma_;
    if (jacobians == nullptr || jacobians[0] == nullptr) return true;
    // d(rotated sample)/d(theta) = (-ry, rx).
    double* J = jacobians[0];  // row-major 2 x 3
    J[0] = -uy * inv_sigma_;
    J[1] = ux * inv_sigma_;
    J[2] = (rx * ux + ry * uy) * inv_sigma_;
    const double on = before || after ? inv_sigma_ : 0.0;
    J[3] = ux * on;
    J[4] = uy * on;
    J[5] = (-ry * ux + rx * uy) * on;
    return true;
  }

 private:
  Point2 sample_;     // scan frame, m
  Point2 a_;          // map frame, m
  Point2 direction_;  // unit vector from a to b (x axis for a point)
  double length_;     // |b - a|, m
  double inv_sigma_;  // 1/m
};

}  // namespace shape_slam::internal
