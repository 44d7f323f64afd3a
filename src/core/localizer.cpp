#include "shape_slam/localizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "shape_slam/internal/localization.h"
#include "shape_slam/internal/validation.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam/visibility.h"

namespace shape_slam {
namespace {

void InRange(double value, double lo, double hi, const std::string& name) {
  if (!(value >= lo && value <= hi)) {
    throw std::invalid_argument(name + " must be in [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "]");
  }
}

void AtLeastOne(int value, const std::string& name) {
  if (value < 1) throw std::invalid_argument(name + " must be >= 1");
}

// The params validated, the localizer's fast track fit in its stages (LocalizerParams::
// fast_track_min_fit).
LocalizerParams Validated(const LocalizerParams& params) {
  params.Validate();
  LocalizerParams own = params;
  own.stages.fast_track_min_fit = params.fast_track_min_fit;
  return own;
}

using internal::ValidateScan;  // shared with the mapper

std::vector<Polyline> MapWalls(const PolylineMap& map) {
  if (map.Empty()) throw std::invalid_argument("Localizer: the map is empty");
  return map.Polylines();
}

// Window centres on a grid covering the map's bounding box, 2 * tile_half_m apart.
// The global search's window: one tile (with a cell of overlap), every turn, no prior.
// The global search's field covers at most this many cells per side: 2048 at 0.2 m is a map
// of 400 m without coarsening (memory: one byte per cell and pyramid level).
constexpr int kGlobalMaxCellsPerSide = 2048;

WindowSearchParams GlobalSearchParams(const LocalizerParams& params) {
  WindowSearchParams window = params.stages.window_search;
  window.resolution_m = params.global_resolution_m;
  window.hit_sigma_m = params.global_hit_sigma_m;
  window.max_step_range_m = params.global_max_step_range_m;
  window.half_window_m = params.global_tile_half_m + params.global_resolution_m;
  window.half_window_rad = M_PI;
  window.prior_weight = 0.0;
  window.max_hypotheses = params.global_hypotheses;
  window.min_relative_score = 0.0;
  window.max_node_evaluations = params.global_node_evaluations;
  window.max_cells_per_side = kGlobalMaxCellsPerSide;
  window.distinct_m = params.distinct_m;
  window.distinct_rad = params.distinct_rad;
  return window;
}

// What a scan is matched against from a sensor pose: the visible map shape (§3), around the
// scan's field of view, or all around and a motion farther when the pose is only a guess (§4.3;
// internal::ModelVisibility); with `seen`, without what the scan saw through, and with the
// occlusion tolerance at least depth_tolerance_m. The tracked pose's recent scan is added by
// Track.
internal::LocalModel ModelAt(const PolylineMap& map, const LaserScan& scan,
                             const Pose2& T_map_sensor, bool all_around, const ShapeSlamParams& p,
                             double depth_tolerance_m, const SeenRays* seen) {
  VisibilityParams visibility = internal::ModelVisibility(scan, all_around, p);
  visibility.depth_tolerance_m = std::max(visibility.depth_tolerance_m, depth_tolerance_m);
  return internal::VisibleModel(map.Visible(T_map_sensor, visibility, seen), visibility);
}

bool Near(const Pose2& a, const Pose2& b, const LocalizerParams& params) {
  return PosesWithin(a, b, params.distinct_m, params.distinct_rad);
}

}  // namespace

void LocalizerParams::Validate() const {
  stages.Validate();
  InRange(min_inlier_ratio, 0.0, 1.0, "LocalizerParams::min_inlier_ratio");
  InRange(relative_inlier_ratio, 0.0, 1.0, "LocalizerParams::relative_inlier_ratio");
  InRange(min_global_fit, 0.0, 1.0, "LocalizerParams::min_global_fit");
  InRange(global_tile_half_m, 0.1, 1e3, "LocalizerParams::global_tile_half_m");
  InRange(global_resolution_m, 0.01, 10.0, "LocalizerParams::global_resolution_m");
  InRange(global_hit_sigma_m, 0.01, 10.0, "LocalizerParams::global_hit_sigma_m");
  InRange(global_max_step_range_m, 1.0, 1e3, "LocalizerParams::global_max_step_range_m");
  AtLeastOne(global_node_evaluations, "LocalizerParams::global_node_evaluations");
  AtLeastOne(global_hypotheses, "LocalizerParams::global_hypotheses");
  AtLeastOne(max_hypotheses, "LocalizerParams::max_hypotheses");
  InRange(distinct_m, 0.0, 1e6, "LocalizerParams::distinct_m");
  InRange(distinct_rad, 0.0, M_PI, "LocalizerParams::distinct_rad");
  InRange(evidence_decay, 0.0, 0.999, "LocalizerParams::evidence_decay");
  InRange(ambiguous_margin_samples, 0.0, 1e9, "LocalizerParams::ambiguous_margin_samples");
  AtLeastOne(lost_after_scans, "LocalizerParams::lost_after_scans");
  InRange(fit_drop_ratio, 0.0, 1.0, "LocalizerParams::fit_drop_ratio");
  AtLeastOne(fit_drop_scans, "LocalizerParams::fit_drop_scans");
  InRange(fit_mean_weight, 1e-6, 1.0, "LocalizerParams::fit_mean_weight");
  InRange(retry_depth_tolerance_m, 0.0, 100.0, "LocalizerParams::retry_depth_tolerance_m");
  InRange(see_through_margin_m, 0.0, 100.0, "LocalizerParams::see_through_margin_m");
  InRange(off_map_fit, 0.0, 1.0, "LocalizerParams::off_map_fit");
  AtLeastOne(off_map_search_every, "LocalizerParams::off_map_search_every");
  if (off_map_confirm_scans < 0) {
    throw std::invalid_argument("LocalizerParams::off_map_confirm_scans must be >= 0");
  }
  if (first_pose_confirm_scans < 0) {
    throw std::invalid_argument("LocalizerParams::first_pose_confirm_scans must be >= 0");
  }
  InRange(off_map_margin, 0.0, 1.0, "LocalizerParams::off_map_margin");
  if (recheck_every < 0) throw std::invalid_argument("LocalizerParams::recheck_every must be >= 0");
  InRange(recheck_half_window_m, 0.0, 100.0, "LocalizerParams::recheck_half_window_m");
  InRange(recheck_half_window_rad, 0.0, M_PI, "LocalizerParams::recheck_half_window_rad");
  InRange(recheck_margin, 0.0, 1.0, "LocalizerParams::recheck_margin");
  InRange(recheck_poor_fit, 0.0, 1.0, "LocalizerParams::recheck_poor_fit");
  InRange(recheck_poor_half_window_m, 0.0, 100.0, "LocalizerParams::recheck_poor_half_window_m");
  InRange(recheck_poor_half_window_rad, 0.0, M_PI, "LocalizerParams::recheck_poor_half_window_rad");
  InRange(field_track_min_fit, 0.0, 1.0, "LocalizerParams::field_track_min_fit");
  InRange(field_track_half_window_m, 0.0, 100.0, "LocalizerParams::field_track_half_window_m");
  InRange(field_track_half_window_rad, 0.0, M_PI, "LocalizerParams::field_track_half_window_rad");
  InRange(field_track_tie, 0.0, 1.0, "LocalizerParams::field_track_tie");
  InRange(field_track_check_ratio, 0.0, 1.0, "LocalizerParams::field_track_check_ratio");
  InRange(field_track_turn_below, 0.0, 1.0, "LocalizerParams::field_track_turn_below");
  field_track_turn.Validate();
  if (!(field_track_prior_sigma_m > 0.0 && field_track_prior_sigma_m <= 100.0)) {
    throw std::invalid_argument("LocalizerParams::field_track_prior_sigma_m must be in (0, 100]");
  }
  if (!(fast_track_min_fit >= 0.0)) {
    throw std::invalid_argument("LocalizerParams::fast_track_min_fit must be >= 0");
  }
}

const char* ToString(LocalizerStatus status) {
  switch (status) {
    case LocalizerStatus::kSearching: return "searching";
    case LocalizerStatus::kAmbiguous: return "ambiguous";
    case LocalizerStatus::kTracking: return "tracking";
    case LocalizerStatus::kLost: return "lost";
  }
  return "unknown";
}

Localizer::Localizer(PolylineMap map, const LocalizerParams& params)
    : params_(Validated(params)),
      map_(std::move(map)),
      walls_(MapWalls(map_)),
      global_search_(walls_, GlobalSearchParams(params_)),
      field_stages_(params_.stages),
      search_stages_(params_.stages),
      odometry_calibrator_(params_.stages.odometry_calibration) {
  field_stages_.odometry_noise.sigma_xy_m = params_.field_track_prior_sigma_m;
  if (!params_.search_retry) {
    search_stages_.window_search_fallback = false;
    search_stages_.thorough_retry = false;
  }
}

void Localizer::SetInitialPose(const Pose2& T_map_robot) {
  hypotheses_ = {Hypothesis(T_map_robot, 1.0, 0.0, params_.stages.motion_model)};
  recent_.reset();
  status_ = LocalizerStatus::kTracking;
  was_localized_ = true;
  drop_scans_ = 0;
  challenger_.reset();
  fit_mean_ = -1.0;  // set by the first match
}

// Odometry that never moved since the first scan is none, and so is odometry that stalled: its
// pose the last one's to the bit while the best hypothesis was moving (as in the mapper,
// ShapeSlamParams::stale_odometry_min_step_m; `stale`).
std::optional<Pose2> Localizer::OdometryDelta(const LaserScan& scan, bool& stale) {
  stale = false;
  if (!params_.stages.use_odometry || !scan.T_odom_robot) return std::nullopt;
  if (!odometry_motion_.Moved(*scan.T_odom_robot) || !last_T_odom_robot_) return std::nullopt;
  stale = !hypotheses_.empty() &&
          OdometryStalled(*scan.T_odom_robot, *last_T_odom_robot_,
                          hypotheses_.front().velocity.LongestRecentStep(),
                          params_.stages.stale_odometry_min_step_m);
  if (stale) return std::nullopt;
  return last_T_odom_robot_->Inverse() * *scan.T_odom_robot;
}

// The raw increment with the learned heading error taken out (OdometryCalibrator).
std::optional<Pose2> Localizer::Calibrated(const std::optional<Pose2>& raw_odometry_delta) const {
  if (!raw_odometry_delta) return std::nullopt;
  return odometry_calibrator_.Correct(*raw_odometry_delta);
}

// A scan the tracked pose matched teaches the calibration as in the mapper (ShapeSlam::
// LearnOdometry): the scan's own heading correction (without the prior's pull) plus what the
// calibration added is one sample of the raw increment's heading error.
void Localizer::LearnOdometry(const Pose2& raw_odometry_delta, const Pose2& odometry_delta,
                              const Verified& v) {
  if (!params_.stages.odometry_calibration.enabled) return;
  const std::optional<Pose2> own = ScanOwnCorrection(v.correction, v.covariance, odometry_delta,
                                                     params_.stages.odometry_noise);
  if (own) odometry_calibrator_.AddRegistration(raw_odometry_delta, odometry_delta, *own);
}

// One hypothesis through one scan: the per-scan localization of the mapper (candidates from
// shape matching §4.2-§4.3, the prediction and the window search, candidate selection, §5.1
// refinement) against the visible map from the predicted pose.
Localizer::Verified Localizer::Track(const ScanShapes& shapes, const LaserScan& scan,
                                     const Hypothesis& hypothesis,
                                     const std::optional<Pose2>& odometry_delta,
                                     int lost_scans, double min_fit,
                                     const TrackingAids& aids) const {
  const ShapeSlamParams& p = aids.stages != nullptr ? *aids.stages : params_.stages;
  Pose2 T_map_robot_pred = hypothesis.T_map_robot;
  std::optional<Pose2> velocity_hint;
  if (odometry_delta) {
    T_map_robot_pred =
        hypothesis.T_map_robot_at_odometry.value_or(hypothesis.T_map_robot) * *odometry_delta;
  } else if (const std::optional<Pose2> v = hypothesis.velocity.Predict()) {
    velocity_hint = MotionInFrame(*v, scan.T_robot_sensor);
  }
  const Pose2 T_map_sensor_pred = T_map_robot_pred * scan.T_robot_sensor;
  Verified verified;
  verified.T_map_robot = T_map_robot_pred;
  if (shapes.coarse.empty()) return verified;
  std::optional<SeenRays> seen;
  if (aids.see_through) seen = SeenRaysOf(scan, params_.see_through_margin_m);
  internal::LocalModel model = ModelAt(map_, scan, T_map_sensor_pred, !odometry_delta, p,
                                       aids.depth_tolerance_m, seen ? &*seen : nullptr);
  if (aids.recent != nullptr && p.use_last_keyframe) {
    const Pose2 T_pred_recent = T_map_sensor_pred.Inverse() * aids.recent->T_map_sensor;
    for (const Polyline& c : aids.recent->shapes.coarse) {
      model.recent_coarse.push_back(Transform(T_pred_recent, c));
    }
    for (const Polyline& f : aids.recent->shapes.fine) {
      model.recent_fine.push_back(Transform(T_pred_recent, f));
    }
  }
  const internal::Localization loc =
      internal::Localize(shapes, model, odometry_delta, velocity_hint, lost_scans, p);
  verified.T_map_robot = T_map_sensor_pred * loc.correction * scan.T_robot_sensor.Inverse();
  const std::vector<Point2> samples =
      internal::AlignmentSamples(shapes.fine, p.matcher.alignment.sample_spacing_m);
  verified.fit = loc.trusted ? loc.inlier_ratio : 0.0;
  verified.trusted = loc.trusted && loc.inlier_ratio >= min_fit;
  verified.correction = loc.correction;
  verified.covariance = loc.covariance;
  verified.explained = verified.fit * static_cast<double>(samples.size());
  return verified;
}

// The scan's samples for the global search's field (sensor frame, window_search_spacing_m).
std::vector<Point2> Localizer::GlobalSamples(const ScanShapes& shapes) const {
  const ShapeSlamParams& p = params_.stages;
  const double spacing = p.matcher.alignment.sample_spacing_m;
  return internal::Thinned(internal::AlignmentSamples(shapes.fine, spacing), spacing,
                           p.window_search_spacing_m);
}

// A pose of the global search's field (sensor frame) verified by the localization with it as a
// tight prediction, matched at min_fit or not.
Localizer::Verified Localizer::Verify(const ScanShapes& shapes, const LaserScan& scan,
                                      const Pose2& T_map_sensor, double min_fit) const {
  return VerifyRobot(shapes, scan, T_map_sensor * scan.T_robot_sensor.Inverse(), min_fit,
                     SearchAids());
}

// The aids of a search's registrations: its stages (search_retry), nothing else.
Localizer::TrackingAids Localizer::SearchAids() const {
  TrackingAids aids;
  aids.stages = &search_stages_;
  return aids;
}

// A robot pose verified as Verify does, with `aids` (the field track's: the recent scan, its
// prior).
Localizer::Verified Localizer::VerifyRobot(const ScanShapes& shapes, const LaserScan& scan,
                                           const Pose2& T_map_robot, double min_fit,
                                           const TrackingAids& aids) const {
  const Hypothesis probe(T_map_robot, 0.0, 0.0, params_.stages.motion_model);
  return Track(shapes, scan, probe, Pose2(), 0, min_fit, aids);
}

// The branch and bound over the whole map (all turns) for `samples` (GlobalSamples): its best
// distinct robot poses, best fit first, each verified (Verify); the ones matched at min_fit, in
// that order. Its params (GlobalSearchParams) have
// no motion prior, so score is fit, and the localizer's distinct_m, distinct_rad and
// global_hypotheses, so the poses are already the distinct few to verify.
std::vector<Localizer::Verified> Localizer::VerifiedGlobalPoses(const ScanShapes& shapes,
                                                                const LaserScan& scan,
                                                                const std::vector<Point2>& samples,
                                                                double min_fit) const {
  std::vector<Verified> verified;
  for (const WindowHypothesis& h : global_search_.SearchMap(samples)) {
    const Verified v = Verify(shapes, scan, h.T_model_scan, min_fit);
    if (v.trusted) verified.push_back(v);
  }
  return verified;
}

void Localizer::Motion(Hypothesis& hypothesis, const Pose2& T_map_robot, bool confirmed) {
  hypothesis.velocity.Add(hypothesis.T_map_robot.Inverse() * T_map_robot, confirmed);
  hypothesis.T_map_robot = T_map_robot;
}

// Every kept hypothesis is tracked through the scan (after a miss as a search's pose is verified,
// search_retry); its evidence decays and gains the fit. One that misses lost_after_scans scans
// in a row is dropped.
void Localizer::PropagateHypotheses(const ScanShapes& shapes, const LaserScan& scan,
                                    const std::vector<Point2>& samples,
                                    const std::optional<Pose2>& odometry_delta) {
  std::vector<Hypothesis> kept;
  for (Hypothesis& h : hypotheses_) {
    std::optional<Verified> field;
    if (FieldTrackOn(odometry_delta) && h.misses == 0) {
      field = FieldTrack(shapes, scan, samples, h, params_.min_inlier_ratio, TrackingAids{});
    }
    const TrackingAids aids = h.misses > 0 ? SearchAids() : TrackingAids{};
    const Verified v = field ? *field
                             : Track(shapes, scan, h, odometry_delta, h.misses,
                                     params_.min_inlier_ratio, aids);
    Motion(h, v.T_map_robot, v.trusted);
    h.fit = v.fit;
    h.evidence = params_.evidence_decay * h.evidence + v.explained;
    h.misses = v.trusted ? 0 : h.misses + 1;
    if (h.misses < params_.lost_after_scans) kept.push_back(std::move(h));
  }
  hypotheses_ = std::move(kept);
}

// The global search's poses, each verified by the localization with it as a tight prediction;
// the trusted ones not already kept become new hypotheses.
void Localizer::AddGlobalHypotheses(const ScanShapes& shapes, const LaserScan& scan,
                                    const std::vector<Point2>& samples) {
  for (const Verified& v : VerifiedGlobalPoses(shapes, scan, samples, params_.min_inlier_ratio)) {
    const bool known = std::any_of(hypotheses_.begin(), hypotheses_.end(), [&](const Hypothesis& h) {
      return Near(h.T_map_robot, v.T_map_robot, params_);
    });
    if (!known) {
      hypotheses_.push_back(Hypothesis(v.T_map_robot, v.explained, v.fit, params_.stages.motion_model));
    }
  }
}

// Best evidence first (ties: the older one), near duplicates merged, at most max_hypotheses.
void Localizer::PruneHypotheses() {
  std::stable_sort(hypotheses_.begin(), hypotheses_.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.evidence > b.evidence; });
  std::vector<Hypothesis> distinct;
  for (Hypothesis& h : hypotheses_) {
    const bool duplicate = std::any_of(distinct.begin(), distinct.end(), [&](const Hypothesis& d) {
      return Near(d.T_map_robot, h.T_map_robot, params_);
    });
    if (!duplicate && static_cast<int>(distinct.size()) < params_.max_hypotheses) {
      distinct.push_back(std::move(h));
    }
  }
  hypotheses_ = std::move(distinct);
}

