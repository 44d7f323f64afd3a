// Internal (not installed): the residual of one scan sample against one model segment, for the
// Ceres refinement of the alignment (alignment_refinement.h).
#pragma once

#include <ceres/autodiff_cost_function.h>

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
class PointToSegmentCost {
 public:
  static constexpr int kNumResiduals = 2;

  static ceres::CostFunction* Create(const Point2& sample_scan, const Point2& a_map,
                                     const Point2& b_map, double sigma_m) {
    return new ceres::AutoDiffCostFunction<PointToSegmentCost, kNumResiduals, 3>(
        new PointToSegmentCost(sample_scan, a_map, b_map, sigma_m));
  }

  template <typename T>
  bool operator()(const T* const pose, T* residual) const {
    using std::cos;
    using std::sin;
    const T c = cos(pose[2]), s = sin(pose[2]);
    // The sample in the map frame, relative to a.
    const T dx = c * sample_.x() - s * sample_.y() + pose[0] - a_.x();
    const T dy = s * sample_.x() + c * sample_.y() + pose[1] - a_.y();
    const T along = dx * direction_.x() + dy * direction_.y();
    const T across = dy * direction_.x() - dx * direction_.y();
    T excess = T(0.0);
    if (along < T(0.0)) {
      excess = along;
    } else if (along > T(length_)) {
      excess = along - T(length_);
    }
    residual[0] = across * inv_sigma_;
    residual[1] = excess * inv_sigma_;
    return true;
  }

 private:
  PointToSegmentCost(const Point2& sample_scan, const Point2& a_map, const Point2& b_map,
                     double sigma_m)
      : sample_(sample_scan),
        a_(a_map),
        length_((b_map - a_map).norm()),
        inv_sigma_(1.0 / sigma_m) {
    direction_ = length_ > 0.0 ? Point2((b_map - a_map) / length_) : Point2(1.0, 0.0);
  }

  Point2 sample_;     // scan frame, m
  Point2 a_;          // map frame, m
  Point2 direction_;  // unit vector from a to b (x axis for a point)
  double length_;     // |b - a|, m
  double inv_sigma_;  // 1/m
};

}  // namespace shape_slam::internal
