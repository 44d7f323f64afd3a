#include "shape_slam/loop_closure.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <queue>
#include <stdexcept>
#include <string>
#include <utility>

#include "shape_slam/candidate_selection.h"
#include "shape_slam/internal/registration.h"
#include "shape_slam/internal/validation.h"
#include "shape_slam/internal/model_segments.h"
#include "shape_slam/shape_matcher.h"
#include "shape_slam/window_search.h"

namespace shape_slam {
namespace {

using internal::NonNegative;
using internal::Positive;
using internal::Fraction;

Pose2 SensorPose(const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph, int k) {
  return graph.Node(keyframes[k].node) * keyframes[k].T_robot_sensor;
}

// The old place: the candidate keyframe's polylines for shape matching (one view, in the
// counter-clockwise order §4 relies on) and, for the window search, the alignment and the fit,
// those of its neighbours along the old path too (one every submap_step_m of driving within
// submap_travel_m), all in the candidate's sensor frame.
struct Place {
  std::vector<Polyline> coarse;
  std::vector<Polyline> fine;
};

Place OldPlace(const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph, int old,
               int current, const LoopClosureParams& p) {
  Place place;
  place.coarse = keyframes[old].shapes.coarse;
  const Pose2 T_old_map = SensorPose(keyframes, graph, old).Inverse();
  double last_taken = -std::numeric_limits<double>::infinity();
  for (int j = 0; j < current; ++j) {
    const double apart = keyframes[j].travel_m - keyframes[old].travel_m;
    const bool old_enough = keyframes[current].travel_m - keyframes[j].travel_m >= p.min_travel_m;
    if (std::abs(apart) > p.submap_travel_m || !old_enough) continue;
    if (j != old && keyframes[j].travel_m - last_taken < p.submap_step_m) continue;
    last_taken = keyframes[j].travel_m;
    const Pose2 T_old_j = T_old_map * SensorPose(keyframes, graph, j);
    for (const Polyline& polyline : keyframes[j].shapes.fine) {
      place.fine.push_back(Transform(T_old_j, polyline));
    }
  }
  return place;
}

// Of the model samples (scan frame) that the scan could have seen -- within the bearings and
// ranges of its own samples, not beyond what it saw in that direction -- the fraction within
// inlier_distance_m of the scan's polylines. A place seen only partly by the scan is judged by
// what the scan saw.
double VisibleInlierRatio(const std::vector<Point2>& model_samples_scan,
                          const std::vector<Point2>& scan_samples, const internal::SegmentGrid& scan_grid) {
  constexpr int kBins = 720;  // half a degree
  constexpr double kBehindM = 0.5;  // a model sample this much beyond the scan's reach is hidden
  std::vector<double> reach(kBins, -1.0);
  const auto bin = [](const Point2& p) {
    const double a = std::atan2(p.y(), p.x());
    return std::min(kBins - 1, static_cast<int>((a + M_PI) / (2.0 * M_PI) * kBins));
  };
  for (const Point2& q : scan_samples) reach[bin(q)] = std::max(reach[bin(q)], q.norm());
  int seen = 0, explained = 0;
  for (const Point2& q : model_samples_scan) {
    const double r = reach[bin(q)];
    if (r < 0.0 || q.norm() > r + kBehindM) continue;
    ++seen;
    explained += scan_grid.Nearest(q).segment >= 0 ? 1 : 0;
  }
  return seen == 0 ? 0.0 : static_cast<double>(explained) / seen;
}

// Shape matching (§4.2 with a guess, §4.3 without) of the new keyframe against the old place.
std::optional<Pose2> ShapeCandidate(const ScanShapes& scan, const std::vector<Polyline>& model,
                                    const std::optional<Pose2>& guess, const Pose2& estimate,
                                    const ScanMatchParams& match) {
  ShapeMatchInput input;
  input.scan = scan.coarse;
  input.scan_fine = scan.fine;
  input.model = model;
  input.model_cyclic = !guess;
  ShapeMatcherParams matcher = match.matcher;
  if (!guess) {
    input.hint_estimates = {Pose2(), estimate};
    // No map backs a closure up: as many seeds as scan-to-scan registration.
    matcher.max_seed_pairs = match.seed_pairs;
    matcher.num_seeds = match.seeds;
  }
  const ShapeMatchResult result = MatchShapes(input, guess, matcher);
  if (result.matches.empty()) return std::nullopt;
  return result.T_model_scan;
}

// Weighted adjacency of the pose graph: consecutive edges weigh the driving between their
// keyframes (plus guess_m for a guessed step), loop edges nothing (they tie the two places
// together). Keyframes after `current` are not known: the nodes they own are placed at no
// driving (as when they did not exist yet).
std::vector<std::vector<std::pair<int, double>>> Adjacency(const std::vector<LoopKeyframe>& keyframes,
                                                           const PoseGraph& graph, double guess_m,
                                                           int current) {
  std::vector<double> travel(graph.NumNodes(), 0.0);
  for (int k = 0; k <= current; ++k) travel.at(keyframes[k].node) = keyframes[k].travel_m;
  std::vector<std::vector<std::pair<int, double>>> adjacency(graph.NumNodes());
  for (const PoseGraphEdge& e : graph.Edges()) {
    const double w =
        e.loop ? 0.0 : std::abs(travel[e.to] - travel[e.from]) + (e.guessed ? guess_m : 0.0);
    adjacency[e.from].emplace_back(e.to, w);
    adjacency[e.to].emplace_back(e.from, w);
  }
  return adjacency;
}

}  // namespace

void LoopClosureParams::Validate() const {
  if (search_every < 1) throw std::invalid_argument("LoopClosureParams::search_every must be >= 1");
  if (final_searches < 0) throw std::invalid_argument("LoopClosureParams::final_searches must be >= 0");
  if (final_sweep_every < 0) {
    throw std::invalid_argument("LoopClosureParams::final_sweep_every must be >= 0");
  }
  if (max_candidates < 1) throw std::invalid_argument("LoopClosureParams::max_candidates must be >= 1");
  NonNegative(submap_travel_m, "LoopClosureParams::submap_travel_m");
  NonNegative(submap_step_m, "LoopClosureParams::submap_step_m");
  NonNegative(ambiguity_m, "LoopClosureParams::ambiguity_m");
  NonNegative(corridor_heading_rad, "LoopClosureParams::corridor_heading_rad");
  NonNegative(corridor_offset_m, "LoopClosureParams::corridor_offset_m");
  NonNegative(corridor_sigma_m, "LoopClosureParams::corridor_sigma_m");
  Fraction(ambiguity_fit_margin, "LoopClosureParams::ambiguity_fit_margin");
  Positive(window_half_m, "LoopClosureParams::window_half_m");
  Positive(window_resolution_m, "LoopClosureParams::window_resolution_m");
  if (window_max_evaluations < 1) {
    throw std::invalid_argument("LoopClosureParams::window_max_evaluations must be >= 1");
  }
  Positive(max_view_angle_rad, "LoopClosureParams::max_view_angle_rad");
  NonNegative(view_angle_per_m, "LoopClosureParams::view_angle_per_m");
  Positive(max_match_sigma_m, "LoopClosureParams::max_match_sigma_m");
  Fraction(strong_inlier_ratio, "LoopClosureParams::strong_inlier_ratio");
  NonNegative(quick_min_fit, "LoopClosureParams::quick_min_fit");
  Fraction(window_min_fit, "LoopClosureParams::window_min_fit");
  Fraction(refine_min_fit, "LoopClosureParams::refine_min_fit");
  Positive(search_radius_m, "LoopClosureParams::search_radius_m");
  NonNegative(search_radius_per_m, "LoopClosureParams::search_radius_per_m");
  if (!(max_search_radius_m >= search_radius_m) || !std::isfinite(max_search_radius_m)) {
    throw std::invalid_argument("LoopClosureParams::max_search_radius_m must be >= search_radius_m");
  }
  NonNegative(min_travel_m, "LoopClosureParams::min_travel_m");
  Positive(covariance_scale, "LoopClosureParams::covariance_scale");
  Positive(sigma_floor_m, "LoopClosureParams::sigma_floor_m");
  Positive(sigma_floor_rad, "LoopClosureParams::sigma_floor_rad");
  NonNegative(min_correction_m, "LoopClosureParams::min_correction_m");
  NonNegative(min_correction_rad, "LoopClosureParams::min_correction_rad");
  Positive(max_correction_rad, "LoopClosureParams::max_correction_rad");
  NonNegative(max_correction_rad_per_m, "LoopClosureParams::max_correction_rad_per_m");
  if (confirm_within_keyframes < 1) {
    throw std::invalid_argument("LoopClosureParams::confirm_within_keyframes must be >= 1");
  }
  NonNegative(confirm_near_m, "LoopClosureParams::confirm_near_m");
  if (confirm_near_keyframes < 1) {
    throw std::invalid_argument("LoopClosureParams::confirm_near_keyframes must be >= 1");
  }
  NonNegative(confirm_tolerance_m, "LoopClosureParams::confirm_tolerance_m");
  NonNegative(confirm_tolerance_rad, "LoopClosureParams::confirm_tolerance_rad");
  NonNegative(confirm_tolerance_per_m, "LoopClosureParams::confirm_tolerance_per_m");
  NonNegative(confirm_tolerance_rad_per_m, "LoopClosureParams::confirm_tolerance_rad_per_m");
  NonNegative(candidate_turn_weight_m_per_rad, "LoopClosureParams::candidate_turn_weight_m_per_rad");
  NonNegative(candidate_spacing_m, "LoopClosureParams::candidate_spacing_m");
  Positive(unconfirmed_sigma_m, "LoopClosureParams::unconfirmed_sigma_m");
  Positive(unconfirmed_sigma_rad, "LoopClosureParams::unconfirmed_sigma_rad");
  Positive(guess_sigma_m, "LoopClosureParams::guess_sigma_m");
  Positive(guess_sigma_rad, "LoopClosureParams::guess_sigma_rad");
  NonNegative(guess_graph_m, "LoopClosureParams::guess_graph_m");
  NonNegative(ridge_max_shift_m, "LoopClosureParams::ridge_max_shift_m");
  Fraction(ridge_fit_margin, "LoopClosureParams::ridge_fit_margin");
  Positive(max_correction_m, "LoopClosureParams::max_correction_m");
  NonNegative(max_correction_per_m, "LoopClosureParams::max_correction_per_m");
  Fraction(min_inlier_ratio, "LoopClosureParams::min_inlier_ratio");
  Positive(verify_tolerance_m, "LoopClosureParams::verify_tolerance_m");
  Positive(verify_tolerance_rad, "LoopClosureParams::verify_tolerance_rad");
  Fraction(max_broken_fraction, "LoopClosureParams::max_broken_fraction");
  Fraction(min_reverse_inlier_ratio, "LoopClosureParams::min_reverse_inlier_ratio");
  graph.Validate();
}

Eigen::Matrix3d EdgeCovariance(const Eigen::Matrix3d& refined, const LoopClosureParams& params) {
  Eigen::Matrix3d c = params.covariance_scale * refined;
  c = 0.5 * (c + c.transpose()).eval();
  const double fm = params.sigma_floor_m * params.sigma_floor_m;
  const double fr = params.sigma_floor_rad * params.sigma_floor_rad;
  c(0, 0) = std::max(c(0, 0), fm);
  c(1, 1) = std::max(c(1, 1), fm);
  c(2, 2) = std::max(c(2, 2), fr);
  // Keep it positive definite whatever the refinement reported.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  if (eig.eigenvalues().minCoeff() <= 1e-12) c += Eigen::Vector3d(fm, fm, fr).asDiagonal();
  return c;
}

const char* LoopDecisionName(LoopDecision decision) {
  switch (decision) {
    case LoopDecision::kAgreed: return "agreed";
    case LoopDecision::kTaken: return "taken";
    case LoopDecision::kPending: return "pending";
    case LoopDecision::kConfirmed: return "confirmed";
    case LoopDecision::kRefused: return "refused";
    case LoopDecision::kAmbiguous: return "ambiguous";
  }
  return "unknown";
}

LoopCloser::LoopCloser(const LoopClosureParams& params, const ScanMatchParams& match)
    : params_(params), match_(match) {
  params_.Validate();
  match_.Validate();
}

double LoopCloser::SearchRadius(double graph_distance_m) const {
  return std::min(params_.max_search_radius_m,
                  params_.search_radius_m + params_.search_radius_per_m * graph_distance_m);
}

double LoopCloser::CorrectionBoundM(double graph_distance_m) const {
  return std::min(SearchRadius(graph_distance_m),
                  std::max(params_.max_correction_m, params_.max_correction_per_m * graph_distance_m));
}

double LoopCloser::CorrectionBoundRad(double graph_distance_m) const {
  return std::min(M_PI, params_.max_correction_rad + params_.max_correction_rad_per_m * graph_distance_m);
}

// Dijkstra from keyframe `from` over the graph (see Adjacency): the driving that separates each
// keyframe from it once the closed loops are taken into account, a proxy for the uncertainty of
// their relative pose. Indexed by keyframe.
std::vector<double> LoopCloser::GraphDistances(const std::vector<LoopKeyframe>& keyframes,
                                               const PoseGraph& graph, int from, double guess_m,
                                               int current) const {
  const auto adjacency = Adjacency(keyframes, graph, guess_m, current);
  std::vector<double> node_distance(graph.NumNodes(), std::numeric_limits<double>::infinity());
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> queue;
  node_distance.at(keyframes[from].node) = 0.0;
  queue.emplace(0.0, keyframes[from].node);
  while (!queue.empty()) {
    const auto [d, n] = queue.top();
    queue.pop();
    if (d > node_distance[n]) continue;
    for (const auto& [m, w] : adjacency[n]) {
      if (d + w < node_distance[m]) {
        node_distance[m] = d + w;
        queue.emplace(d + w, m);
      }
    }
  }
  std::vector<double> distance(current + 1);
  for (int k = 0; k <= current; ++k) {
    const double d = node_distance[keyframes[k].node];
    // A keyframe the graph does not connect: its uncertainty is the driving between them.
    distance[k] = std::isfinite(d) ? d : std::abs(keyframes[from].travel_m - keyframes[k].travel_m);
  }
  return distance;
}

// Old keyframes at least min_travel_m of driving back, within the search region of the current
// estimate (which grows with the graph distance) and seen from a similar heading (within the
// heading uncertainty: a 180 deg scanner's view from the opposite direction shares little),
// ordered by distance plus heading difference relative to their search radius, spread along
// the old path.
std::vector<int> LoopCloser::CandidatesAt(const std::vector<LoopKeyframe>& keyframes,
                                          const PoseGraph& graph,
                                          const std::vector<double>& graph_distance, int current,
                                          double max_view_angle_rad) const {
  if (current < 1) return {};
  const Pose2 P_now = graph.Node(keyframes[current].node);
  std::vector<std::pair<double, int>> scored;
  for (int k = 0; k < current; ++k) {
    if (keyframes[current].travel_m - keyframes[k].travel_m < params_.min_travel_m) break;
    const Pose2 P = graph.Node(keyframes[k].node);
    const double g = graph_distance[k];
    const double radius = SearchRadius(g);
    const double d = (P.Translation() - P_now.Translation()).norm();
    const double turn = std::abs(NormalizeAngle(P.theta - P_now.theta));
    const double view = std::min(M_PI, max_view_angle_rad + params_.view_angle_per_m * g);
    if (d <= radius && turn <= view) {
      scored.emplace_back((d + params_.candidate_turn_weight_m_per_rad * turn) / radius, k);
    }
  }
  std::sort(scored.begin(), scored.end());
  std::vector<int> places;
  for (const auto& [score, k] : scored) {
    // Neighbouring keyframes see nearly the same: spread the tries along the old path.
    const bool near_tried = std::any_of(places.begin(), places.end(), [&, k = k](int c) {
      return std::abs(keyframes[c].travel_m - keyframes[k].travel_m) < params_.candidate_spacing_m;
    });
    if (!near_tried) places.push_back(k);
  }
  // The best-ranked place, then the others in turn from search to search.
  std::vector<int> candidates;
  if (places.empty()) return candidates;
  candidates.push_back(places[0]);
  const int others = static_cast<int>(places.size()) - 1;
  for (int j = 0; j < std::min(others, params_.max_candidates - 1); ++j) {
    candidates.push_back(places[1 + (round_robin_ + j) % others]);
  }
  return candidates;
}

// Both sides of a candidate match: the current keyframe's scan and the old place.
struct LoopCloser::Sides {
  const LoopKeyframe& now;
  const LoopKeyframe& then;
  int old = 0, current = 0;
  double graph_distance = 0.0;
  Place place;
  Pose2 estimate;                               // the graph's pose of the scan in the place
  std::vector<Point2> samples, place_samples;  // scan and place, sampled for alignment
  CandidateSelector selector;                   // fit of the scan to the place
  internal::SegmentGrid scan_grid;              // fit of the place to the scan
};

std::unique_ptr<LoopCloser::Sides> LoopCloser::MakeSides(const std::vector<LoopKeyframe>& keyframes,
                                                         const PoseGraph& graph, int old, int current,
                                                         double graph_distance) const {
  const LoopKeyframe& now = keyframes[current];
  const LoopKeyframe& then = keyframes[old];
  if (now.shapes.coarse.empty() || then.shapes.coarse.empty()) return nullptr;
  Place place = OldPlace(keyframes, graph, old, current, params_);
  const double spacing = match_.matcher.alignment.sample_spacing_m;
  std::vector<Point2> samples = internal::AlignmentSamples(now.shapes.fine, spacing);
  std::vector<Point2> place_samples = internal::AlignmentSamples(place.fine, spacing);
  if (samples.empty() || place_samples.empty()) return nullptr;
  const Pose2 estimate = SensorPose(keyframes, graph, old).Inverse() * SensorPose(keyframes, graph, current);
  CandidateSelectionParams selection = match_.selection;
  selection.capture_distance_m = match_.coarse_gate_m;
  selection.inlier_distance_m = match_.matcher.inlier_distance_m;
  CandidateSelector selector(place.fine, selection);
  return std::unique_ptr<Sides>(new Sides{now,
                                          then,
                                          old,
                                          current,
                                          graph_distance,
                                          std::move(place),
                                          estimate,
                                          std::move(samples),
                                          std::move(place_samples),
                                          std::move(selector),
                                          internal::SegmentGrid(internal::MakeModelSegments(now.shapes.fine),
                                                                match_.matcher.inlier_distance_m)});
}

std::optional<RefinementResult> LoopCloser::Refine(const Sides& sides,
                                                   const RankedCandidate& candidate) const {
  RefinementResult refined = internal::RefineAgainstMap(sides.samples, sides.place.fine,
                                                        candidate.T_model_scan, std::nullopt,
                                                        match_.refinement, match_.coarse_gate_m);
  if (!refined.converged) return std::nullopt;
  return refined;
}

std::optional<LoopClosure> LoopCloser::Verify(const Sides& sides,
                                              const internal::RegistrationResult& registered,
                                              const PoseGraph& graph) const {
  // Verification: both sides explain each other ...
  LoopClosure loop;
  loop.inlier_ratio = registered.fit;
  std::vector<Point2> place_in_scan;
  const PointTransform T_scan_old(registered.T_model_scan.Inverse());
  for (const Point2& q : sides.place_samples) place_in_scan.push_back(T_scan_old(q));
  loop.reverse_inlier_ratio = VisibleInlierRatio(place_in_scan, sides.samples, sides.scan_grid);
  if (loop.inlier_ratio < params_.min_inlier_ratio ||
      loop.reverse_inlier_ratio < params_.min_reverse_inlier_ratio) {
    return std::nullopt;
  }
  // ... the match constrains every direction (not along a featureless corridor) ...
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> xy(registered.covariance.topLeftCorner<2, 2>());
  if (std::sqrt(std::max(0.0, xy.eigenvalues().maxCoeff())) > params_.max_match_sigma_m) {
    return std::nullopt;
  }
  // ... and the correction lies within the uncertainty (drift is bounded; a corridor turned
  // by 180 deg, a parallel corridor far off are not).
  const Pose2 T_old_now = graph.Node(sides.then.node).Inverse() * graph.Node(sides.now.node);
  loop.edge = {sides.then.node, sides.now.node,
               sides.then.T_robot_sensor * registered.T_model_scan * sides.now.T_robot_sensor.Inverse(),
               EdgeCovariance(registered.covariance, params_), true};
  loop.correction = T_old_now.Inverse() * loop.edge.T_from_to;
  loop.old_keyframe = sides.old;
  loop.new_keyframe = sides.current;
  loop.graph_distance_m = sides.graph_distance;
  if (std::abs(loop.correction.theta) > CorrectionBoundRad(sides.graph_distance) ||
      loop.correction.Translation().norm() > CorrectionBoundM(sides.graph_distance)) {
    return std::nullopt;
  }
  return loop;
}

// The quick check (not in the paper): where the graph is already right -- a place revisited
// after its loop was closed -- the estimate itself fits; it is taken when the scan fits the
// place at least quick_min_fit, without shape matching or window search.
std::optional<LoopClosure> LoopCloser::QuickMatch(const Sides& sides, const PoseGraph& graph) const {
  const std::vector<RankedCandidate> quick =
      sides.selector.Rank(sides.samples, {sides.estimate}, sides.estimate);
  if (quick.empty() || quick.front().fit < params_.quick_min_fit) return std::nullopt;
  const std::optional<RefinementResult> refined = Refine(sides, quick.front());
  if (!refined) return std::nullopt;
  std::optional<LoopClosure> loop = Verify(
      sides,
      internal::ToResult(quick.front(), *refined, sides.selector.Fit(sides.samples, refined->T_map_scan)),
      graph);
  if (loop && loop->inlier_ratio >= params_.quick_min_fit) return loop;
  return std::nullopt;
}

std::optional<LoopClosure> LoopCloser::FullMatch(const Sides& sides, const PoseGraph& graph) const {
  const Pose2& estimate = sides.estimate;
  // The window search over the whole place first: where it finds no pose at which the scan
  // overlaps the place at all, no candidate could pass the verification.
  const double bound_m = CorrectionBoundM(sides.graph_distance);
  WindowSearchParams window = match_.window_search;
  window.resolution_m = params_.window_resolution_m;
  window.hit_sigma_m = params_.window_resolution_m;
  window.half_window_m = std::min(bound_m, params_.window_half_m);
  window.half_window_rad = CorrectionBoundRad(sides.graph_distance);
  window.max_node_evaluations = params_.window_max_evaluations;
  const Pose2 centre = bound_m <= params_.window_half_m ? estimate : Pose2(0.0, 0.0, estimate.theta);
  const WindowSearch search(sides.place.fine, window);
  const std::vector<Point2> coarse_samples = internal::Thinned(
      sides.samples, match_.matcher.alignment.sample_spacing_m, match_.window_search_spacing_m);
  const std::vector<WindowHypothesis> hypotheses = search.Search(coarse_samples, centre);
  double best_window_fit = 0.0;
  for (const WindowHypothesis& h : hypotheses) best_window_fit = std::max(best_window_fit, h.fit);
  if (best_window_fit < params_.window_min_fit) return std::nullopt;
  // Candidates: the estimate, the shape match with it as guess and the one without (§4.3), and
  // the window search's best poses.
  std::vector<Pose2> candidates = {estimate};
  for (const std::optional<Pose2>& guess : {std::optional<Pose2>(estimate), std::optional<Pose2>()}) {
    if (auto c = ShapeCandidate(sides.now.shapes, sides.place.coarse, guess, estimate, match_)) {
      candidates.push_back(*c);
    }
  }
  for (const WindowHypothesis& h : hypotheses) candidates.push_back(h.T_model_scan);
  // Among fits that explain the scan about equally well the one nearest the estimate wins:
  // repetitive places (parallel corridors, rows of doors) offer look-alike fits farther away.
  // A candidate fitting less than refine_min_fit is not refined: the verification would refuse it.
  const auto refine = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
    if (c.fit < params_.refine_min_fit) return std::nullopt;
    return Refine(sides, c);
  };
  const internal::RegistrationResult registered = internal::RegisterCandidates(
      sides.samples, sides.selector, candidates, estimate, match_.selection.max_refinements, refine);
  if (!registered.converged) return std::nullopt;
  return Verify(sides, registered, graph);
}

