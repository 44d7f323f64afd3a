#include "shape_slam/internal/model_icp.h"

#include <algorithm>
#include <cmath>

#include "shape_slam/evaluation.h"

namespace shape_slam::internal {

ModelIcp::ModelIcp(const std::vector<Polyline>& model, double capture_m, double inlier_m,
                   double open_end_m)
    : ModelIcp(MakeModelSegments(model), capture_m, inlier_m, open_end_m) {}

ModelIcp::ModelIcp(const std::vector<ModelSegment>& segments, double capture_m, double inlier_m,
                   double open_end_m)
    : capture_grid_(segments, capture_m),
      inlier_grid_(segments, inlier_m),
      capture_m_(capture_m),
      inlier_m_(inlier_m) {
  if (open_end_m > 0.0) open_end_grid_.emplace(segments, open_end_m);
}

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

double ModelIcp::KnownInlierRatio(const std::vector<Point2>& samples_scan,
                                  const Pose2& T_model_scan) const {
  if (!open_end_grid_) return InlierRatio(samples_scan, T_model_scan);
  int inliers = 0, unknown = 0;
  const PointTransform transform(T_model_scan);
  for (const Point2& p_scan : samples_scan) {
    const Point2 p = transform(p_scan);
    if (inlier_grid_.Nearest(p).segment >= 0) {
      ++inliers;
      continue;
    }
    const SegmentMatch end = open_end_grid_->Nearest(p);
    if (end.segment < 0 || !end.beyond_end) continue;
    const ModelSegment& s = open_end_grid_->Segment(end.segment);
    const Point2 d = p - s.a;  // off the segment's line by |ab x d| / |ab|
    if (std::abs(s.ab.x() * d.y() - s.ab.y() * d.x()) * std::sqrt(s.inv_length2) <= inlier_m_) {
      ++unknown;
    }
  }
  const int known = static_cast<int>(samples_scan.size()) - unknown;
  return known > 0 ? static_cast<double>(inliers) / known : 0.0;
}

}  // namespace shape_slam::internal
