#include "shape_slam/pipeline.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/alignment.h"
#include "shape_slam/internal/localization.h"
#include "shape_slam/internal/validation.h"
#include "shape_slam/scan_insertion.h"
#include "shape_slam/internal/model_icp.h"

namespace shape_slam {
namespace {

using internal::NonNegative;
using internal::Positive;

using internal::ValidateScan;  // shared with the localizer

Eigen::Matrix3d DiagonalCovariance(double sigma_m, double sigma_rad) {
  return Eigen::Vector3d(sigma_m * sigma_m, sigma_m * sigma_m, sigma_rad * sigma_rad).asDiagonal();
}

Eigen::Matrix3d UnconfirmedCovariance(const LoopClosureParams& p) {
  return DiagonalCovariance(p.unconfirmed_sigma_m, p.unconfirmed_sigma_rad);
}

}  // namespace

void KeyframeParams::Validate() const {
  NonNegative(min_translation_m, "KeyframeParams::min_translation_m");
  NonNegative(min_rotation_rad, "KeyframeParams::min_rotation_rad");
}

void SubmapParams::Validate() const {
  if (keyframes < 2) throw std::invalid_argument("SubmapParams::keyframes must be >= 2");
  NonNegative(restart_follow_m, "SubmapParams::restart_follow_m");
  NonNegative(restart_follow_rad, "SubmapParams::restart_follow_rad");
}

void ShapeSlamParams::Validate() const {
  shapes.Validate();
  visibility.Validate();
  NonNegative(visibility_fov_margin_rad, "ShapeSlamParams::visibility_fov_margin_rad");
  matcher.Validate();
  refinement.Validate();
  map_update.Validate();
  keyframe.Validate();
  submaps.Validate();
  loop_closure.Validate();
  odometry_noise.Validate();
  odometry_calibration.Validate();
  odometry_edges.Validate();
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    throw std::invalid_argument("ShapeSlamParams::min_inlier_ratio must be in [0, 1]");
  }
  Positive(index_cell_size_m, "ShapeSlamParams::index_cell_size_m");
  Positive(coarse_gate_m, "ShapeSlamParams::coarse_gate_m");
  Positive(new_territory_distance_m, "ShapeSlamParams::new_territory_distance_m");
  NonNegative(fast_track_min_fit, "ShapeSlamParams::fast_track_min_fit");
  NonNegative(fast_track_max_correction_m, "ShapeSlamParams::fast_track_max_correction_m");
  NonNegative(fast_track_max_correction_rad, "ShapeSlamParams::fast_track_max_correction_rad");
  NonNegative(keyframe_track_min_fit, "ShapeSlamParams::keyframe_track_min_fit");
  if (!(keyframe_track_turn_without_odometry_rad >= 0.0 &&
        keyframe_track_turn_without_odometry_rad <= M_PI)) {
    throw std::invalid_argument(
        "ShapeSlamParams::keyframe_track_turn_without_odometry_rad must be in [0, pi]");
  }
  if (!(max_untrusted_coverage >= 0.0 && max_untrusted_coverage <= 1.0)) {
    throw std::invalid_argument("ShapeSlamParams::max_untrusted_coverage must be in [0, 1]");
  }
  Positive(max_prior_mahalanobis, "ShapeSlamParams::max_prior_mahalanobis");
  Positive(max_motion_per_scan_m, "ShapeSlamParams::max_motion_per_scan_m");
  Positive(max_turn_per_scan_rad, "ShapeSlamParams::max_turn_per_scan_rad");
  NonNegative(motion_prior_weight, "ShapeSlamParams::motion_prior_weight");
  NonNegative(motion_prior_max_penalty, "ShapeSlamParams::motion_prior_max_penalty");
  motion_model.Validate();
  Positive(motion_prior_sigma_m, "ShapeSlamParams::motion_prior_sigma_m");
  if (!(odometry_check_fit >= 0.0 && odometry_check_fit <= 1.0)) {
    throw std::invalid_argument("ShapeSlamParams::odometry_check_fit must be in [0, 1]");
  }
  NonNegative(odometry_override_margin, "ShapeSlamParams::odometry_override_margin");
  NonNegative(odometry_override_step_ratio, "ShapeSlamParams::odometry_override_step_ratio");
  NonNegative(odometry_override_slack_m, "ShapeSlamParams::odometry_override_slack_m");
  NonNegative(odometry_override_turn_slack_rad,
              "ShapeSlamParams::odometry_override_turn_slack_rad");
  if (!std::isfinite(odometry_override_min_along) || odometry_override_min_along > 1.0) {
    throw std::invalid_argument(
        "ShapeSlamParams::odometry_override_min_along must be finite and <= 1");
  }
  NonNegative(odometry_override_judged_step_m, "ShapeSlamParams::odometry_override_judged_step_m");
  NonNegative(stale_odometry_min_step_m, "ShapeSlamParams::stale_odometry_min_step_m");
  Positive(motion_prior_sigma_rad, "ShapeSlamParams::motion_prior_sigma_rad");
  if (!(max_lost_growth >= 1.0) || !std::isfinite(max_lost_growth)) {
    throw std::invalid_argument("ShapeSlamParams::max_lost_growth must be >= 1");
  }
  selection.Validate();
  window_search.Validate();
  Positive(window_search_odometry_scale, "ShapeSlamParams::window_search_odometry_scale");
  Positive(window_search_spacing_m, "ShapeSlamParams::window_search_spacing_m");
  if (scan_match_seed_pairs < 1 || scan_match_seeds < 1) {
    throw std::invalid_argument(
        "ShapeSlamParams::scan_match_seed_pairs and scan_match_seeds must be >= 1");
  }
}