bool LoopCloser::AsksLargeCorrection(const LoopClosure& closure) const {
  return params_.confirm_near_m > 0.0 &&
         closure.correction.Translation().norm() > params_.max_correction_m;
}

// Within confirm_within_keyframes of each other; or, both asking a large correction, new
// keyframes within confirm_near_m of each other (LoopClosureParams::confirm_near_m).
bool LoopCloser::MayConfirm(const LoopClosure& pending, const LoopClosure& later,
                            const std::vector<LoopKeyframe>& keyframes,
                            const PoseGraph& graph) const {
  // Only a later keyframe confirms: at the end of the log (FinalUpdate) a keyframe is searched
  // again, and one before a pending closure's keyframe is searched after it.
  if (later.new_keyframe <= pending.new_keyframe) return false;
  if (later.new_keyframe - pending.new_keyframe <= params_.confirm_within_keyframes) return true;
  if (!AsksLargeCorrection(pending) || !AsksLargeCorrection(later)) return false;
  const Point2 a = graph.Node(keyframes[pending.new_keyframe].node).Translation();
  const Point2 b = graph.Node(keyframes[later.new_keyframe].node).Translation();
  return (a - b).norm() <= params_.confirm_near_m;
}

// The cycle oa -> ka (loop a) -> kb (graph) -> ob (loop b, inverted) must return to where the
// graph puts ob relative to oa. The two chains along the graph (oa..ob, ka..kb) carry the
// drift, so the tolerance grows with their length. A chain that cannot avoid a guessed step
// carries a motion nothing measured: the cycle then closes or not by chance (every 2nd scan
// without odometry: look-alike pairs 5.0-7.5 m and 0.2-0.5 rad off passed a tolerance grown to
// 8-13 m by the guessed steps' guess_graph_m).
bool LoopCloser::Consistent(const LoopClosure& a, const LoopClosure& b,
                            const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph) const {
  return ConsistentAt(a, b, keyframes, graph, static_cast<int>(keyframes.size()) - 1);
}