// Not localized: the kept hypotheses are propagated, the global search adds new ones, and the
// best wins when it fits well, matched this scan and no rival has comparable evidence.
LocalizerReport Localizer::Search(const ScanShapes& shapes, const LaserScan& scan,
                                  const std::optional<Pose2>& odometry_delta) {
  const std::vector<Point2> samples = GlobalSamples(shapes);
  PropagateHypotheses(shapes, scan, samples, odometry_delta);
  AddGlobalHypotheses(shapes, scan, samples);
  PruneHypotheses();
  LocalizerReport report;
  report.status = status_;
  report.hypotheses = static_cast<int>(hypotheses_.size());
  if (hypotheses_.empty()) return report;
  const Hypothesis& best = hypotheses_.front();
  report.T_map_robot = best.T_map_robot;
  report.inlier_ratio = best.fit;
  const bool rival = hypotheses_.size() > 1 &&
                     hypotheses_[1].evidence >= best.evidence - params_.ambiguous_margin_samples;
  if (rival) report.status = LocalizerStatus::kAmbiguous;
  const double min_fit = best.tracked ? params_.min_inlier_ratio : params_.min_global_fit;
  if (rival || best.misses > 0 || best.fit < min_fit) return report;
  hypotheses_.erase(hypotheses_.begin() + 1, hypotheses_.end());
  hypotheses_.front().tracked = false;
  report.hypotheses = 1;
  report.status = status_ = LocalizerStatus::kTracking;
  report.localized = report.matched = true;
  report.recovered_event = was_localized_;
  was_localized_ = true;
  drop_scans_ = 0;
  fit_mean_ = best.fit;
  return report;
}