ScanMatchParams ToScanMatchParams(const ShapeSlamParams& params) {
  ScanMatchParams scan_match;
  scan_match.shapes = params.shapes;
  scan_match.matcher = params.matcher;
  scan_match.refinement = params.refinement;
  scan_match.selection = params.selection;
  const double all_turns = scan_match.window_search.half_window_rad;
  scan_match.window_search = params.window_search;
  scan_match.window_search.half_window_rad = all_turns;
  scan_match.window_search_spacing_m = params.window_search_spacing_m;
  scan_match.coarse_gate_m = params.coarse_gate_m;
  scan_match.min_inlier_ratio = params.min_inlier_ratio;
  scan_match.seed_pairs = params.scan_match_seed_pairs;
  scan_match.seeds = params.scan_match_seeds;
  return scan_match;
}

ScanInsertionParams ToScanInsertionParams(const ShapeSlamParams& params) {
  ScanInsertionParams insertion;
  insertion.shapes = params.shapes;
  insertion.visibility = params.visibility;
  insertion.visibility_fov_margin_rad = params.visibility_fov_margin_rad;
  insertion.map_update = params.map_update;
  return insertion;
}

const char* ToString(OdometryStatus status) {
  switch (status) {
    case OdometryStatus::kDisabled: return "disabled";
    case OdometryStatus::kAbsent: return "absent";
    case OdometryStatus::kConstant: return "constant";
    case OdometryStatus::kUsed: return "used";
  }
  return "unknown";
}

ShapeSlam::ShapeSlam(const ShapeSlamParams& params)
    : params_(params),
      map_(params.index_cell_size_m),
      initial_map_(params.index_cell_size_m),
      loop_closer_(params.loop_closure, ToScanMatchParams(params)),
      odometry_noise_(params.odometry_noise),
      odometry_calibrator_(params.odometry_calibration),
      odometry_edge_noise_(params.odometry_edges),
      tracking_params_(params),
      keyframe_stages_(params),
      velocity_(params.motion_model) {
  params_.Validate();
  keyframe_stages_.fast_track_max_correction_rad = params_.keyframe_track_turn_without_odometry_rad;
  if (!params_.use_odometry) odometry_.status = OdometryStatus::kDisabled;
}

// The saved map is copied into an index of this mapper's cell size; the first scan is then
// predicted at the given pose, as if the robot had arrived there (its motion prior is the
// correction the first match makes).
ShapeSlam::ShapeSlam(const ShapeSlamParams& params, const PolylineMap& initial_map,
                     const Pose2& T_map_robot_first)
    : ShapeSlam(params) {
  if (initial_map.Empty()) throw std::invalid_argument("ShapeSlam: the initial map is empty");
  if (!std::isfinite(T_map_robot_first.x) || !std::isfinite(T_map_robot_first.y) ||
      !std::isfinite(T_map_robot_first.theta)) {
    throw std::invalid_argument("ShapeSlam: the first robot pose is not finite");
  }
  for (const PolylineId id : initial_map.Ids()) initial_map_.Add(initial_map.Get(id));
  graph_.AddNode(Pose2());  // node 0, held fixed: the frame of the loaded map (AddMapAnchor)
  last_T_map_robot_ = T_map_robot_first;
}

// Odometry that has not moved since the first scan is no odometry (logs without any carry
// zeros): until it moves, scans are matched by shape alone.
void ShapeSlam::TrackOdometry(const LaserScan& scan) {
  ++odometry_.scans;
  if (!scan.T_odom_robot) return;
  ++odometry_.scans_with_odometry;
  if (odometry_.status == OdometryStatus::kDisabled || odometry_.status == OdometryStatus::kUsed) {
    return;
  }
  odometry_.status = odometry_motion_.Moved(*scan.T_odom_robot) ? OdometryStatus::kUsed
                                                                : OdometryStatus::kConstant;
}

ShapeSlam::Prediction ShapeSlam::Predict(const LaserScan& scan) const {
  Prediction prediction;
  if (!last_T_map_robot_) return prediction;  // the first scan defines the map frame
  prediction.T_map_robot = *last_T_map_robot_;
  const bool odometry =
      odometry_.status == OdometryStatus::kUsed && scan.T_odom_robot && odometry_anchor_;
  prediction.odometry_stale =
      odometry && OdometryStalled(*scan.T_odom_robot, odometry_anchor_->T_odom_robot,
                                  velocity_.LongestRecentStep(), params_.stale_odometry_min_step_m);
  if (odometry && !prediction.odometry_stale) {
    const Pose2 raw = odometry_anchor_->T_odom_robot.Inverse() * *scan.T_odom_robot;
    const Pose2 delta = odometry_calibrator_.Correct(raw);
    prediction.raw_odometry_delta = raw;
    prediction.odometry_delta = delta;
    prediction.T_map_robot = odometry_anchor_->T_track_robot * delta;
  } else {
    prediction.T_pred_robot_velocity = velocity_.Predict();
  }
  return prediction;
}

bool ShapeSlam::IsKeyframe(const Pose2& T_map_robot) const {
  if (keyframes_.empty()) return true;
  const Pose2 moved = TrackingPose(static_cast<int>(keyframes_.size()) - 1).Inverse() * T_map_robot;
  return moved.Translation().norm() >= params_.keyframe.min_translation_m ||
         std::abs(moved.theta) >= params_.keyframe.min_rotation_rad;
}

Pose2 ShapeSlam::KeyframePose(int keyframe) const { return graph_.Node(places_[keyframe].node); }

const PolylineMap& ShapeSlam::TrackingMap() const {
  static const PolylineMap kEmpty;
  return active_submaps_.empty() ? kEmpty : active_submaps_.front().map;
}

Pose2 ShapeSlam::TrackingPose(int keyframe) const {
  return keyframes_[keyframe].T_local_robot;
}

Pose2 ShapeSlam::GlobalPose(const Pose2& T_track_robot) const {
  if (keyframes_.empty()) return T_track_robot;
  const int last = static_cast<int>(keyframes_.size()) - 1;
  return KeyframePose(last) * keyframes_[last].T_local_robot.Inverse() * T_track_robot;
}