bool LoopCloser::ConsistentAt(const LoopClosure& a, const LoopClosure& b,
                              const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph,
                              int current) const {
  const auto distances = [&](int from, double guess_m) {
    return GraphDistances(keyframes, graph, from, guess_m, current);
  };
  const double chain_old = distances(a.old_keyframe, params_.guess_graph_m)[b.old_keyframe];
  const double chain_new = distances(a.new_keyframe, params_.guess_graph_m)[b.new_keyframe];
  // A chain shorter than guess_graph_m crosses no guessed step (each weighs that much); only a
  // longer one is searched again with guessed steps all but closed.
  constexpr double kAvoidGuess = 1e9;  // a chain this long crosses a guessed step
  const auto avoids_guess = [&](int from, int to, double chain) {
    return chain < params_.guess_graph_m ||
           distances(from, kAvoidGuess)[to] < kAvoidGuess;
  };
  if (!avoids_guess(a.old_keyframe, b.old_keyframe, chain_old) ||
      !avoids_guess(a.new_keyframe, b.new_keyframe, chain_new)) {
    return false;
  }
  const auto node = [&](int k) { return graph.Node(keyframes[k].node); };
  const Pose2 T_oa_ob = node(a.old_keyframe).Inverse() * node(b.old_keyframe);
  const Pose2 T_ka_kb = node(a.new_keyframe).Inverse() * node(b.new_keyframe);
  const Pose2 error = T_oa_ob.Inverse() * a.edge.T_from_to * T_ka_kb * b.edge.T_from_to.Inverse();
  const double chains = chain_old + chain_new;
  return error.Translation().norm() <= params_.confirm_tolerance_m + params_.confirm_tolerance_per_m * chains &&
         std::abs(error.theta) <= params_.confirm_tolerance_rad + params_.confirm_tolerance_rad_per_m * chains;
}

