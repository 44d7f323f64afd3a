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
#include "shape_slam/visibility.h"

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
                                    const ShapeMatcherParams& matcher, int& matched_pairs) {
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
  const ShapeMatchResult match = MatchShapes(input, guess, matcher);
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
void Take(const RegistrationResult& registered, const ShapeSlamParams& params, Localization& loc) {
  loc.correction = registered.T_model_scan;
  loc.covariance = registered.covariance;
  loc.rms_error_m = registered.rms_error_m;
  loc.inlier_ratio = registered.fit;
  loc.trusted = registered.fit >= params.min_inlier_ratio;
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
  Take(ToResult(fast.front(), refined, fit), params, loc);
  loc.fast_track = true;
  return true;
}

}  // namespace

VisibilityParams ModelVisibility(const LaserScan& scan, bool no_estimate,
                                 const ShapeSlamParams& params) {
  VisibilityParams visibility =
      VisibilityForScan(scan, params.visibility, params.shapes.extraction.min_range_m,
                        params.visibility_fov_margin_rad);
  if (no_estimate) {
    visibility.fov_rad = 2.0 * M_PI;
    visibility.max_range_m = std::min(params.visibility.max_range_m,
                                      visibility.max_range_m + params.max_motion_per_scan_m);
  }
  return visibility;
}

LocalModel VisibleModel(const std::vector<VisiblePolyline>& visible,
                        const VisibilityParams& visibility) {
  LocalModel model;
  for (const VisiblePolyline& v : visible) model.map.push_back(v.points_sensor);
  model.map_cyclic = visibility.fov_rad >= 2.0 * M_PI - 1e-9;
  return model;
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

// One scan's registration against its local model: the samples, the model, the prior (odometry)
// or motion bound (without), and the candidate selection that every attempt of Localize shares.
class TrackingSearch {
 public:
  TrackingSearch(const Shapes& shapes, const LocalModel& model,
                 const std::optional<Pose2>& odometry_delta,
                 const std::optional<Pose2>& velocity_hint, int lost_scans,
                 const ShapeSlamParams& params)
      : shapes_(shapes), model_(model), velocity_hint_(velocity_hint), params_(params),
        growth_(odometry_delta ? 1.0 : std::min(1.0 + lost_scans, params.max_lost_growth)) {
    if (odometry_delta) {
      guess_ = Pose2();  // the model is already seen from the odometry prediction
      prior_ = PosePrior{Pose2(), OdometryCovariance(*odometry_delta, params.odometry_noise),
                         params.odometry_noise.loss_sigmas};
    }
    all_ = model.map;
    all_.insert(all_.end(), model.recent_fine.begin(), model.recent_fine.end());
    samples_ = AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
    if (Empty()) return;
    selection_ = SelectionFor(params);
    if (!odometry_delta) {
      selection_.prior_weight = params.motion_prior_weight;
      selection_.prior_sigma_m = growth_ * params.motion_prior_sigma_m;
      selection_.prior_sigma_rad = growth_ * params.motion_prior_sigma_rad;
      selection_.prior_max_penalty = params.motion_prior_max_penalty;
      if (params.motion_unknown_beyond_ends) selection_.open_end_m = params.max_motion_per_scan_m;
    }
    selector_.emplace(all_, selection_);
    // Between equally good fits the one nearest the prediction (with odometry) or the
    // constant-velocity extrapolation (without) wins.
    reference_ = guess_.value_or(velocity_hint.value_or(Pose2()));
    // Without odometry, the constant-velocity motion is a weak prior of the refinement: it
    // decides only the directions the scan leaves unconstrained (along a featureless corridor).
    if (!odometry_delta && velocity_hint && params.motion_prior_weight > 0.0) {
      const double sm = growth_ * params.motion_prior_sigma_m;
      const double sr = growth_ * params.motion_prior_sigma_rad;
      motion_prior_ =
          PosePrior{*velocity_hint, Eigen::Vector3d(sm * sm, sm * sm, sr * sr).asDiagonal()};
    }
  }

  bool Empty() const { return samples_.empty() || all_.empty(); }
  double growth() const { return growth_; }

  /// With odometry: the prediction alone, refined (see FastTrack above).
  void TryFastTrack(Localization& loc) const {
    if (prior_) FastTrack(samples_, all_, *selector_, *prior_, params_.fast_track_min_fit, params_, loc);
  }

  /// The candidates ranked by the candidate selection; the first that the Ceres refinement and
  /// the gates accept sets `loc`.
  void Run(const ShapeMatcherParams& matcher, double window_scale, Localization& loc) {
    const std::vector<Pose2> candidates = Candidates(matcher, window_scale, loc.matched_pairs);
    const auto accept = [&](const Pose2& T) { return Accept(T); };
    const auto refine = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
      RefinementResult refined = RefineAlignment(samples_, all_, c.T_model_scan,
                                                 prior_ ? prior_ : motion_prior_, params_.refinement);
      if (!refined.converged || !Accept(refined.T_map_scan)) return std::nullopt;
      return refined;
    };
    const RegistrationResult registered = RegisterCandidates(
        samples_, *selector_, candidates, reference_, selection_.max_refinements, refine, accept);
    if (registered.converged) Take(registered, params_, loc);
  }

  /// Unconfirmed: the prediction, which without odometry is the constant-velocity one (a robot
  /// that was moving most likely still is). Its coverage decides whether it may still update
  /// the map (new territory).
  void Unconfirmed(Localization& loc) const {
    if (loc.inlier_ratio > 0.0) loc.best_untrusted = loc.correction;  // a refinement converged
    loc.correction = guess_ ? Pose2() : velocity_hint_.value_or(Pose2());
    const SegmentGrid near(MakeModelSegments(all_), params_.new_territory_distance_m);
    loc.coverage = InlierRatio(samples_, near, loc.correction);
  }

 private:
  bool Accept(const Pose2& T) const {
    return prior_ ? WithinPrior(T, *prior_, params_.max_prior_mahalanobis)
                  : WithinMotionBound(T, growth_, params_);
  }

  // Shape matching against the visible map and the last keyframe (§4.2, §4.3), the prediction
  // and, without odometry, the hints and the window search.
  std::vector<Pose2> Candidates(const ShapeMatcherParams& matcher, double window_scale,
                                int& matched_pairs) {
    std::vector<Pose2> candidates;
    if (map_coarse_.empty()) {  // derived only when shape matching runs
      for (const Polyline& m : model_.map) map_coarse_.push_back(ForShapeMatching(m, params_.shapes));
    }
    for (const auto& [shape_model, cyclic] :
         {std::pair{&std::as_const(map_coarse_), model_.map_cyclic},
          std::pair{&model_.recent_coarse, false}}) {
      if (auto c = ShapeCandidate(shapes_, *shape_model, cyclic, guess_, velocity_hint_, matcher,
                                  matched_pairs)) {
        candidates.push_back(*c);
      }
    }
    if (guess_) candidates.push_back(*guess_);
    if (!guess_) {
      candidates.push_back(Pose2());  // the robot did not move
      if (velocity_hint_) candidates.push_back(*velocity_hint_);
    }
    if (window_scale > 0.0) {
      for (const Pose2& c : WindowCandidates(all_, samples_, reference_, window_scale, params_)) {
        candidates.push_back(c);
      }
    }
    return candidates;
  }

  const Shapes& shapes_;
  const LocalModel& model_;
  const std::optional<Pose2> velocity_hint_;
  const ShapeSlamParams& params_;
  const double growth_;
  std::optional<Pose2> guess_;
  std::optional<PosePrior> prior_, motion_prior_;
  std::vector<Polyline> all_;  // the visible map and the last keyframe
  std::vector<Point2> samples_;
  CandidateSelectionParams selection_;
  std::optional<CandidateSelector> selector_;
  Pose2 reference_;
  std::vector<Polyline> map_coarse_;  // the visible map as shape matching sees it
};

