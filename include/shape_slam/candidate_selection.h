// Choosing among candidate poses of a scan against a model: the one step that every matcher of
// the project ends with (the seeds of §4.3 in shape_matcher.h, scan-to-scan registration in
// scan_matcher.h, per-scan localization and loop closure in the pipeline).
//
// Candidates come from shape matching (§4.2, §4.3), the window search (window_search.h), the
// prediction and hints. Each is finished by a few point-to-point ICP steps against the whole
// model, scored by the fraction of the scan it explains (samples within inlier_distance_m of a
// model polyline), and ordered: the best fit first, and among fits within equally_good_fit of
// the best remaining one, the candidate nearest the reference pose (the prediction, the guess,
// "the robot did not move"). Repetitive places offer look-alike fits farther away; between
// consecutive scans the smaller motion is the likelier one. The caller then refines in that order
// and takes the first estimate its own checks accept (SelectRefined).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {
namespace internal {
class ModelIcp;
}

struct CandidateSelectionParams {
  /// Point-to-point ICP steps (closed form, shrinking gate) that finish each candidate.
  int icp_iterations = 8;
  /// Association gate of the first of those steps (it shrinks to 40 % of it), metres.
  double capture_distance_m = 0.6;
  /// A sample within this distance of the model counts as explained, metres.
  double inlier_distance_m = 0.10;
  /// Fits (explained fractions) closer than this to the best remaining one count as equally
  /// good; among them the one nearest the reference wins.
  double equally_good_fit = 0.05;
  /// Distance to the reference = translation (m) + this * |rotation| (rad), metres per radian.
  double turn_weight_m_per_rad = 1.0;
  /// At most this many candidates, in order, are refined by SelectRefined.
  int max_refinements = 6;
  /// Motion prior: a candidate is ranked by its fit less prior_weight * ((|t| / prior_sigma_m)^2
  /// + (theta / prior_sigma_rad)^2), (t, theta) its motion from the reference. 0: the fit alone
  /// (then only equally_good_fit prefers the nearer candidate).
  double prior_weight = 0.0;
  double prior_sigma_m = 0.5;    ///< metres
  double prior_sigma_rad = 0.5;  ///< radians
  /// The motion prior's penalty never exceeds this (fit units; 0: unbounded): a heavy-tailed
  /// prior. Between close fits (along a featureless corridor) the candidate nearer the
  /// reference still wins; one that explains clearly more of the scan wins wherever it lies (a
  /// robot that starts, stops or turns between two scans, when the reference is the last motion).
  double prior_max_penalty = 0.0;
  /// > 0: a sample off the model that continues a model polyline beyond its open end (within
  /// inlier_distance_m of the end segment's line, at most open_end_m past the end) is unknown
  /// space, left out of the fit instead of counted as a miss. A scan that sees farther along a
  /// corridor than the model then fits as well at its true pose as at one short of it; counted
  /// as misses, those samples make the shorter motion fit best. 0: off, every sample counts.
  double open_end_m = 0.0;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// A candidate after the quick ICP.
struct RankedCandidate {
  Pose2 T_model_scan;     ///< finished by the ICP steps
  /// Fraction of the samples within inlier_distance_m of the model (of those not in unknown
  /// space beyond the model's open ends when open_end_m > 0).
  double fit = 0.0;
  double score = 0.0;     ///< fit less the motion prior (see prior_weight)
  double distance = 0.0;  ///< to the reference, metres (see turn_weight_m_per_rad)
  int index = 0;          ///< position of the candidate it came from in the input
};

/// The order of SelectRefined, on given fits and distances: repeatedly the highest remaining
/// fit f, then among the remaining with fit >= f - equally_good_fit the smallest distance
/// (ties: lower index). Returns indices into the inputs. Equal sizes required.
std::vector<int> OrderByFit(const std::vector<double>& fits, const std::vector<double>& distances,
                            double equally_good_fit);

class CandidateSelector {
 public:
  /// Prepares the model polylines (model frame). Throws std::invalid_argument on invalid params.
  CandidateSelector(const std::vector<Polyline>& model, const CandidateSelectionParams& params);
  ~CandidateSelector();
  CandidateSelector(CandidateSelector&&) noexcept;

  /// Fraction of the samples (scan frame) within inlier_distance_m of the model at a pose.
  double Fit(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan) const;

  /// `iterations` quick ICP steps from a pose (see icp_iterations).
  Pose2 QuickAlign(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan,
                   int iterations) const;

  /// Every candidate finished and scored; those `accept` refuses (if given) are dropped; the rest
  /// in the order of OrderByFit on their scores, distances measured from `reference`.
  std::vector<RankedCandidate> Rank(const std::vector<Point2>& samples_scan,
                                    const std::vector<Pose2>& candidates, const Pose2& reference,
                                    const std::function<bool(const Pose2&)>& accept = {}) const;

  const CandidateSelectionParams& Params() const { return params_; }

 private:
  CandidateSelectionParams params_;
  std::unique_ptr<const internal::ModelIcp> icp_;
};

/// Distance of a pose from a reference in the sense of CandidateSelectionParams.
double PoseDistance(const Pose2& reference, const Pose2& pose, double turn_weight_m_per_rad);

/// Refines the ranked candidates in order (at most max_refinements) with `refine`, which returns
/// the refined estimate or nullopt when its checks reject it; the first accepted one, with the
/// candidate it came from, or nullopt.
template <typename Refined>
std::optional<std::pair<RankedCandidate, Refined>> SelectRefined(
    const std::vector<RankedCandidate>& ranked, int max_refinements,
    const std::function<std::optional<Refined>(const RankedCandidate&)>& refine) {
  int tried = 0;
  for (const RankedCandidate& candidate : ranked) {
    if (tried++ >= max_refinements) break;
    if (std::optional<Refined> refined = refine(candidate)) {
      return std::make_pair(candidate, std::move(*refined));
    }
  }
  return std::nullopt;
}

}  // namespace shape_slam