// Every keyframe goes into each active submap (§5.2 inside it); the older one is the tracking
// model and `visible_front` its visible shape at the keyframe. A new submap starts once the
// newest holds half its keyframes; the older is finished, never to change, once full.
MapUpdateStats ShapeSlam::InsertIntoSubmaps(const std::vector<Polyline>& perceived,
                                            const Pose2& T_local_sensor,
                                            const std::vector<VisiblePolyline>& visible_front,
                                            const LaserScan& scan, Placement placement) {
  const int keyframe = static_cast<int>(keyframes_.size());
  const int half = std::max(1, params_.submaps.keyframes / 2);
  const bool restart = placement == Placement::kGuessed;
  if (restart) {  // a guessed keyframe: the active submaps end before it
    for (Submap& submap : active_submaps_) finished_submaps_.push_back(std::move(submap));
    active_submaps_.clear();
  }
  if (active_submaps_.empty() || active_submaps_.back().num_keyframes >= half) {
    active_submaps_.push_back({PolylineMap(params_.index_cell_size_m), keyframe, 0});
  }
  MapUpdateStats front_stats;
  for (std::size_t i = 0; i < active_submaps_.size(); ++i) {
    Submap& submap = active_submaps_[i];
    const bool front = i == 0;
    // Nothing is visible in a new submap (after a restart the front one too); the front one's
    // visible shape is the registration's.
    std::vector<VisiblePolyline> computed;
    if (!submap.map.Empty() && !front) {
      computed = submap.map.Visible(T_local_sensor, internal::ModelVisibility(scan, false, params_));
    }
    const std::vector<VisiblePolyline>& visible =
        front && !submap.map.Empty() ? visible_front : computed;
    const bool trusted = placement == Placement::kMatched || submap.map.Empty();
    MapUpdateStats stats =
        UpdateMap(submap.map, perceived, T_local_sensor, visible, scan, trusted, params_.map_update);
    ++submap.num_keyframes;
    if (front) front_stats = std::move(stats);
  }
  if (active_submaps_.front().num_keyframes >= params_.submaps.keyframes) {
    finished_submaps_.push_back(std::move(active_submaps_.front()));
    active_submaps_.erase(active_submaps_.begin());
  }
  return front_stats;
}

// The consecutive edge: the scan aligned to the previous keyframe alone, not to the map, so that
// a pose corrected against older parts of the map enters the graph as a loop closure (found by
// SearchLoop) rather than as a jump in the odometry chain.
PoseGraphEdge ShapeSlam::SequentialEdge(const std::vector<Polyline>& fine, const LaserScan& scan,
                                        const Pose2& T_map_robot, Placement placement,
                                        const Eigen::Matrix3d& covariance) const {
  const int previous = static_cast<int>(keyframes_.size()) - 1;
  const Keyframe& prev = keyframes_[previous];
  const std::vector<Polyline>& prev_fine = places_[previous].shapes.fine;
  PoseGraphEdge edge;
  edge.from = places_[previous].node;
  edge.T_from_to = TrackingPose(previous).Inverse() * T_map_robot;
  // An unconfirmed step (odometry or nothing) is a weak constraint; the motion model's guess
  // (no odometry) a weaker one, which the loop search counts as a long drive.
  const LoopClosureParams& lc = params_.loop_closure;
  edge.guessed = placement == Placement::kGuessed;
  edge.covariance = placement == Placement::kMatched ? EdgeCovariance(covariance, lc)
                    : edge.guessed ? DiagonalCovariance(lc.guess_sigma_m, lc.guess_sigma_rad)
                                   : UnconfirmedCovariance(lc);
  const std::vector<Point2> samples =
      internal::AlignmentSamples(fine, params_.matcher.alignment.sample_spacing_m);
  if (samples.empty() || prev_fine.empty()) return edge;
  const Pose2 estimate = prev.scan.T_robot_sensor.Inverse() * edge.T_from_to * scan.T_robot_sensor;
  const RefinementResult local =
      RefineAlignment(samples, prev_fine, estimate, std::nullopt, params_.refinement);
  // Along a corridor that the two views cannot place, the step is only as certain as the
  // prediction: with odometry it held the tracking there; without, the edge is widened, so
  // that a loop closure corrects a slide without bending the rest of the path.
  const bool widen = odometry_.status != OdometryStatus::kUsed && lc.ridge_max_shift_m > 0.0;
  // One model for the fit check and the ridge (its open ends only prepared when widening).
  const internal::ModelIcp check(prev_fine, params_.matcher.inlier_distance_m,
                                 params_.matcher.inlier_distance_m,
                                 widen ? internal::RidgeOpenEndM(lc.ridge_max_shift_m) : 0.0);
  // The scan-to-scan refinement corrects the tracking's step; one that jumped away from it
  // (RefinementStayedNear) leaves the step as tracked.
  if (local.converged &&
      internal::RefinementStayedNear(samples, estimate, local.T_map_scan, params_.refinement) &&
      check.InlierRatio(samples, local.T_map_scan) >= params_.min_inlier_ratio) {
    edge.T_from_to = prev.scan.T_robot_sensor * local.T_map_scan * scan.T_robot_sensor.Inverse();
    edge.covariance = EdgeCovariance(local.covariance, lc);
    edge.guessed = false;
    if (widen) {
      edge.covariance = internal::WidenedAlongRidge(samples, check, local.T_map_scan,
                                                    edge.covariance, lc.ridge_max_shift_m,
                                                    lc.ridge_fit_margin);
    }
  }
  return edge;
}

