#include "shape_slam/candidate_selection.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/internal/model_icp.h"

namespace shape_slam {

void CandidateSelectionParams::Validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("CandidateSelectionParams::") + name + " must be > 0");
    }
  };
  positive(capture_distance_m, "capture_distance_m");
  positive(inlier_distance_m, "inlier_distance_m");
  if (icp_iterations < 0) {
    throw std::invalid_argument("CandidateSelectionParams::icp_iterations must be >= 0");
  }
  if (!(equally_good_fit >= 0.0 && equally_good_fit <= 1.0)) {
    throw std::invalid_argument("CandidateSelectionParams::equally_good_fit must be in [0, 1]");
  }
  if (!(turn_weight_m_per_rad >= 0.0) || !std::isfinite(turn_weight_m_per_rad)) {
    throw std::invalid_argument("CandidateSelectionParams::turn_weight_m_per_rad must be >= 0");
  }
  positive(prior_sigma_m, "prior_sigma_m");
  positive(prior_sigma_rad, "prior_sigma_rad");
  if (!(prior_weight >= 0.0) || !std::isfinite(prior_weight)) {
    throw std::invalid_argument("CandidateSelectionParams::prior_weight must be >= 0");
  }
  if (!(prior_max_penalty >= 0.0) || !std::isfinite(prior_max_penalty)) {
    throw std::invalid_argument("CandidateSelectionParams::prior_max_penalty must be >= 0");
  }
  if (!(open_end_m >= 0.0) || !std::isfinite(open_end_m)) {
    throw std::invalid_argument("CandidateSelectionParams::open_end_m must be >= 0");
  }
  if (max_refinements < 1) {
    throw std::invalid_argument("CandidateSelectionParams::max_refinements must be >= 1");
  }
}

std::vector<int> OrderByFit(const std::vector<double>& fits, const std::vector<double>& distances,
                            double equally_good_fit) {
  if (fits.size() != distances.size()) {
    throw std::invalid_argument("OrderByFit: fits and distances differ in size");
  }
  std::vector<int> remaining(fits.size()), order;
  for (std::size_t i = 0; i < fits.size(); ++i) remaining[i] = static_cast<int>(i);
  while (!remaining.empty()) {
    double best_fit = -std::numeric_limits<double>::infinity();
    for (const int i : remaining) best_fit = std::max(best_fit, fits[i]);
    std::size_t pick = 0;
    bool have = false;
    for (std::size_t k = 0; k < remaining.size(); ++k) {
      const int i = remaining[k];
      if (fits[i] < best_fit - equally_good_fit) continue;
      if (!have || distances[i] < distances[remaining[pick]]) pick = k, have = true;
    }
    order.push_back(remaining[pick]);
    remaining.erase(remaining.begin() + static_cast<std::ptrdiff_t>(pick));
  }
  return order;
}

double PoseDistance(const Pose2& reference, const Pose2& pose, double turn_weight_m_per_rad) {
  const Pose2 d = reference.Inverse() * pose;
  return d.Translation().norm() + turn_weight_m_per_rad * std::abs(d.theta);
}

CandidateSelector::CandidateSelector(const std::vector<Polyline>& model,
                                     const CandidateSelectionParams& params)
    : params_(params) {
  params_.Validate();
  icp_ = std::make_unique<const internal::ModelIcp>(
      model, std::max(params_.capture_distance_m, params_.inlier_distance_m),
      params_.inlier_distance_m, params_.open_end_m);
}

CandidateSelector::~CandidateSelector() = default;
CandidateSelector::CandidateSelector(CandidateSelector&&) noexcept = default;

double CandidateSelector::Fit(const std::vector<Point2>& samples_scan,
                              const Pose2& T_model_scan) const {
  return icp_->InlierRatio(samples_scan, T_model_scan);
}

Pose2 CandidateSelector::QuickAlign(const std::vector<Point2>& samples_scan,
                                    const Pose2& T_model_scan, int iterations) const {
  return icp_->Align(samples_scan, T_model_scan, iterations);
}

std::vector<RankedCandidate> CandidateSelector::Rank(
    const std::vector<Point2>& samples_scan, const std::vector<Pose2>& candidates,
    const Pose2& reference, const std::function<bool(const Pose2&)>& accept) const {
  std::vector<RankedCandidate> finished;
  std::vector<double> scores, distances;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Pose2 aligned = QuickAlign(samples_scan, candidates[i], params_.icp_iterations);
    if (accept && !accept(aligned)) continue;
    const Pose2 motion = reference.Inverse() * aligned;
    const double et = motion.Translation().norm() / params_.prior_sigma_m;
    const double er = motion.theta / params_.prior_sigma_rad;
    const double fit = icp_->KnownInlierRatio(samples_scan, aligned);
    double penalty = params_.prior_weight * (et * et + er * er);
    if (params_.prior_max_penalty > 0.0) penalty = std::min(penalty, params_.prior_max_penalty);
    finished.push_back({aligned, fit, fit - penalty,
                        PoseDistance(reference, aligned, params_.turn_weight_m_per_rad),
                        static_cast<int>(i)});
    scores.push_back(finished.back().score);
    distances.push_back(finished.back().distance);
  }
  std::vector<RankedCandidate> ranked;
  for (const int i : OrderByFit(scores, distances, params_.equally_good_fit)) ranked.push_back(finished[i]);
  return ranked;
}

}  // namespace shape_slam