// The field track (LocalizerParams::field_track_*) serves scans without odometry when it is on.
bool Localizer::FieldTrackOn(const std::optional<Pose2>& odometry_delta) const {
  return !odometry_delta && params_.field_track_min_fit > 0.0;
}

// While tracking, the fit a scan needs to be matched: min_inlier_ratio, or
// relative_inlier_ratio times the running mean of the fit when that is lower.
double Localizer::TrackingMinFit() const {
  if (params_.relative_inlier_ratio <= 0.0 || fit_mean_ <= 0.0) return params_.min_inlier_ratio;
  return std::min(params_.min_inlier_ratio, params_.relative_inlier_ratio * fit_mean_);
}

// The tracked pose's registration: the field track (without odometry) first; the usual track
// (with odometry from its prediction, without from none) when there is no field pose or it fits
// poorly, the better fit winning; with odometry, a retry with a wider occlusion tolerance when
// nothing was trusted. `field_tracked` says whether the field track's pose was taken.
Localizer::Verified Localizer::RegisterTracked(const ScanShapes& shapes, const LaserScan& scan,
                                               const Hypothesis& h,
                                               const std::optional<Pose2>& odometry_delta,
                                               const std::vector<Point2>& samples,
                                               TrackingAids& aids, bool& field_tracked) const {
  std::optional<Verified> field;
  if (FieldTrackOn(odometry_delta)) {
    field = FieldTrack(shapes, scan, samples, h, TrackingMinFit(), aids);
  }
  std::optional<Verified> usual;
  if (!field || (fit_mean_ > 0.0 && field->fit < params_.field_track_check_ratio * fit_mean_)) {
    usual = Track(shapes, scan, h, odometry_delta, h.misses, TrackingMinFit(), aids);
    if (field && usual->trusted && usual->fit > field->fit) field.reset();
  }
  field_tracked = field.has_value();
  Verified v = field ? *field : *usual;
  if (!v.trusted && odometry_delta &&
      params_.retry_depth_tolerance_m > params_.stages.visibility.depth_tolerance_m) {
    aids.depth_tolerance_m = params_.retry_depth_tolerance_m;
    const Verified wider = Track(shapes, scan, h, odometry_delta, h.misses, TrackingMinFit(), aids);
    if (wider.trusted) v = wider;
  }
  return v;
}