// The odometry edge (OdometryEdgeParams) beside the scan edge into a new keyframe, when both
// keyframes had fresh odometry: the calibrated odometry's step between them, its noise learned
// from the matched steps so far (this one included).
void ShapeSlam::AddOdometryEdge(const PoseGraphEdge& scan_edge, Placement placement,
                                const std::optional<Pose2>& T_dead_reckoned) {
  const std::optional<Pose2>& previous = keyframes_.back().T_odometry;
  if (!params_.odometry_edges.enabled || !T_dead_reckoned || !previous) return;
  const Pose2 step = previous->Inverse() * *T_dead_reckoned;
  if (placement == Placement::kMatched) odometry_edge_noise_.Add(step, scan_edge.T_from_to);
  const std::optional<Eigen::Matrix3d> covariance = odometry_edge_noise_.Covariance(step);
  if (!covariance) return;
  PoseGraphEdge odometry{scan_edge.from, scan_edge.to, step, *covariance};
  odometry.loss_sigmas = params_.odometry_edges.loss_sigmas;
  graph_.AddEdge(odometry);
}

// A new pose-graph node, tied to the previous keyframe.
bool ShapeSlam::AddKeyframe(const LaserScan& scan, std::vector<Polyline> coarse,
                            std::vector<Polyline> fine, const Pose2& T_track_robot,
                            Placement placement, const Eigen::Matrix3d& covariance,
                            const std::optional<Pose2>& T_dead_reckoned) {
  const bool trusted = placement == Placement::kMatched;
  std::optional<PoseGraphEdge> edge;
  if (!keyframes_.empty()) edge = SequentialEdge(fine, scan, T_track_robot, placement, covariance);
  const Pose2 T_map_robot = GlobalPose(T_track_robot);
  const int node = graph_.AddNode(T_map_robot);
  if (edge) {
    edge->to = node;
    graph_.AddEdge(*edge);
    AddOdometryEdge(*edge, placement, T_dead_reckoned);
  }
  // Continuing a loaded map: the first keyframe was placed in it (Register), the later ones are
  // registered in it here.
  const bool continued = !initial_map_.Empty(), first = keyframes_.empty();
  if (continued && first) AddMapAnchor(node, T_map_robot, trusted, covariance);
  keyframes_.push_back({scan, trusted, T_track_robot, T_dead_reckoned});
  places_.push_back({node, {std::move(coarse), std::move(fine)}, scan.T_robot_sensor, travel_m_,
                     odometry_.status == OdometryStatus::kUsed});
  return continued && !first && AnchorInLoadedMap(scan, places_.back().shapes, node, T_map_robot);
}

// The scan registered against the loaded map (run --map) from a predicted sensor pose in its
// frame. With `drive` (the motion since the pose was last confirmed there) as an odometry
// prediction is: its prior and gate; without, by shape without a guess (§4.3) as a scan without
// odometry is, the prediction standing for the constant-velocity hint.
internal::Localization ShapeSlam::LocalizeInLoadedMap(const ScanShapes& shapes,
                                                      const LaserScan& scan,
                                                      const Pose2& T_map_sensor_pred,
                                                      const std::optional<Pose2>& drive) const {
  const VisibilityParams visibility = internal::ModelVisibility(scan, /*no_estimate=*/true, params_);
  const internal::LocalModel model =
      internal::VisibleModel(initial_map_.Visible(T_map_sensor_pred, visibility), visibility);
  const std::optional<Pose2> hint = drive ? std::nullopt : std::optional<Pose2>(Pose2());
  return internal::Localize(shapes, model, drive, hint, /*lost_scans=*/0, tracking_params_);
}

// The loaded map is a frozen submap in the map frame (node 0): every keyframe after
// the first is registered against it at its global pose, and a trusted registration ties the
// keyframe to node 0 (a loop edge, so robust), as a loop closure against a finished submap
// would. The prediction is the graph's pose, its prior the drive since the last keyframe so tied
// (none yet: no prior). Every keyframe is tried: trying only every LoopClosureParams::
// search_every-th after a miss made infinite-corridor's two sessions 2.9 -> 8.1 m (5 copies).
// Returns whether the edge disagrees with the graph by more than
// LoopClosureParams::min_correction_* (then the graph is optimised).
bool ShapeSlam::AnchorInLoadedMap(const LaserScan& scan, const ScanShapes& shapes, int node,
                                  const Pose2& T_map_robot) {
  const Pose2 T_map_sensor_pred = T_map_robot * scan.T_robot_sensor;
  std::optional<Pose2> drive;
  if (last_map_anchor_node_ >= 0) drive = graph_.Node(last_map_anchor_node_).Inverse() * T_map_robot;
  const internal::Localization loc = LocalizeInLoadedMap(shapes, scan, T_map_sensor_pred, drive);
  // Verified as a loop closure is: most of the scan explained by the loaded map.
  if (!loc.trusted || loc.inlier_ratio < params_.loop_closure.min_inlier_ratio) return false;
  const Pose2 T_map_robot_matched = T_map_sensor_pred * loc.correction * scan.T_robot_sensor.Inverse();
  AddMapAnchor(node, T_map_robot_matched, /*trusted=*/true, loc.covariance);
  const Pose2 c = T_map_robot.Inverse() * T_map_robot_matched;
  const LoopClosureParams& lc = params_.loop_closure;
  return c.Translation().norm() > lc.min_correction_m || std::abs(c.theta) > lc.min_correction_rad;
}

// A continued map: node 0 stands for the loaded map's frame. A keyframe registered in the map is
// tied to node 0 by its pose there (a loop edge, so robust), and the first keyframe always
// (weakly when the map did not confirm it): a loop closure among the new keyframes must then
// not pull them away from the map they were localized in, and the graph has one fixed node.
void ShapeSlam::AddMapAnchor(int node, const Pose2& T_map_robot, bool trusted,
                             const Eigen::Matrix3d& covariance) {
  PoseGraphEdge anchor;
  anchor.from = 0;
  anchor.to = node;
  anchor.T_from_to = T_map_robot;
  anchor.covariance = trusted ? EdgeCovariance(covariance, params_.loop_closure)
                              : UnconfirmedCovariance(params_.loop_closure);
  anchor.loop = true;
  graph_.AddEdge(anchor);
  num_map_anchors_ += trusted ? 1 : 0;
  if (trusted) last_map_anchor_node_ = node;
}