// One Dijkstra per search serves the candidates and their matches. The quick check at every
// candidate first: where one passes, the graph is right there and the full searches of the
// others would only find the same. The best fit wins, unless another place fits nearly as
// well somewhere else (AmbiguousMatches, LoopClosureParams::ambiguity_m).
std::optional<LoopClosure> LoopCloser::Search(const std::vector<LoopKeyframe>& keyframes,
                                              const PoseGraph& graph, int current,
                                              double max_view_angle_rad) {
  std::optional<LoopClosure> loop;
  const std::vector<double> graph_distance =
      GraphDistances(keyframes, graph, current, params_.guess_graph_m, current);
  const std::vector<int> candidates =
      CandidatesAt(keyframes, graph, graph_distance, current, max_view_angle_rad);
  if (!candidates.empty()) round_robin_ += std::max(1, params_.max_candidates - 1);
  std::vector<std::unique_ptr<Sides>> sides;
  for (const int old : candidates) {
    if (auto s = MakeSides(keyframes, graph, old, current, graph_distance[old])) {
      sides.push_back(std::move(s));
    }
  }
  const auto keep_best = [&](std::optional<LoopClosure> candidate) {
    if (candidate && (!loop || candidate->inlier_ratio > loop->inlier_ratio)) loop = std::move(candidate);
  };
  for (const auto& s : sides) keep_best(QuickMatch(*s, graph));
  if (loop) return loop;
  std::vector<ImpliedPose> implied;  // the new keyframe's pose in the graph, as each match puts it
  for (const auto& s : sides) {
    std::optional<LoopClosure> candidate = FullMatch(*s, graph);
    if (candidate) {
      implied.push_back(
          {graph.Node(s->then.node) * candidate->edge.T_from_to, candidate->inlier_ratio});
    }
    keep_best(std::move(candidate));
  }
  if (loop && AmbiguousMatches(implied, params_.ambiguity_m, params_.ambiguity_fit_margin)) {
    if (keyframes[current].odometry) {
      if (std::optional<LoopClosure> across = AcrossCorridor(implied, *loop, graph, params_)) return across;
    }
    events_.push_back({*loop, LoopDecision::kAmbiguous});
    ++num_ambiguous_;
    return std::nullopt;
  }
  return loop;
}