// The fast track first (with odometry); shape matching only when it falls short; a second,
// wider attempt for a scan that found no trusted match; else the prediction, unconfirmed.
Localization Localize(const Shapes& shapes, const LocalModel& model,
                      const std::optional<Pose2>& odometry_delta,
                      const std::optional<Pose2>& velocity_hint, int lost_scans,
                      const ShapeSlamParams& params) {
  Localization loc;
  TrackingSearch search(shapes, model, odometry_delta, velocity_hint, lost_scans, params);
  if (search.Empty()) return loc;
  search.TryFastTrack(loc);
  const double window_scale =
      !odometry_delta && params.window_search_without_odometry ? search.growth() : 0.0;
  if (!loc.fast_track) search.Run(params.matcher, window_scale, loc);
  // A scan that found no trusted match tries again: without odometry with as many seed pairs
  // as scan-to-scan matching uses (scan_match_*; thorough_retry), with odometry with the window
  // search around the prediction (window_search_fallback). Needed only for the odd scan.
  if (!loc.trusted && !odometry_delta && params.thorough_retry) {
    ShapeMatcherParams thorough = params.matcher;
    thorough.max_seed_pairs = params.scan_match_seed_pairs;
    thorough.num_seeds = params.scan_match_seeds;
    search.Run(thorough, window_scale, loc);
  } else if (!loc.trusted && params.window_search_fallback) {
    search.Run(params.matcher, params.window_search_odometry_scale, loc);
  }
  if (!loc.trusted) search.Unconfirmed(loc);
  return loc;
}

Localization TrackKeyframe(const Shapes& shapes, const std::vector<Polyline>& keyframe_fine,
                           const Pose2& odometry_delta, const ShapeSlamParams& params) {
  Localization loc;
  const std::vector<Point2> samples =
      AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
  if (samples.empty() || keyframe_fine.empty()) return loc;
  const CandidateSelector selector(keyframe_fine, SelectionFor(params));
  const PosePrior prior{Pose2(), OdometryCovariance(odometry_delta, params.odometry_noise),
                       params.odometry_noise.loss_sigmas};
  FastTrack(samples, keyframe_fine, selector, prior, params.keyframe_track_min_fit, params, loc);
  return loc;  // FastTrack sets nothing when it falls short
}

}  // namespace shape_slam::internal