void ShapeSlam::Optimize() {
  graph_.Optimize(params_.loop_closure.graph);
  ++num_optimizations_;
}

// The final optimisation runs whenever the graph holds a loop edge, whether or not the final
// searches asked for one: closures that agreed with the graph (LoopDecision::kAgreed) were added
// without an optimisation.
void ShapeSlam::Finish() {
  loop_closer_.FinalUpdate(places_, graph_, [this] { Optimize(); });
  const auto& edges = graph_.Edges();
  const bool has_loops =
      std::any_of(edges.begin(), edges.end(), [](const PoseGraphEdge& e) { return e.loop; });
  if (has_loops) Optimize();
}

const PolylineMap& ShapeSlam::Map() const {
  const std::pair<int, int> now{static_cast<int>(keyframes_.size()), num_optimizations_};
  if (map_made_from_ != now) BuildGlobalMap();
  map_made_from_ = now;
  return map_;
}

// Every keyframe inserted (§5.2) at its optimised pose into the loaded map or an empty one.
void ShapeSlam::BuildGlobalMap() const {
  map_ = initial_map_;  // empty unless mapping continues a loaded map
  const ScanInsertionParams insertion = ToScanInsertionParams(params_);
  for (std::size_t k = 0; k < keyframes_.size(); ++k) InsertKeyframe(map_, static_cast<int>(k), insertion);
}

MapUpdateStats ShapeSlam::InsertKeyframe(PolylineMap& map, int k,
                                         const ScanInsertionParams& insertion) const {
  const Keyframe& kf = keyframes_[k];
  const Pose2 T_map_sensor = KeyframePose(k) * kf.scan.T_robot_sensor;
  return InsertScanShapes(map, places_[k].shapes.fine, kf.scan, T_map_sensor,
                          kf.trusted || map.Empty(), insertion);
}

std::vector<StampedPose> ShapeSlam::LocalTrajectory() const { return AnchoredPoses(true); }

std::vector<StampedPose> ShapeSlam::Trajectory() const { return AnchoredPoses(false); }

// Every scan at its keyframe's pose (tracking frame or optimised) times its offset from it.
std::vector<StampedPose> ShapeSlam::AnchoredPoses(bool tracking_frame) const {
  std::vector<StampedPose> trajectory;
  trajectory.reserve(anchors_.size());
  for (const ScanAnchor& a : anchors_) {
    const Pose2 T_keyframe = tracking_frame ? TrackingPose(a.keyframe) : KeyframePose(a.keyframe);
    trajectory.push_back({a.timestamp_s, T_keyframe * a.T_keyframe_robot});
  }
  return trajectory;
}

// The last keyframe's polylines in the sensor frame T_map_sensor (tracking frame).
std::vector<Polyline> ShapeSlam::LastKeyframeIn(const std::vector<Polyline>& polylines,
                                                const Pose2& T_map_sensor) const {
  const Pose2 T_sensor_keyframe = T_map_sensor.Inverse() *
                                  TrackingPose(static_cast<int>(keyframes_.size()) - 1) *
                                  places_.back().T_robot_sensor;
  std::vector<Polyline> out;
  out.reserve(polylines.size());
  for (const Polyline& p : polylines) out.push_back(Transform(T_sensor_keyframe, p));
  return out;
}

// Registers the scan against the tracking map seen from a predicted sensor pose (§3, §4.2-§4.3,
// §5.1): its visible shape (returned in `visible`, prediction frame) and the last keyframe's
// polylines (`recent_fine` when already made).
internal::Localization ShapeSlam::LocalizeAt(const ScanShapes& shapes, const LaserScan& scan,
                                             const Pose2& T_map_sensor_pred,
                                             const std::optional<Pose2>& odometry_delta,
                                             const std::optional<Pose2>& velocity_hint,
                                             std::vector<Polyline> recent_fine,
                                             std::vector<VisiblePolyline>& visible) const {
  const VisibilityParams visibility = internal::ModelVisibility(scan, !odometry_delta, params_);
  visible = TrackingMap().Visible(T_map_sensor_pred, visibility);
  internal::LocalModel model = internal::VisibleModel(visible, visibility);
  if (params_.use_last_keyframe && !keyframes_.empty()) {
    model.recent_coarse = LastKeyframeIn(places_.back().shapes.coarse, T_map_sensor_pred);
    model.recent_fine = recent_fine.empty()
                            ? LastKeyframeIn(places_.back().shapes.fine, T_map_sensor_pred)
                            : std::move(recent_fine);
  }
  return internal::Localize(shapes, model, odometry_delta, velocity_hint, lost_scans_,
                            tracking_params_);
}

// Odometry as a prior, not a gate (ShapeSlamParams::odometry_check_fit): a scan that the
// odometry's prediction leaves poorly explained is matched again as if there were no odometry,
// from the last pose (§4.3); a clearly better fit there wins over the odometry (a glitch, a
// slip). `loc` and `visible` are then replaced, still relative to the odometry's prediction.
void ShapeSlam::CheckOdometry(const ScanShapes& shapes, const LaserScan& scan,
                              const Pose2& T_map_sensor_pred, const Pose2& T_map_sensor_last,
                              internal::Localization& loc,
                              std::vector<VisiblePolyline>& visible) const {
  std::vector<VisiblePolyline> visible_last;
  internal::Localization alt =
      LocalizeAt(shapes, scan, T_map_sensor_last, std::nullopt, std::nullopt, {}, visible_last);
  if (!alt.trusted || alt.inlier_ratio < loc.inlier_ratio + params_.odometry_override_margin) {
    return;
  }
  const Pose2 T_pred_last = T_map_sensor_pred.Inverse() * T_map_sensor_last;
  const Pose2 T_sensor_robot = scan.T_robot_sensor.Inverse();
  const Pose2 odometry_step = MotionInFrame(T_pred_last.Inverse(), T_sensor_robot);
  const Pose2 match_step = MotionInFrame(alt.correction, T_sensor_robot);
  if (!OdometrySupportsOverride(match_step, odometry_step)) return;
  alt.correction = T_pred_last * alt.correction;
  alt.odometry_overridden = true;
  loc = alt;
  for (VisiblePolyline& v : visible_last) v.points_sensor = Transform(T_pred_last, v.points_sensor);
  visible = std::move(visible_last);
}