// Localized: the one pose is tracked; too many scans without a trusted match, or a fit that
// stays far below its running mean, mean the robot is lost (or was carried away).
LocalizerReport Localizer::TrackPose(const ScanShapes& shapes, const LaserScan& scan,
                                     const std::optional<Pose2>& raw_odometry_delta) {
  const std::optional<Pose2> odometry_delta = Calibrated(raw_odometry_delta);
  Hypothesis& h = hypotheses_.front();
  TrackingAids aids;
  aids.recent = recent_ ? &*recent_ : nullptr;
  aids.see_through = odometry_delta && params_.see_through_margin_m > 0.0;
  // The map-only steps (the field track, the map's check, the search off the map) score the
  // same samples (GlobalSamples).
  const std::vector<Point2> samples =
      FieldTrackOn(odometry_delta) || params_.recheck_every > 0 || params_.off_map_fit > 0.0
          ? GlobalSamples(shapes)
          : std::vector<Point2>();
  bool field_tracked = false;
  Verified v = RegisterTracked(shapes, scan, h, odometry_delta, samples, aids, field_tracked);
  Motion(h, v.T_map_robot, v.trusted);
  h.fit = v.fit;
  h.evidence = params_.evidence_decay * h.evidence + v.explained;
  h.misses = v.trusted ? 0 : h.misses + 1;
  LocalizerReport report;
  report.T_map_robot = v.T_map_robot;
  report.inlier_ratio = v.fit;
  report.matched = v.trusted;
  report.hypotheses = 1;
  report.field_tracked = field_tracked;
  const bool dropped = fit_mean_ > 0.0 && v.fit < params_.fit_drop_ratio * fit_mean_;
  drop_scans_ = dropped ? drop_scans_ + 1 : 0;
  if (v.trusted && !dropped) {
    if (odometry_delta) LearnOdometry(*raw_odometry_delta, *odometry_delta, v);
    fit_mean_ = fit_mean_ < 0.0 ? v.fit
                                : (1.0 - params_.fit_mean_weight) * fit_mean_ +
                                      params_.fit_mean_weight * v.fit;
  }
  if (h.misses >= params_.lost_after_scans || drop_scans_ >= params_.fit_drop_scans) {
    h.tracked = true;  // kept: see "lost" in localizer.h
    recent_.reset();
    challenger_.reset();
    report.status = status_ = LocalizerStatus::kLost;
    report.lost_event = true;
    return report;
  }
  // The map alone scores the tracked pose once, for the map's check and the search off the map.
  std::optional<double> map_fit;
  if (v.trusted && !dropped &&
      Recheck(shapes, scan, samples, odometry_delta.has_value(), v, map_fit)) {
    report.T_map_robot = v.T_map_robot;
    report.inlier_ratio = v.fit;
    report.rechecked = true;
  }
  if (params_.off_map_fit > 0.0 &&
      RelocalizeOffMap(shapes, scan, samples, odometry_delta, v, map_fit)) {
    report.T_map_robot = v.T_map_robot;
    report.inlier_ratio = v.fit;
    report.matched = report.recovered_event = true;
  }
  if (v.trusted && !dropped) KeepRecent(shapes, scan, v.T_map_robot);
  report.status = LocalizerStatus::kTracking;
  report.localized = true;
  return report;
}