namespace {

// The match that fits best (the first of equal fits, as LoopCloser::Search keeps its closure).
// Requires a non-empty vector.
const ImpliedPose& BestFit(const std::vector<ImpliedPose>& implied) {
  return *std::max_element(implied.begin(), implied.end(),
                           [](const ImpliedPose& a, const ImpliedPose& b) { return a.fit < b.fit; });
}

}  // namespace

bool AmbiguousMatches(const std::vector<ImpliedPose>& implied, double ambiguity_m,
                      double fit_margin) {
  if (ambiguity_m <= 0.0 || implied.empty()) return false;
  const ImpliedPose& best = BestFit(implied);
  return std::any_of(implied.begin(), implied.end(), [&](const ImpliedPose& other) {
    return other.fit >= best.fit - fit_margin &&
           (other.T_graph_keyframe.Translation() - best.T_graph_keyframe.Translation()).norm() >
               ambiguity_m;
  });
}

std::optional<LoopClosure> AcrossCorridor(const std::vector<ImpliedPose>& implied,
                                          const LoopClosure& best, const PoseGraph& graph,
                                          const LoopClosureParams& params) {
  if (params.corridor_sigma_m <= 0.0 || implied.empty()) return std::nullopt;
  const ImpliedPose& top = BestFit(implied);
  // The rivals in the best match's keyframe frame: one heading, and the line through the farthest.
  std::vector<Point2> rivals;
  Point2 farthest = Point2::Zero();
  for (const ImpliedPose& other : implied) {
    if (other.fit < top.fit - params.ambiguity_fit_margin) continue;
    const Pose2 T = top.T_graph_keyframe.Inverse() * other.T_graph_keyframe;
    if (std::abs(T.theta) > params.corridor_heading_rad) return std::nullopt;
    rivals.push_back(T.Translation());
    if (T.Translation().norm() > farthest.norm()) farthest = T.Translation();
  }
  if (farthest.norm() <= params.ambiguity_m) return std::nullopt;
  const Point2 along = farthest.normalized();
  for (const Point2& p : rivals) {
    if (std::abs(along.x() * p.y() - along.y() * p.x()) > params.corridor_offset_m) return std::nullopt;
  }
  // The edge's position moved along the line to the graph's: the closure asks nothing there.
  LoopClosure across = best;
  const Pose2& measured = best.edge.T_from_to;
  const Point2 along_old = Eigen::Rotation2Dd(measured.theta) * along;  // in the old keyframe's frame
  const Pose2 T_old_new = graph.Node(best.edge.from).Inverse() * graph.Node(best.edge.to);
  const Point2 t = measured.Translation() +
                   (T_old_new.Translation() - measured.Translation()).dot(along_old) * along_old;
  across.edge.T_from_to = Pose2(t.x(), t.y(), measured.theta);
  across.edge.covariance.topLeftCorner<2, 2>() +=
      params.corridor_sigma_m * params.corridor_sigma_m * along_old * along_old.transpose();
  across.correction = T_old_new.Inverse() * across.edge.T_from_to;
  across.across_only = true;
  across.along_rad = std::atan2(along_old.y(), along_old.x());
  return across;
}