// Whether the odometry's step (robot frame, since the last scan) supports an override that moves
// the robot by `match_step` instead: not farther than both that step and the robot's recent
// steps (odometry_override_within_step, _step_ratio) plus the slack, not turning it farther than
// both the odometry's turn and the recent turns plus odometry_override_turn_slack_rad, and along
// the odometry's step. The wheels' direction of travel holds through a glitch (which turns the
// heading) and most slips: a match that moves the robot less than odometry_override_min_along of
// the odometry's step along it, or against it, found a look-alike place, not a glitch.
bool ShapeSlam::OdometrySupportsOverride(const Pose2& match_step,
                                         const Pose2& odometry_step) const {
  const double slack = params_.odometry_override_slack_m;
  const Eigen::Vector2d odometry_t = odometry_step.Translation();
  const Eigen::Vector2d match_t = match_step.Translation();
  const double step = odometry_t.norm();
  if (params_.odometry_override_within_step) {
    const double reach = std::max(
        step, params_.odometry_override_step_ratio * velocity_.LongestRecentStep());
    if (match_t.norm() > reach + slack) return false;
    const double turn = std::max(std::abs(odometry_step.theta), velocity_.LargestRecentTurn());
    if (std::abs(match_step.theta) > turn + params_.odometry_override_turn_slack_rad) return false;
  }
  if (step <= 0.0 || step < params_.odometry_override_judged_step_m) return true;
  return match_t.dot(odometry_t) / step >= params_.odometry_override_min_along * step - slack;
}

// What registering one scan gave: the correction of its prediction and the visible shape of
// the tracking map (prediction frame; empty when the keyframe track placed the scan).
struct ShapeSlam::Registration {
  internal::Localization loc;
  std::vector<VisiblePolyline> visible;
  bool model_empty = true;  // nothing to register against yet (the first scan)
  bool guessed = false;     // placed by the motion model alone (SubmapParams::restart_when_lost)
  // Without odometry and without a trusted match: the best candidate lies within
  // SubmapParams::restart_follow_* of the constant-velocity prediction (the scan fits poorly but
  // where the robot's motion puts it).
  bool follows_motion = false;
  // The odometry's dead-reckoned pose of this scan, when it gave a fresh increment (odometry
  // edges, AddOdometryEdge).
  std::optional<Pose2> T_dead_reckoned;
};

// One scan through the pipeline: extract (§3.1) -> predict -> register (§3, §4.2-§4.3, §5.1)
// -> at keyframes, update the submaps (§5.2) and the pose graph.
ScanReport ShapeSlam::Process(const LaserScan& input_scan) {
  ValidateScan(input_scan);
  const LaserScan scan = CounterClockwiseScan(input_scan);
  ScanReport report;
  report.timestamp_s = scan.timestamp_s;
  ScanShapes shapes = ExtractScanShapes(scan, params_.shapes);
  report.polylines = static_cast<int>(shapes.coarse.size());

  TrackOdometry(scan);
  const Prediction prediction = Predict(scan);
  report.used_odometry = prediction.odometry_delta.has_value();
  odometry_.scans_predicted += report.used_odometry ? 1 : 0;
  odometry_.scans_stale += prediction.odometry_stale ? 1 : 0;
  const Pose2 T_map_sensor_pred = prediction.T_map_robot * scan.T_robot_sensor;

  Registration registration = Register(shapes, scan, prediction, T_map_sensor_pred, report);
  if (prediction.odometry_delta) {
    T_dead_reckoned_ = T_dead_reckoned_ * *prediction.odometry_delta;
    registration.T_dead_reckoned = T_dead_reckoned_;
  }
  const internal::Localization& loc = registration.loc;
  LearnOdometry(prediction, loc);
  // Poses in the local tracking frame (the submaps').
  const Pose2 T_map_sensor = T_map_sensor_pred * loc.correction;
  const Pose2 T_track_robot = T_map_sensor * scan.T_robot_sensor.Inverse();
  report.matched = loc.trusted;
  report.fast_track = loc.fast_track && !report.keyframe_tracked;
  report.covariance = loc.covariance;
  report.matched_pairs = loc.matched_pairs;
  report.inlier_ratio = loc.inlier_ratio;
  report.rms_error_m = loc.rms_error_m;
  UpdateMotion(T_track_robot, loc.trusted || registration.model_empty);

  // A scan whose pose no match confirmed updates the map only where the map knows nothing yet
  // (new territory); elsewhere it would blur or duplicate what is there.
  // Without odometry such a scan, unless its best candidate follows the
  // robot's motion, may be a keyframe all the same, the first of new submaps
  // (SubmapParams::restart_when_lost): the next scans are tracked against what it saw, and only
  // its guessed step to the previous keyframe is left for loop closure to correct.
  registration.guessed = params_.submaps.restart_when_lost && !loc.trusted &&
                         !registration.follows_motion && !registration.model_empty &&
                         !report.used_odometry && !prediction.odometry_stale;
  const bool may_update = loc.trusted || registration.model_empty || registration.guessed ||
                          loc.coverage < params_.max_untrusted_coverage;
  if (!shapes.fine.empty() && may_update &&
      (registration.guessed || IsKeyframe(T_track_robot))) {
    UpdateMapAndGraph(std::move(shapes), scan, T_map_sensor, registration, report);
  }
  if (!keyframes_.empty()) {
    const int k = static_cast<int>(keyframes_.size()) - 1;
    anchors_.push_back({scan.timestamp_s, k, TrackingPose(k).Inverse() * T_track_robot});
  }
  report.T_map_robot = GlobalPose(T_track_robot);
  last_T_map_robot_ = T_track_robot;
  if (scan.T_odom_robot && !prediction.odometry_stale) {
    odometry_anchor_ = OdometryAnchor{*scan.T_odom_robot, T_track_robot};
  }
  return report;
}

