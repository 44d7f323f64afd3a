#include "shape_slam/internal/model_icp.h"

#include <algorithm>

#include "shape_slam/evaluation.h"

namespace shape_slam::internal {

ModelIcp::ModelIcp(const std::vector<Polyline>& model, double capture_m, double inlier_m)
    : capture_grid_(MakeModelSegments(model), capture_m),
      inlier_grid_(MakeModelSegments(model), inlier_m),
      capture_m_(capture_m) {}

Pose2 ModelIcp::Align(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan,
                      int iterations) const {
  Pose2 T = T_model_scan;
  std::vector<Point2> from, to;
  from.reserve(samples_scan.size());
  to.reserve(samples_scan.size());
  for (int k = 0; k < iterations; ++k) {
    const double gate = capture_m_ * (1.0 - 0.6 * k / std::max(1, iterations - 1));
    from.clear();
    to.clear();
    const PointTransform transform(T);
    for (const Point2& p : samples_scan) {
      const SegmentMatch m = capture_grid_.Nearest(transform(p));
      if (m.segment < 0 || m.beyond_end || m.squared_distance > gate * gate) continue;
      from.push_back(p);
      to.push_back(m.point);
    }
    if (from.size() < 3) break;
    T = BestRigidAlignment(from, to);
  }
  return T;
}

double ModelIcp::InlierRatio(const std::vector<Point2>& samples_scan,
                             const Pose2& T_model_scan) const {
  if (samples_scan.empty()) return 0.0;
  int inliers = 0;
  const PointTransform transform(T_model_scan);
  for (const Point2& p : samples_scan) {
    inliers += inlier_grid_.Nearest(transform(p)).segment >= 0 ? 1 : 0;
  }
  return static_cast<double>(inliers) / samples_scan.size();
}

}  // namespace shape_slam::internal