// The field track (LocalizerParams::field_track_*), without odometry: the map's likelihood field
// near the constant-velocity prediction (or near it turned as the scans' orientation histograms
// say, field_track_turn_below) gives the prediction, which the registration refines as an
// odometry prediction (Track with a zero increment) under the field track's prior and matched
// at `min_fit`. Nothing when it does not fit field_track_min_fit. `samples`: the scan's
// (GlobalSamples).
std::optional<Localizer::Verified> Localizer::FieldTrack(const ScanShapes& shapes,
                                                         const LaserScan& scan,
                                                         const std::vector<Point2>& samples,
                                                         const Hypothesis& h, double min_fit,
                                                         const TrackingAids& aids) const {
  if (shapes.coarse.empty() || samples.empty()) return std::nullopt;
  Pose2 moved = h.T_map_robot * h.velocity.Predict().value_or(Pose2());
  Pose2 T_map_sensor = moved * scan.T_robot_sensor;
  std::vector<WindowHypothesis> found =
      global_search_.Search(samples, T_map_sensor, params_.field_track_half_window_m,
                            params_.field_track_half_window_rad);
  if (found.empty()) return std::nullopt;
  // The scans' turn (field_track_turn_below): the window again at the heading the robot turned
  // by, when the constant velocity's window fits poorly and that heading lies beyond it.
  if (scan_turn_ && found.front().fit < params_.field_track_turn_below) {
    const Pose2 turned{moved.x, moved.y, NormalizeAngle(h.T_map_robot.theta + *scan_turn_)};
    const double beyond = std::abs(NormalizeAngle(turned.theta - moved.theta));
    if (beyond > params_.field_track_half_window_rad) {
      const Pose2 T_map_sensor_turned = turned * scan.T_robot_sensor;
      std::vector<WindowHypothesis> found_turned =
          global_search_.Search(samples, T_map_sensor_turned, params_.field_track_half_window_m,
                                params_.field_track_half_window_rad);
      if (!found_turned.empty() && found_turned.front().fit >= params_.field_track_turn_below &&
          found_turned.front().fit >= found.front().fit + params_.field_track_tie) {
        moved = turned;
        T_map_sensor = T_map_sensor_turned;
        found = std::move(found_turned);
      }
    }
  }
  const bool tie =
      global_search_.Fit(samples, T_map_sensor) >= found.front().fit - params_.field_track_tie;
  const Pose2 predicted =
      tie ? moved : found.front().T_model_scan * scan.T_robot_sensor.Inverse();
  TrackingAids with_prior = aids;
  with_prior.stages = &field_stages_;
  const Verified v = VerifyRobot(shapes, scan, predicted, min_fit, with_prior);
  if (!v.trusted || v.fit < params_.field_track_min_fit) return std::nullopt;
  return v;
}