// The closures already in the graph vote on the new ones: the graph optimised with them must
// still agree with the earlier loop edges it agreed with (a wrong pair of consistent closures
// bends the graph away from them).
bool LoopCloser::BreaksEarlierLoops(const PoseGraph& graph,
                                    const std::vector<LoopClosure>& accepted) const {
  PoseGraph trial = graph;
  for (const LoopClosure& a : accepted) trial.AddEdge(a.edge);
  trial.Optimize(params_.graph);
  int broken = 0, kept = 0;
  const auto agrees = [&](const PoseGraph& g, const PoseGraphEdge& e) {
    const Pose2 error = e.T_from_to.Inverse() * (g.Node(e.from).Inverse() * g.Node(e.to));
    return error.Translation().norm() <= params_.verify_tolerance_m &&
           std::abs(error.theta) <= params_.verify_tolerance_rad;
  };
  for (const PoseGraphEdge& e : graph.Edges()) {
    if (!e.loop || !agrees(graph, e)) continue;
    (agrees(trial, e) ? kept : broken) += 1;
  }
  return broken > params_.max_broken_fraction * (broken + kept);
}

bool LoopCloser::Update(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph) {
  const int current = static_cast<int>(keyframes.size()) - 1;
  if (!params_.enabled || current < 1 || current % params_.search_every != 0) return false;
  return SearchAndDecide(keyframes, graph, current, params_.max_view_angle_rad);
}