// A scan predicted short of the next keyframe first tries the last keyframe alone
// (ShapeSlamParams::keyframe_track); otherwise, or when that falls short, it is registered
// against the tracking map's visible shape, and with odometry that explains it poorly, checked
// without the odometry (CheckOdometry).
ShapeSlam::Registration ShapeSlam::Register(const ScanShapes& shapes, const LaserScan& scan,
                                            const Prediction& prediction,
                                            const Pose2& T_map_sensor_pred,
                                            ScanReport& report) const {
  Registration r;
  std::vector<Polyline> recent_fine;  // made once: the keyframe track and Localize share it
  if (params_.keyframe_track_min_fit <= 1.0 && prediction.odometry_delta && !keyframes_.empty() &&
      !shapes.coarse.empty() && !IsKeyframe(prediction.T_map_robot)) {
    recent_fine = LastKeyframeIn(places_.back().shapes.fine, T_map_sensor_pred);
    r.loc = internal::TrackKeyframe(shapes, recent_fine, *prediction.odometry_delta,
                                    tracking_params_);
    report.keyframe_tracked = r.loc.fast_track;
  } else if (KeyframeTrackWithoutOdometry(shapes, scan, prediction, T_map_sensor_pred, r.loc)) {
    report.keyframe_tracked = true;
  }
  r.model_empty = TrackingMap().Empty();
  if (r.model_empty && keyframes_.empty() && !initial_map_.Empty() && !shapes.coarse.empty()) {
    // The first scan of a continued map (run --map): localized in the loaded map, whose frame
    // the local frame starts as; unconfirmed, it starts at the given pose.
    r.loc = LocalizeInLoadedMap(shapes, scan, T_map_sensor_pred, std::nullopt);
    r.model_empty = !r.loc.trusted;
    if (!r.loc.trusted) r.loc = {};
    return r;
  }
  if (report.keyframe_tracked || r.model_empty || shapes.coarse.empty()) return r;
  std::optional<Pose2> velocity_hint;
  if (prediction.T_pred_robot_velocity) {
    velocity_hint = MotionInFrame(*prediction.T_pred_robot_velocity, scan.T_robot_sensor);
  }
  r.loc = LocalizeAt(shapes, scan, T_map_sensor_pred, prediction.odometry_delta, velocity_hint,
                     std::move(recent_fine), r.visible);
  if (!prediction.odometry_delta && velocity_hint && r.loc.best_untrusted) {
    r.follows_motion = PosesWithin(*r.loc.best_untrusted, *velocity_hint,
                                   params_.submaps.restart_follow_m,
                                   params_.submaps.restart_follow_rad);
  }
  if (prediction.odometry_delta && !r.loc.fast_track && last_T_map_robot_ &&
      r.loc.inlier_ratio < params_.odometry_check_fit) {
    CheckOdometry(shapes, scan, T_map_sensor_pred, *last_T_map_robot_ * scan.T_robot_sensor, r.loc,
                  r.visible);
    report.odometry_overridden = r.loc.odometry_overridden;
  }
  return r;
}

// The keyframe track without odometry (ShapeSlamParams::keyframe_track_without_odometry; also
// while the odometry stalls): after a trusted match, a scan that the constant-velocity motion
// leaves short of the next keyframe gets the fast track against the last keyframe alone, that
// motion standing for the odometry's increment, its estimate turning at most
// keyframe_track_turn_without_odometry_rad from it (keyframe_stages_). Sets `loc` (relative to
// T_map_sensor_pred, the last pose) and returns true only when it fits keyframe_track_min_fit.
bool ShapeSlam::KeyframeTrackWithoutOdometry(const ScanShapes& shapes, const LaserScan& scan,
                                             const Prediction& prediction,
                                             const Pose2& T_map_sensor_pred,
                                             internal::Localization& loc) const {
  if (!params_.keyframe_track_without_odometry || params_.keyframe_track_min_fit > 1.0 ||
      prediction.odometry_delta || !prediction.T_pred_robot_velocity || lost_scans_ > 0 ||
      keyframes_.empty() || shapes.coarse.empty()) {
    return false;
  }
  const Pose2& motion = *prediction.T_pred_robot_velocity;
  if (IsKeyframe(prediction.T_map_robot * motion)) return false;
  const Pose2 T_pred_moved = MotionInFrame(motion, scan.T_robot_sensor);
  const std::vector<Polyline> keyframe_fine =
      LastKeyframeIn(places_.back().shapes.fine, T_map_sensor_pred * T_pred_moved);
  internal::Localization tracked =
      internal::TrackKeyframe(shapes, keyframe_fine, motion, keyframe_stages_);
  if (!tracked.fast_track) return false;
  // From the moved frame to the last pose's: the correction composed, its covariance rotated.
  tracked.correction = T_pred_moved * tracked.correction;
  tracked.covariance = CovarianceInFrame(tracked.covariance, T_pred_moved);
  loc = std::move(tracked);
  return true;
}

// A trusted registration that the odometry did not override teaches the odometry model: what the
// scan itself says, not the estimate the prior already pulled (ScanOwnCorrection), is one
// sample of the increments' heading error (OdometryCalibrator) and of their noise.
void ShapeSlam::LearnOdometry(const Prediction& prediction, const internal::Localization& loc) {
  if (!prediction.odometry_delta || !loc.trusted || loc.odometry_overridden) return;
  const bool calibrate = params_.odometry_calibration.enabled;
  if (!params_.odometry_noise.learn && !calibrate) return;
  const std::optional<Pose2> own = ScanOwnCorrection(
      loc.correction, loc.covariance, *prediction.odometry_delta, tracking_params_.odometry_noise);
  if (!own) return;
  if (calibrate) {
    odometry_calibrator_.AddRegistration(*prediction.raw_odometry_delta,
                                         *prediction.odometry_delta, *own);
    odometry_.heading_per_m = odometry_calibrator_.HeadingPerMetre();
    odometry_.heading_per_rad = odometry_calibrator_.HeadingPerRadian();
  }
  if (params_.odometry_noise.learn) LearnOdometryNoise(*prediction.odometry_delta, *own);
}