// The map's check of the tracked pose (LocalizerParams::recheck_*): every recheck_every matched
// scans, and without odometry at every scan the map's likelihood field scores below
// recheck_poor_fit (in the wider window then; the schedule goes on), the best pose of the map's
// likelihood field near the tracked one, verified by the registration (Verify) and better by
// recheck_margin there before and after, replaces it (`v`; true). `samples`: the scan's
// (GlobalSamples), shared with RelocalizeOffMap; `map_fit`: the field's score of `v`, computed
// here when still unknown and kept for RelocalizeOffMap.
bool Localizer::Recheck(const ScanShapes& shapes, const LaserScan& scan,
                        const std::vector<Point2>& samples, bool odometry, Verified& v,
                        std::optional<double>& map_fit) {
  if (params_.recheck_every <= 0 || challenger_) return false;
  const bool scheduled = ++recheck_scans_ >= params_.recheck_every;
  if (scheduled) recheck_scans_ = 0;
  const Pose2 T_map_sensor = v.T_map_robot * scan.T_robot_sensor;
  const bool check_poor = !odometry && params_.recheck_poor_fit > 0.0;
  if (!scheduled && !check_poor) return false;
  if (!map_fit) map_fit = global_search_.Fit(samples, T_map_sensor);
  const double tracked_fit = *map_fit;
  const bool poor = check_poor && tracked_fit < params_.recheck_poor_fit;
  if (!scheduled && !poor) return false;
  // The best pose of a window, verified and still better by the margin after it.
  double replacement_fit = 0.0;
  const auto check = [&](double half_window_m, double half_window_rad) -> std::optional<Verified> {
    const std::vector<WindowHypothesis> found =
        global_search_.Search(samples, T_map_sensor, half_window_m, half_window_rad);
    if (found.empty() || found.front().fit < tracked_fit + params_.recheck_margin) return std::nullopt;
    const Verified c = Verify(shapes, scan, found.front().T_model_scan, params_.min_global_fit);
    if (!c.trusted) return std::nullopt;
    replacement_fit = global_search_.Fit(samples, c.T_map_robot * scan.T_robot_sensor);
    if (replacement_fit < tracked_fit + params_.recheck_margin) return std::nullopt;
    return c;
  };
  // The wider window first; where its best pose fails, the scheduled check is still made.
  std::optional<Verified> c;
  if (poor) c = check(params_.recheck_poor_half_window_m, params_.recheck_poor_half_window_rad);
  if (!c && scheduled) c = check(params_.recheck_half_window_m, params_.recheck_half_window_rad);
  if (!c) return false;
  Hypothesis& h = hypotheses_.front();
  h.T_map_robot = c->T_map_robot;
  h.fit = c->fit;
  recent_.reset();
  v = *c;
  map_fit = replacement_fit;
  return true;
}

