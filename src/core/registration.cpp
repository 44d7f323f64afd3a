#include "shape_slam/internal/registration.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "shape_slam/alignment.h"
#include "shape_slam/internal/median.h"

namespace shape_slam::internal {

std::vector<Point2> AlignmentSamples(const std::vector<Polyline>& fine, double spacing_m) {
  std::vector<Point2> samples;
  for (const Polyline& p : fine) {
    const std::vector<Point2> s = SamplePolyline(p, spacing_m);
    samples.insert(samples.end(), s.begin(), s.end());
  }
  return samples;
}

RefinementResult RefineAgainstMap(const std::vector<Point2>& samples,
                                  const std::vector<Polyline>& model, const Pose2& init,
                                  const std::optional<PosePrior>& prior,
                                  const RefinementParams& refinement, double coarse_gate_m) {
  RefinementParams coarse = refinement;
  coarse.max_correspondence_distance_m =
      std::max(coarse_gate_m, refinement.max_correspondence_distance_m);
  coarse.loss_scale_m = std::max(coarse.loss_scale_m, coarse_gate_m / 4.0);
  const RefinementResult first = RefineAlignment(samples, model, init, prior, coarse);
  return RefineAlignment(samples, model, first.T_map_scan, prior, refinement);
}

// Fraction of the samples within the grid's radius of the model at an estimate.
double InlierRatio(const std::vector<Point2>& samples, const internal::SegmentGrid& grid,
                   const Pose2& T_model_scan) {
  int inliers = 0;
  const PointTransform transform(T_model_scan);
  for (const Point2& p : samples) inliers += grid.Nearest(transform(p)).segment >= 0 ? 1 : 0;
  return samples.empty() ? 0.0 : static_cast<double>(inliers) / samples.size();
}

Eigen::Matrix3d WidenedAlongRidge(const std::vector<Point2>& samples, const ModelIcp& model,
                                  const Pose2& T_model_scan, const Eigen::Matrix3d& covariance,
                                  double max_shift_m, double fit_margin) {
  if (max_shift_m <= 0.0 || samples.empty()) return covariance;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance.topLeftCorner<2, 2>());
  const Eigen::Vector2d weakest = eig.eigenvectors().col(1);  // eigenvalues ascend
  const double fit = model.KnownInlierRatio(samples, T_model_scan);
  double extent = 0.0;
  for (const double shift : {0.5 * max_shift_m, max_shift_m}) {
    for (const double sign : {-1.0, 1.0}) {
      Pose2 shifted = T_model_scan;
      shifted.x += sign * shift * weakest.x();
      shifted.y += sign * shift * weakest.y();
      if (model.KnownInlierRatio(samples, shifted) >= fit - fit_margin) {
        extent = std::max(extent, shift);
      }
    }
  }
  Eigen::Matrix3d widened = covariance;
  const double variance = weakest.dot(covariance.topLeftCorner<2, 2>() * weakest);
  if (extent * extent > variance) {
    widened.topLeftCorner<2, 2>() += (extent * extent - variance) * weakest * weakest.transpose();
  }
  return widened;
}

std::vector<Point2> Thinned(const std::vector<Point2>& samples, double from_m, double to_m) {
  const int every = std::max(1, static_cast<int>(std::lround(to_m / from_m)));
  std::vector<Point2> thinned;
  for (std::size_t i = 0; i < samples.size(); i += every) thinned.push_back(samples[i]);
  return thinned;
}

RegistrationResult ToResult(const RankedCandidate& candidate, const RefinementResult& refined,
                            double fit) {
  RegistrationResult result;
  result.T_model_scan = refined.T_map_scan;
  result.covariance = refined.covariance;
  result.fit = fit;
  result.converged = true;
  result.candidate = candidate.index;
  result.rms_error_m = refined.rms_error_m;
  result.iterations = refined.iterations;
  return result;
}

RegistrationResult RegisterCandidates(
    const std::vector<Point2>& samples, const CandidateSelector& selector,
    const std::vector<Pose2>& candidates, const Pose2& reference, int max_refinements,
    const std::function<std::optional<RefinementResult>(const RankedCandidate&)>& refine,
    const std::function<bool(const Pose2&)>& accept) {
  const auto selected = SelectRefined<RefinementResult>(
      selector.Rank(samples, candidates, reference, accept), max_refinements, refine);
  if (!selected) {
    RegistrationResult none;
    none.T_model_scan = reference;
    return none;
  }
  const auto& [candidate, refined] = *selected;
  return ToResult(candidate, refined, selector.Fit(samples, refined.T_map_scan));
}

double MedianShift(const std::vector<Point2>& samples, const Pose2& from, const Pose2& to) {
  if (samples.empty()) return 0.0;
  std::vector<double> shifts;
  shifts.reserve(samples.size());
  for (const Point2& p : samples) shifts.push_back((to * p - from * p).norm());
  return MedianInPlace(shifts);
}

bool RefinementStayedNear(const std::vector<Point2>& samples, const Pose2& start,
                          const Pose2& refined, const RefinementParams& params) {
  return MedianShift(samples, start, refined) <=
         params.outer_iterations * params.max_correspondence_distance_m;
}

}  // namespace shape_slam::internal