// Keyframes between the final searches (LoopClosureParams::final_searches).
constexpr int kFinalSearchSpacing = 2;

bool LoopCloser::FinalUpdate(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph,
                             const std::function<void()>& optimize) {
  const int last = static_cast<int>(keyframes.size()) - 1;
  const bool any = params_.final_searches > 0 || params_.final_sweep_every > 0;
  if (!params_.enabled || !any || last < 1 || last == final_searched_) return false;
  final_searched_ = last;
  // The sweep (final_sweep_every): a pass of its own over the keyframes, earliest first, each
  // searched as if it were the last. The closures still pending from the run's last searches
  // wait for the final searches (no keyframe of the sweep comes after them).
  if (params_.final_sweep_every > 0) {
    std::vector<LoopClosure> run_pending;
    run_pending.swap(pending_);
    for (int current = params_.final_sweep_every; current < last; current += params_.final_sweep_every) {
      if (SearchAndDecide(keyframes, graph, current, M_PI)) optimize();
    }
    pending_.insert(pending_.end(), run_pending.begin(), run_pending.end());
  }
  // The final searches, earliest first, each as if it were the last keyframe: a closure found
  // at one may then be confirmed by the next, as during the run.
  bool moved = false;
  for (int i = params_.final_searches - 1; i >= 0; --i) {
    const int current = last - i * kFinalSearchSpacing;
    if (current < 1) continue;
    moved = SearchAndDecide(keyframes, graph, current, M_PI) || moved;
  }
  return moved;
}

