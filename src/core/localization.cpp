#include "shape_slam/internal/localization.h"

#include "shape_slam/internal/model_icp.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <utility>

#include "shape_slam/alignment.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/shape_matcher.h"

namespace shape_slam::internal {
namespace {

// Whether an estimate lies within max_sigma standard deviations (Mahalanobis) of the prior.
bool WithinPrior(const Pose2& estimate, const PosePrior& prior, double max_sigma) {
  const Pose2 d = prior.T_map_scan.Inverse() * estimate;
  const Eigen::Vector3d e(d.x, d.y, d.theta);
  return e.dot(prior.covariance.ldlt().solve(e)) <= max_sigma * max_sigma;
}

// Without odometry: whether a correction of the prediction (the last pose) implies a motion a
// robot can make between two scans (`growth` times more after scans without a match).
bool WithinMotionBound(const Pose2& correction, double growth, const ShapeSlamParams& params) {
  return correction.Translation().norm() <= growth * params.max_motion_per_scan_m &&
         std::abs(correction.theta) <= std::min(M_PI, growth * params.max_turn_per_scan_rad);
}

// Shape matching (§4.2, §4.3) of the scan against one model; its alignment is a candidate.
std::optional<Pose2> ShapeCandidate(const Shapes& shapes, const std::vector<Polyline>& model,
                                    bool model_cyclic, const std::optional<Pose2>& guess,
                                    const std::optional<Pose2>& velocity_hint,
                                    const ShapeSlamParams& params, int& matched_pairs) {
  if (model.empty()) return std::nullopt;
  ShapeMatchInput input;
  input.scan = shapes.coarse;
  input.scan_fine = shapes.fine;
  input.model = model;
  input.model_cyclic = model_cyclic || !guess;
  if (!guess) {
    input.hint_estimates.push_back(Pose2());  // the robot did not move
    if (velocity_hint) input.hint_estimates.push_back(*velocity_hint);
  }
  const ShapeMatchResult match = MatchShapes(input, guess, params.matcher);
  matched_pairs = std::max(matched_pairs, static_cast<int>(match.matches.size()));
  if (match.matches.empty()) return std::nullopt;
  return match.T_model_scan;
}

// The candidate selection of the localization: the coarse gate captures, the matcher's inlier
// distance scores.
CandidateSelectionParams SelectionFor(const ShapeSlamParams& params) {
  CandidateSelectionParams selection = params.selection;
  selection.capture_distance_m = params.coarse_gate_m;
  selection.inlier_distance_m = params.matcher.inlier_distance_m;
  return selection;
}

// The estimate of a refinement, with its fit (inlier ratio) to the model.
void Take(const RefinementResult& refined, double fit, const ShapeSlamParams& params,
          Localization& loc) {
  loc.correction = refined.T_map_scan;
  loc.covariance = refined.covariance;
  loc.rms_error_m = refined.rms_error_m;
  loc.inlier_ratio = fit;
  loc.trusted = fit >= params.min_inlier_ratio;
}

// The fast track (with odometry, not in the paper; ShapeSlamParams::fast_track_min_fit): the
// prediction alone, refined against the model; taken when the scan fits it by
// min_fit before and after and the estimate stays near the prediction. `loc` is set only then.
bool FastTrack(const std::vector<Point2>& samples, const std::vector<Polyline>& model,
               const CandidateSelector& selector, const PosePrior& prior, double min_fit,
               const ShapeSlamParams& params, Localization& loc) {
  const auto near_prediction = [&](const Pose2& T) {
    return T.Translation().norm() <= params.fast_track_max_correction_m &&
           std::abs(T.theta) <= params.fast_track_max_correction_rad &&
           WithinPrior(T, prior, params.max_prior_mahalanobis);
  };
  const std::vector<RankedCandidate> fast = selector.Rank(samples, {Pose2()}, Pose2(), near_prediction);
  if (fast.empty() || fast.front().fit < min_fit) return false;
  const RefinementResult refined =
      RefineAlignment(samples, model, fast.front().T_model_scan, prior, params.refinement);
  const double fit = refined.converged ? selector.Fit(samples, refined.T_map_scan) : 0.0;
  if (fit < min_fit || !near_prediction(refined.T_map_scan)) return false;
  Take(refined, fit, params, loc);
  loc.fast_track = true;
  return true;
}

}  // namespace

// Covariance of the odometry increment T_prev_cur, as a prior on the correction.
Eigen::Matrix3d OdometryCovariance(const Pose2& delta, const OdometryNoiseParams& noise) {
  const double distance = delta.Translation().norm();
  const double turn = std::abs(delta.theta);
  const double sxy = noise.sigma_xy_m + noise.sigma_xy_per_m * distance;
  const double sth =
      noise.sigma_theta_rad + noise.sigma_theta_per_rad * turn + noise.sigma_theta_per_m * distance;
  return Eigen::Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
}

// The window search's hypotheses around a centre, in a window scaled by `scale`.
std::vector<Pose2> WindowCandidates(const std::vector<Polyline>& model,
                                    const std::vector<Point2>& samples, const Pose2& centre,
                                    double scale, const ShapeSlamParams& params) {
  WindowSearchParams window = params.window_search;
  window.half_window_m *= scale;
  window.half_window_rad *= scale;
  const WindowSearch search(model, window);
  std::vector<Pose2> candidates;
  const std::vector<Point2> coarse =
      Thinned(samples, params.matcher.alignment.sample_spacing_m, params.window_search_spacing_m);
  for (const WindowHypothesis& h : search.Search(coarse, centre)) candidates.push_back(h.T_model_scan);
  return candidates;
}

// Candidates from shape matching against the visible map and the last keyframe (§4.2, §4.3),
// the prediction and, without odometry, the hints and the window search; the candidate
// selection ranks them and the first that the Ceres refinement and the gates accept wins.
Localization Localize(const Shapes& shapes, const LocalModel& model,
                      const std::optional<Pose2>& odometry_delta,
                      const std::optional<Pose2>& velocity_hint, int lost_scans,
                      const ShapeSlamParams& params) {
  Localization loc;
  const double growth = odometry_delta ? 1.0 : std::min(1.0 + lost_scans, params.max_lost_growth);
  std::optional<Pose2> guess;
  std::optional<PosePrior> prior;
  if (odometry_delta) {
    guess = Pose2();  // the model is already seen from the odometry prediction
    prior = PosePrior{Pose2(), OdometryCovariance(*odometry_delta, params.odometry_noise)};
  }
  std::vector<Polyline> all = model.map;
  all.insert(all.end(), model.recent_fine.begin(), model.recent_fine.end());
  const std::vector<Point2> samples =
      AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
  if (samples.empty() || all.empty()) return loc;
  CandidateSelectionParams selection = SelectionFor(params);
  if (!odometry_delta) {
    selection.prior_weight = params.motion_prior_weight;
    selection.prior_sigma_m = growth * params.motion_prior_sigma_m;
    selection.prior_sigma_rad = growth * params.motion_prior_sigma_rad;
  }
  const CandidateSelector selector(all, selection);
  // Between equally good fits the one nearest the prediction (with odometry) or the
  // constant-velocity extrapolation (without) wins.
  const Pose2 reference = guess.value_or(velocity_hint.value_or(Pose2()));
  // Without odometry, the constant-velocity motion is a weak prior of the refinement: it
  // decides only the directions the scan leaves unconstrained (along a featureless corridor).
  std::optional<PosePrior> motion_prior;
  if (!odometry_delta && velocity_hint && params.motion_prior_weight > 0.0) {
    const double sm = growth * params.motion_prior_sigma_m, sr = growth * params.motion_prior_sigma_rad;
    motion_prior = PosePrior{*velocity_hint, Eigen::Vector3d(sm * sm, sm * sm, sr * sr).asDiagonal()};
  }
  const auto accept = [&](const Pose2& T) {
    return prior ? WithinPrior(T, *prior, params.max_prior_mahalanobis)
                 : WithinMotionBound(T, growth, params);
  };
  // The visible map as shape matching sees it, derived only when shape matching runs.
  std::vector<Polyline> map_coarse;
  const auto localize = [&](const ShapeMatcherParams& matcher, double window_scale) {
    ShapeSlamParams p = params;
    p.matcher = matcher;
    std::vector<Pose2> candidates;
    if (map_coarse.empty()) {
      for (const Polyline& m : model.map) map_coarse.push_back(ForShapeMatching(m, params.shapes));
    }
    for (const auto& [shape_model, cyclic] : {std::pair{&std::as_const(map_coarse), model.map_cyclic},
                                              std::pair{&model.recent_coarse, false}}) {
      if (auto c = ShapeCandidate(shapes, *shape_model, cyclic, guess, velocity_hint, p,
                                  loc.matched_pairs)) {
        candidates.push_back(*c);
      }
    }
    if (guess) candidates.push_back(*guess);
    if (!guess) {
      candidates.push_back(Pose2());  // the robot did not move
      if (velocity_hint) candidates.push_back(*velocity_hint);
    }
    if (window_scale > 0.0) {
      for (const Pose2& c : WindowCandidates(all, samples, reference, window_scale, params)) {
        candidates.push_back(c);
      }
    }
    const auto refine = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
      RefinementResult refined =
          RefineAlignment(samples, all, c.T_model_scan, prior ? prior : motion_prior, params.refinement);
      if (!refined.converged || !accept(refined.T_map_scan)) return std::nullopt;
      return refined;
    };
    const auto selected = SelectRefined<RefinementResult>(
        selector.Rank(samples, candidates, reference, accept), selection.max_refinements, refine);
    if (!selected) return;
    const RefinementResult& refined = selected->second;
    Take(refined, selector.Fit(samples, refined.T_map_scan), params, loc);
  };
  // The fast track (with odometry): the prediction alone, refined; shape matching only when it
  // falls short.
  if (prior) FastTrack(samples, all, selector, *prior, params.fast_track_min_fit, params, loc);
  const bool window_now = !odometry_delta && params.window_search_without_odometry;
  if (!loc.fast_track) localize(params.matcher, window_now ? growth : 0.0);
  // A scan that found no trusted match tries again: without odometry with as many seed pairs
  // as scan-to-scan matching uses (scan_match_*), with odometry with the window search around
  // the prediction (window_search_fallback). Needed only for the odd scan.
  if (!loc.trusted && !odometry_delta) {
    ShapeMatcherParams thorough = params.matcher;
    thorough.max_seed_pairs = params.scan_match_seed_pairs;
    thorough.num_seeds = params.scan_match_seeds;
    localize(thorough, window_now ? growth : 0.0);
  } else if (!loc.trusted && params.window_search_fallback) {
    localize(params.matcher, params.window_search_odometry_scale);
  }
  // Unconfirmed: the prediction, which without odometry is the constant-velocity one (a robot
  // that was moving most likely still is).
  // Its coverage decides whether it may still update the map (new territory).
  if (!loc.trusted) {
    loc.correction = odometry_delta ? Pose2() : velocity_hint.value_or(Pose2());
    const SegmentGrid near(MakeModelSegments(all), params.new_territory_distance_m);
    loc.coverage = InlierRatio(samples, near, loc.correction);
  }
  return loc;
}

Localization TrackKeyframe(const Shapes& shapes, const std::vector<Polyline>& keyframe_fine,
                           const Pose2& odometry_delta, const ShapeSlamParams& params) {
  Localization loc;
  const std::vector<Point2> samples =
      AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
  if (samples.empty() || keyframe_fine.empty()) return loc;
  const CandidateSelector selector(keyframe_fine, SelectionFor(params));
  const PosePrior prior{Pose2(), OdometryCovariance(odometry_delta, params.odometry_noise)};
  FastTrack(samples, keyframe_fine, selector, prior, params.keyframe_track_min_fit, params, loc);
  return loc;  // FastTrack sets nothing when it falls short
}

}  // namespace shape_slam::internal
