#include "shape_slam/scan_matcher.h"

#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

#include "shape_slam/internal/registration.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/shape_matcher.h"
#include "shape_slam/window_search.h"

namespace shape_slam {

void ScanMatchParams::Validate() const {
  shapes.Validate();
  matcher.Validate();
  refinement.Validate();
  selection.Validate();
  window_search.Validate();
  if (!(window_search_spacing_m > 0.0) || !(coarse_gate_m > 0.0)) {
    throw std::invalid_argument(
        "ScanMatchParams::window_search_spacing_m and coarse_gate_m must be > 0");
  }
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    throw std::invalid_argument("ScanMatchParams::min_inlier_ratio must be in [0, 1]");
  }
  if (seed_pairs < 1 || seeds < 1) {
    throw std::invalid_argument("ScanMatchParams::seed_pairs and seeds must be >= 1");
  }
}

namespace {

// The candidate poses of scan J in scan I's sensor frame. Shape matching: with the guess (§4.2,
// D measured against it) and without any (§4.3, seeded by the most reliable pairs, with "the
// robot did not move" as one more estimate); a guess far off gates the right pairs out of the
// first, the second does not need it. Then the guess, the reference (the guess, else no motion:
// among fits explaining the scan about equally well the one nearest it wins, as repetitive
// places offer look-alike fits farther away) and the window search around the reference, all
// turns included: where scan J fits scan I at all. Sets result's matched_pairs and reliability.
std::vector<Pose2> Candidates(const ScanShapes& shapes_i, const ScanShapes& shapes_j,
                              const std::vector<Point2>& samples,
                              const std::optional<Pose2>& guess, const Pose2& reference,
                              const ScanMatchParams& params, ScanMatchResult& result) {
  std::vector<Pose2> candidates;
  for (const bool use_guess : {true, false}) {
    if (use_guess && !guess) continue;
    ShapeMatchInput input;
    input.scan = shapes_j.coarse;
    input.scan_fine = shapes_j.fine;
    input.model = shapes_i.coarse;
    input.model_cyclic = !use_guess;
    if (!use_guess) input.hint_estimates.push_back(reference);
    ShapeMatcherParams matcher = params.matcher;
    if (!use_guess) {
      matcher.max_seed_pairs = params.seed_pairs;
      matcher.num_seeds = params.seeds;
    }
    const ShapeMatchResult match = MatchShapes(input, use_guess ? guess : std::nullopt, matcher);
    if (match.matches.empty()) continue;
    candidates.push_back(match.T_model_scan);
    result.matched_pairs = std::max(result.matched_pairs, static_cast<int>(match.matches.size()));
    if (!use_guess) result.reliability = match.reliability;
  }
  if (guess) candidates.push_back(*guess);
  candidates.push_back(reference);
  const WindowSearch search(shapes_i.fine, params.window_search);
  const std::vector<Point2> coarse = internal::Thinned(
      samples, params.matcher.alignment.sample_spacing_m, params.window_search_spacing_m);
  for (const WindowHypothesis& h : search.Search(coarse, reference)) candidates.push_back(h.T_model_scan);
  return candidates;
}

}  // namespace

ScanMatchResult MatchScans(const LaserScan& scan_i, const LaserScan& scan_j,
                           const std::optional<Pose2>& guess_T_i_j,
                           const ScanMatchParams& params) {
  params.Validate();
  // Robot frames (the result) <-> sensor frames (where the shapes live).
  const auto to_sensor = [&](const Pose2& T_i_j) {
    return scan_i.T_robot_sensor.Inverse() * T_i_j * scan_j.T_robot_sensor;
  };
  const auto to_robot = [&](const Pose2& T_si_sj) {
    return scan_i.T_robot_sensor * T_si_sj * scan_j.T_robot_sensor.Inverse();
  };
  ScanMatchResult result;
  result.T_i_j = guess_T_i_j.value_or(Pose2());
  const ScanShapes shapes_i = ExtractScanShapes(scan_i, params.shapes);
  const ScanShapes shapes_j = ExtractScanShapes(scan_j, params.shapes);
  const std::vector<Point2> samples =
      internal::AlignmentSamples(shapes_j.fine, params.matcher.alignment.sample_spacing_m);
  if (shapes_i.coarse.empty() || samples.empty()) return result;

  std::optional<Pose2> guess;
  if (guess_T_i_j) guess = to_sensor(*guess_T_i_j);
  const Pose2 reference = guess.value_or(to_sensor(Pose2()));
  const std::vector<Pose2> candidates =
      Candidates(shapes_i, shapes_j, samples, guess, reference, params, result);

  // Each candidate finished by quick ICP and ranked by how much of scan J it explains; the
  // best one that the Ceres refinement accepts wins.
  CandidateSelectionParams selection = params.selection;
  selection.capture_distance_m = params.coarse_gate_m;
  selection.inlier_distance_m = params.matcher.inlier_distance_m;
  const CandidateSelector selector(shapes_i.fine, selection);
  const auto refine = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
    RefinementResult refined =
        internal::RefineAgainstMap(samples, shapes_i.fine, c.T_model_scan, std::nullopt,
                                   params.refinement, params.coarse_gate_m);
    if (!refined.converged) return std::nullopt;
    return refined;
  };
  const internal::RegistrationResult registered = internal::RegisterCandidates(
      samples, selector, candidates, reference, selection.max_refinements, refine);
  if (!registered.converged) return result;
  result.T_i_j = to_robot(registered.T_model_scan);
  // Covariance of the robot pose: the sensor offsets are constant, so it transforms with the
  // rotation of scan I's sensor on the robot.
  result.covariance = CovarianceInFrame(registered.covariance, scan_i.T_robot_sensor);
  result.iterations = registered.iterations;
  result.rms_error_m = registered.rms_error_m;
  result.inlier_ratio = registered.fit;
  result.converged = result.inlier_ratio >= params.min_inlier_ratio;
  return result;
}

}  // namespace shape_slam