bool LoopCloser::SearchAndDecide(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph,
                                 int current, double max_view_angle_rad) {
  ++num_searches_;
  pending_.erase(std::remove_if(pending_.begin(), pending_.end(),
                                [&](const LoopClosure& p) {
                                  const int window =
                                      AsksLargeCorrection(p)
                                          ? std::max(params_.confirm_within_keyframes,
                                                     params_.confirm_near_keyframes)
                                          : params_.confirm_within_keyframes;
                                  return current - p.new_keyframe > window;
                                }),
                 pending_.end());
  std::optional<LoopClosure> loop = Search(keyframes, graph, current, max_view_angle_rad);
  if (!loop) return false;
  ++num_found_;
  const Pose2& c = loop->correction;
  const double moved = c.Translation().norm();
  if (moved <= params_.min_correction_m && std::abs(c.theta) <= params_.min_correction_rad) {
    graph.AddEdge(loop->edge);  // agrees with the graph: one more constraint, nothing to correct
    events_.push_back({*loop, LoopDecision::kAgreed});
    ++num_accepted_;
    return false;
  }
  const bool strong = loop->inlier_ratio >= params_.strong_inlier_ratio &&
                      loop->reverse_inlier_ratio >= params_.strong_inlier_ratio &&
                      moved <= params_.max_correction_m && std::abs(c.theta) <= params_.max_correction_rad;
  std::vector<LoopClosure> accepted;
  if (!strong) {
    // A single match must not bend the map: wait for one that agrees with it.
    for (const LoopClosure& p : pending_) {
      if (MayConfirm(p, *loop, keyframes, graph) && ConsistentAt(p, *loop, keyframes, graph, current)) {
        accepted.push_back(p);
      }
    }
    if (accepted.empty()) {
      events_.push_back({*loop, LoopDecision::kPending});
      pending_.push_back(*loop);
      return false;
    }
  }
  accepted.push_back(*loop);
  if (BreaksEarlierLoops(graph, accepted)) {
    for (const LoopClosure& a : accepted) events_.push_back({a, LoopDecision::kRefused});
    ++num_rejected_;
    pending_.clear();
    return false;
  }
  for (const LoopClosure& a : accepted) {
    graph.AddEdge(a.edge);
    events_.push_back({a, strong ? LoopDecision::kTaken : LoopDecision::kConfirmed});
  }
  num_accepted_ += static_cast<int>(accepted.size());
  pending_.clear();
  return true;
}

}  // namespace shape_slam