// Off the map (LocalizerParams::off_map_fit): while the map explains the tracked pose poorly,
// the global search runs every off_map_search_every scans; a pose it finds that the map
// explains off_map_margin better becomes the challenger, tracked beside the pose; once it has
// stayed matched and that much better for off_map_confirm_scans scans it replaces the tracked
// pose (`v`; true). A look-alike corridor fits one scan; rarely the next few as well.
// `tracked_map_fit`: the field's score of `v` when Recheck computed it.
bool Localizer::RelocalizeOffMap(const ScanShapes& shapes, const LaserScan& scan,
                                 const std::vector<Point2>& samples,
                                 const std::optional<Pose2>& odometry_delta, Verified& v,
                                 const std::optional<double>& tracked_map_fit) {
  const auto map_fit = [&](const Pose2& T_map_robot) {
    return global_search_.Fit(samples, T_map_robot * scan.T_robot_sensor);
  };
  const double tracked_fit = tracked_map_fit ? *tracked_map_fit : map_fit(v.T_map_robot);
  off_map_scans_ = tracked_fit < params_.off_map_fit ? off_map_scans_ + 1 : 0;
  if (challenger_) {
    const Verified c = Track(shapes, scan, *challenger_, odometry_delta, 0,
                             params_.min_global_fit, TrackingAids{});
    Motion(*challenger_, c.T_map_robot, c.trusted);
    if (!c.trusted || map_fit(c.T_map_robot) < tracked_fit + params_.off_map_margin) {
      challenger_.reset();
      return false;
    }
    if (++challenger_scans_ < params_.off_map_confirm_scans) return false;
    v = c;
  } else {
    if (off_map_scans_ == 0 || off_map_scans_ % params_.off_map_search_every != 0) return false;
    const std::optional<Verified> found = SearchOffMap(shapes, scan, samples, v.T_map_robot);
    if (!found || map_fit(found->T_map_robot) < tracked_fit + params_.off_map_margin) return false;
    challenger_.emplace(found->T_map_robot, found->explained, found->fit,
                        params_.stages.motion_model);
    challenger_scans_ = 0;
    if (params_.off_map_confirm_scans > 0) return false;
    v = *found;
  }
  Hypothesis& h = hypotheses_.front();
  h = std::move(*challenger_);
  h.fit = v.fit;
  challenger_.reset();
  recent_.reset();
  fit_mean_ = v.fit;
  drop_scans_ = off_map_scans_ = 0;
  return true;
}

