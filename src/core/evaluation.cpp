#include "shape_slam/evaluation.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace shape_slam {
namespace {

// Index of the pose with the nearest timestamp within the tolerance (poses sorted by time).
std::optional<std::size_t> FindByTime(const std::vector<StampedPose>& sorted, double t,
                                      double tolerance) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t,
                                   [](const StampedPose& p, double v) { return p.timestamp_s < v; });
  std::optional<std::size_t> best;
  double best_diff = tolerance;
  for (auto c = (it == sorted.begin() ? it : it - 1); c != sorted.end() && c <= it; ++c) {
    const double diff = std::abs(c->timestamp_s - t);
    if (diff <= best_diff) {
      best_diff = diff;
      best = static_cast<std::size_t>(c - sorted.begin());
    }
  }
  return best;
}

std::vector<StampedPose> SortedByTime(std::vector<StampedPose> poses) {
  std::stable_sort(poses.begin(), poses.end(), [](const StampedPose& a, const StampedPose& b) {
    return a.timestamp_s < b.timestamp_s;
  });
  return poses;
}

void AddRelationError(const Pose2& error, RelationErrors& errors) {
  errors.mean_translation_m += error.Translation().norm();
  errors.mean_rotation_deg += std::abs(error.theta) * 180.0 / M_PI;
  ++errors.count;
}

void FinishMeans(RelationErrors& errors) {
  if (errors.count == 0) return;
  errors.mean_translation_m /= static_cast<double>(errors.count);
  errors.mean_rotation_deg /= static_cast<double>(errors.count);
}

// Kümmerle relation errors, split into consecutive-scan relations and revisits.
void AddRelations(const std::vector<StampedPose>& est, const std::vector<StampedPose>& ref,
                  const std::vector<Relation>& relations, const EvaluationParams& params,
                  EvaluationResult& result) {
  for (const Relation& relation : relations) {
    const auto i1 = FindByTime(est, relation.t1_s, params.max_time_difference_s);
    const auto i2 = FindByTime(est, relation.t2_s, params.max_time_difference_s);
    const auto r1 = FindByTime(ref, relation.t1_s, params.max_time_difference_s);
    const auto r2 = FindByTime(ref, relation.t2_s, params.max_time_difference_s);
    const bool local = r1 && r2 && *r2 == *r1 + 1;
    RelationErrors& errors = local ? result.local : result.revisit;
    if (!i1 || !i2) {
      ++errors.missing;
      continue;
    }
    // e = (x_t1^-1 (+) x_t2) (-) reference
    const Pose2 estimated = est[*i1].pose.Inverse() * est[*i2].pose;
    AddRelationError(relation.T_1_2.Inverse() * estimated, errors);
  }
  FinishMeans(result.local);
  FinishMeans(result.revisit);
}

// Each step between consecutive estimate poses that both have a reference pose, against the
// reference's motion between those two reference poses.
GrossLocalErrors CountGrossLocalErrors(const std::vector<StampedPose>& est,
                                       const std::vector<StampedPose>& ref,
                                       const EvaluationParams& params) {
  GrossLocalErrors gross;
  const double max_rotation_rad = params.gross_rotation_deg * M_PI / 180.0;
  std::optional<std::size_t> previous;  // reference pose of est[i - 1]
  for (std::size_t i = 0; i < est.size(); ++i) {
    const auto r = FindByTime(ref, est[i].timestamp_s, params.max_time_difference_s);
    if (r && previous) {
      const GrossStep step{i, est[i - 1].timestamp_s, est[i].timestamp_s,
                           est[i - 1].pose.Inverse() * est[i].pose,
                           ref[*previous].pose.Inverse() * ref[*r].pose};
      const Pose2 error = step.Error();
      ++gross.steps;
      if (error.Translation().norm() > params.gross_translation_m ||
          std::abs(error.theta) > max_rotation_rad) {
        ++gross.count;
        gross.listed.push_back(step);
      }
    }
    previous = r;
  }
  return gross;
}

}  // namespace

void EvaluationParams::Validate() const {
  if (!(max_time_difference_s >= 0.0) || !std::isfinite(max_time_difference_s)) {
    throw std::invalid_argument("EvaluationParams::max_time_difference_s must be >= 0");
  }
  if (!(gross_translation_m >= 0.0) || !std::isfinite(gross_translation_m)) {
    throw std::invalid_argument("EvaluationParams::gross_translation_m must be >= 0");
  }
  if (!(gross_rotation_deg >= 0.0) || !std::isfinite(gross_rotation_deg)) {
    throw std::invalid_argument("EvaluationParams::gross_rotation_deg must be >= 0");
  }
}

Pose2 BestRigidAlignment(const std::vector<Point2>& from, const std::vector<Point2>& to) {
  if (from.size() != to.size() || from.empty()) {
    throw std::invalid_argument("BestRigidAlignment: need two equal, non-empty point sets");
  }
  Point2 cf = Point2::Zero(), ct = Point2::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) cf += from[i], ct += to[i];
  cf /= static_cast<double>(from.size());
  ct /= static_cast<double>(to.size());
  double dot = 0.0, cross = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Point2 a = from[i] - cf, b = to[i] - ct;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  const double theta = std::atan2(cross, dot);
  const Point2 t = ct - Pose2(0, 0, theta).Rotation() * cf;
  return {t.x(), t.y(), theta};
}

EvaluationResult EvaluateTrajectory(const std::vector<StampedPose>& estimate,
                                    const std::vector<StampedPose>& reference,
                                    const std::vector<Relation>& relations,
                                    const EvaluationParams& params) {
  params.Validate();
  const std::vector<StampedPose> est = SortedByTime(estimate);
  const std::vector<StampedPose> ref = SortedByTime(reference);
  EvaluationResult result;
  result.reference_poses = ref.size();
  std::vector<Point2> from, to;
  for (const StampedPose& r : ref) {
    if (const auto i = FindByTime(est, r.timestamp_s, params.max_time_difference_s)) {
      from.push_back(est[*i].pose.Translation());
      to.push_back(r.pose.Translation());
    }
  }
  if (from.empty()) {
    throw std::invalid_argument("no estimated pose has a reference pose with the same timestamp");
  }
  result.matched_poses = from.size();
  result.T_reference_estimate = BestRigidAlignment(from, to);
  double sum = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double e = (result.T_reference_estimate * from[i] - to[i]).norm();
    sum += e * e;
    result.ate_max_m = std::max(result.ate_max_m, e);
  }
  result.ate_rmse_m = std::sqrt(sum / static_cast<double>(from.size()));

  AddRelations(est, ref, relations, params, result);
  result.gross_local = CountGrossLocalErrors(est, ref, params);
  return result;
}

}  // namespace shape_slam