// A trusted registration's own correction of the odometry's prediction: one sample of the log's
// odometry noise (OdometryNoiseLearner), which the next scans' prior uses. The prior's weight
// follows the learned noise; its gate (max_prior_mahalanobis) never gets tighter than the
// configured model's: a log with good odometry then holds the scans firmly along a corridor,
// yet a scan the odometry misjudges by the configured noise is still matched.
void ShapeSlam::LearnOdometryNoise(const Pose2& odometry_delta, const Pose2& correction) {
  odometry_noise_.Add(odometry_delta, correction);
  tracking_params_.odometry_noise = odometry_noise_.Current();
  const double tightest = std::min(
      {1.0, odometry_noise_.TranslationScale(), odometry_noise_.RotationScale()});
  tracking_params_.max_prior_mahalanobis = params_.max_prior_mahalanobis / tightest;
  odometry_.noise_scale_xy = odometry_noise_.TranslationScale();
  odometry_.noise_scale_theta = odometry_noise_.RotationScale();
}

// The motion state after a scan: scans without a match in a row, the last motions (the
// constant-velocity prediction) and the distance travelled.
void ShapeSlam::UpdateMotion(const Pose2& T_track_robot, bool reset_lost) {
  lost_scans_ = reset_lost ? 0 : lost_scans_ + 1;
  if (!last_T_map_robot_) return;
  velocity_.Add(last_T_map_robot_->Inverse() * T_track_robot, reset_lost);
  travel_m_ += (last_T_map_robot_->Translation() - T_track_robot.Translation()).norm();
}

// A keyframe updates the active submaps (§5.2) and becomes a pose-graph node; a loop closure
// found (or a tie to a loaded map that disagrees with the graph) then optimises the graph. The
// local frame stays: only the keyframes' global poses move.
void ShapeSlam::UpdateMapAndGraph(ScanShapes shapes, const LaserScan& scan,
                                  const Pose2& T_map_sensor, Registration& registration,
                                  ScanReport& report) {
  const internal::Localization& loc = registration.loc;
  std::vector<VisiblePolyline>& visible = registration.visible;
  std::vector<Polyline> perceived_map;
  for (const Polyline& p : shapes.fine) perceived_map.push_back(Transform(T_map_sensor, p));
  if (registration.guessed) {
    visible.clear();  // inserted into new submaps only (InsertIntoSubmaps)
  } else if (report.keyframe_tracked) {
    visible = TrackingMap().Visible(
        T_map_sensor, internal::ModelVisibility(scan, /*no_estimate=*/false, params_));
  } else {
    const Pose2 correction_inverse = loc.correction.Inverse();
    for (VisiblePolyline& v : visible) v.points_sensor = Transform(correction_inverse, v.points_sensor);
  }
  // The first scan of a continued map that the loaded map did not confirm starts at the given
  // pose, weakly tied to the map's frame (AddMapAnchor); its own submap takes it as it is.
  const bool trusted = loc.trusted || (registration.model_empty && initial_map_.Empty());
  const Placement placement = trusted                ? Placement::kMatched
                              : registration.guessed ? Placement::kGuessed
                                                     : Placement::kUnconfirmed;
  report.map_update = InsertIntoSubmaps(perceived_map, T_map_sensor, visible, scan, placement);
  report.keyframe = true;
  const Pose2 T_track_robot = T_map_sensor * scan.T_robot_sensor.Inverse();
  const bool anchor_moved = AddKeyframe(scan, std::move(shapes.coarse), std::move(shapes.fine),
                                        T_track_robot, placement, loc.covariance,
                                        registration.T_dead_reckoned);
  if (loop_closer_.Update(places_, graph_) || anchor_moved) Optimize();
}

std::vector<ShapeSlam::KeyframeView> ShapeSlam::Result::KeyframeViews() const {
  std::vector<KeyframeView> views;
  views.reserve(keyframes.size());
  for (const Keyframe& k : keyframes) views.push_back({&k.scan, k.T_map_robot});
  return views;
}

ShapeSlam::Result ShapeSlam::TakeResult() && {
  Map();  // made (if not yet) while the shapes it is made of are here
  Result result;
  result.map = std::move(map_);
  result.keyframes.reserve(keyframes_.size());
  for (std::size_t k = 0; k < keyframes_.size(); ++k) {
    result.keyframes.push_back({std::move(keyframes_[k].scan), graph_.Node(places_[k].node)});
  }
  result.loop_events = loop_closer_.Events();
  result.odometry = odometry_;
  // Freed now rather than when the mapper goes: the caller may still hold it.
  std::vector<Keyframe>().swap(keyframes_);
  std::vector<LoopKeyframe>().swap(places_);
  std::vector<Submap>().swap(active_submaps_);
  std::vector<Submap>().swap(finished_submaps_);
  loop_closer_ = LoopCloser(params_.loop_closure, ToScanMatchParams(params_));
  graph_ = PoseGraph();
  initial_map_ = PolylineMap();
  map_ = PolylineMap();
  map_made_from_ = {-1, -1};
  return result;
}

std::vector<ShapeSlam::KeyframeView> ShapeSlam::Keyframes() const {
  std::vector<KeyframeView> views;
  views.reserve(keyframes_.size());
  for (std::size_t k = 0; k < keyframes_.size(); ++k) {
    views.push_back({&keyframes_[k].scan, graph_.Node(places_[k].node)});
  }
  return views;
}

}  // namespace shape_slam