// The global search's poses, each verified against the map alone; the best, when it is matched
// at min_global_fit, lies apart from the tracked pose and no distinct rival explains nearly as
// many samples.
std::optional<Localizer::Verified> Localizer::SearchOffMap(const ScanShapes& shapes,
                                                           const LaserScan& scan,
                                                           const std::vector<Point2>& samples,
                                                           const Pose2& T_map_robot_tracked) const {
  std::vector<Verified> found =
      VerifiedGlobalPoses(shapes, scan, samples, params_.min_global_fit);
  if (found.empty()) return std::nullopt;
  std::stable_sort(found.begin(), found.end(),
                   [](const Verified& a, const Verified& b) { return a.explained > b.explained; });
  const Verified& best = found.front();
  if (Near(best.T_map_robot, T_map_robot_tracked, params_)) return std::nullopt;
  for (std::size_t i = 1; i < found.size(); ++i) {
    if (!Near(found[i].T_map_robot, best.T_map_robot, params_) &&
        found[i].explained >= best.explained - params_.ambiguous_margin_samples) {
      return std::nullopt;  // a look-alike place: stay
    }
  }
  return best;
}

// A matched scan becomes the recent scan when there is none or the robot moved a keyframe's
// distance or turn (KeyframeParams) since the recent one, as the mapper's last keyframe does.
void Localizer::KeepRecent(const ScanShapes& shapes, const LaserScan& scan,
                           const Pose2& T_map_robot) {
  const Pose2 T_map_sensor = T_map_robot * scan.T_robot_sensor;
  if (recent_) {
    const Pose2 moved = recent_->T_map_sensor.Inverse() * T_map_sensor;
    const KeyframeParams& keyframe = params_.stages.keyframe;
    if (moved.Translation().norm() < keyframe.min_translation_m &&
        std::abs(moved.theta) < keyframe.min_rotation_rad) {
      return;
    }
  }
  recent_ = RecentScan{shapes, T_map_sensor};
}

LocalizerReport Localizer::Process(const LaserScan& input_scan) {
  ValidateScan(input_scan);
  const LaserScan scan = CounterClockwiseScan(input_scan);
  const ScanShapes shapes = ExtractScanShapes(scan, params_.stages.shapes);
  bool stale = false;
  const std::optional<Pose2> raw_odometry_delta = OdometryDelta(scan, stale);
  // The turn since the last scan (field_track_turn_below): every scan's histogram is kept, so
  // that a scan without odometry in a log with it (a stall) is turned from the scan before.
  scan_turn_.reset();
  if (params_.field_track_turn_below > 0.0) {
    OrientationHistogram histogram =
        ComputeOrientationHistogram(shapes.fine, params_.field_track_turn);
    if (!raw_odometry_delta) {
      scan_turn_ = HistogramTurn(last_histogram_, histogram, params_.field_track_turn);
    }
    last_histogram_ = std::move(histogram);
  }
  LocalizerReport report = status_ == LocalizerStatus::kTracking
                               ? TrackPose(shapes, scan, raw_odometry_delta)
                               : Search(shapes, scan, Calibrated(raw_odometry_delta));
  report.timestamp_s = scan.timestamp_s;
  if (scan.T_odom_robot && !stale) {
    // The next odometry increment starts at this scan: so does every pose it moves.
    last_T_odom_robot_ = scan.T_odom_robot;
    for (Hypothesis& h : hypotheses_) h.T_map_robot_at_odometry = h.T_map_robot;
    if (challenger_) challenger_->T_map_robot_at_odometry = challenger_->T_map_robot;
  }
  return report;
}

std::optional<FirstPose> LocalizeFirstScan(const PolylineMap& map,
                                           const std::vector<LaserScan>& scans,
                                           std::size_t max_scans, const LocalizerParams& params) {
  Localizer localizer(map, params);
  std::optional<FirstPose> pending;  // localized, not yet confirmed
  int confirmed = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!pending && i >= max_scans) break;
    const LocalizerReport report = localizer.Process(scans[i]);
    if (pending && !report.localized) pending.reset();  // lost before it was confirmed
    if (!pending) {
      if (report.localized && i < max_scans) pending = FirstPose{i, report.T_map_robot};
      confirmed = 0;
    } else if (report.matched) {
      ++confirmed;
    }
    if (pending && confirmed >= params.first_pose_confirm_scans) return pending;
  }
  return pending;
}

}  // namespace shape_slam
