// The incremental mapper (paper §3-§5): for every laser scan
//   extract polylines (§3.1) -> predict the pose -> visible map shape from the prediction (§3)
//   -> shape matching (§4.2, or §4.3 without odometry) -> restricted ICP (§5.1) -> Ceres
//   refinement against every visible wall -> map update at keyframes (§5.2).
//
// Keyframes: the map is updated when the robot has moved at least
// KeyframeParams::min_translation_m or turned min_rotation_rad since the last map update (and
// on the first scan). Every scan is localised; only keyframes change the map, which keeps dense
// logs fast and avoids averaging the same view into a wall many times.
//
// Without odometry (or with use_odometry = false) the pose is predicted from the last pose and
// the shape matcher finds the motion by itself (§4.3); the constant-velocity extrapolation is
// tried as one more candidate estimate.
//
// Deterministic: the same scans and parameters give bit-identical results.
#pragma once

#include <optional>
#include <vector>

#include "shape_slam/alignment_refinement.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/map_update.h"
#include "shape_slam/motion_model.h"
#include "shape_slam/odometry_noise.h"
#include "shape_slam/evaluation.h"
#include "shape_slam/loop_closure.h"
#include "shape_slam/polyline_map.h"
#include "shape_slam/pose_graph.h"
#include "shape_slam/scan_insertion.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam/shape_matcher.h"
#include "shape_slam/visibility.h"
#include "shape_slam/window_search.h"

namespace shape_slam {
namespace internal {
struct Localization;  // internal/localization.h
}

struct KeyframeParams {
  double min_translation_m = 0.20;  ///< metres since the last map update
  double min_rotation_rad = 0.15;   ///< radians since the last map update
  void Validate() const;
};

/// Local tracking against submaps (Cartographer's split of local and global SLAM, made with
/// polylines; not in the paper, whose single map is rebuilt by every loop closure). A submap is a
/// polyline map (§5.2 merges inside it) in the local frame of the scan-to-submap tracking,
/// built from `keyframes` consecutive keyframes. Two are active at a time: every keyframe goes
/// into both; the older one (at least half full) is the model each scan is registered against,
/// the newer one takes over when the older has its `keyframes` and is finished. A finished
/// submap never changes. Loop closures only move pose-graph nodes: the local frame, the
/// submaps and the scans' tracking are never rewritten, so one closure more or less cannot
/// change what the next scans are matched against. The global map is made on demand (Map())
/// from the keyframes at their optimised poses. (The earlier design, one global map rebuilt or
/// deformed after every loop closure, was deleted on 2026-12-05: docs/design.md, "Submaps".)
struct SubmapParams {
  /// Keyframes per submap (each keyframe is inserted into two submaps).
  int keyframes = 40;
  /// Without odometry, a scan that no match confirmed (its pose the constant-velocity guess),
  /// and whose best candidate lies farther than restart_follow_* from that guess (nothing
  /// explains where it is: beyond a doorway, say, rather than a poor scan on the robot's
  /// path), is a keyframe that finishes the active submaps and starts new ones: the scans
  /// after it are tracked against what it saw, not against a map it may be misplaced in, and
  /// its edge in the pose graph is weak (LoopClosureParams::guess_*) for loop closure to
  /// correct (docs/design.md, Submaps).
  bool restart_when_lost = true;
  double restart_follow_m = 0.3;
  double restart_follow_rad = 0.175;
  void Validate() const;
};

struct ShapeSlamParams {
  ScanShapesParams shapes;           ///< §3.1 grouping and simplification of each scan
  VisibilityParams visibility;       ///< visible map shape; its fov_rad is set per scan
  /// The visible map shape covers the scan's field of view widened by this on each side, rad.
  double visibility_fov_margin_rad = 0.35;
  ShapeMatcherParams matcher;        ///< §4.2-§4.3 and the §5.1 ICP
  /// The choice among a scan's candidate poses (shape matches, window search, prediction).
  CandidateSelectionParams selection;
  /// Without odometry, the window around the constant-velocity prediction is searched for the
  /// poses where the scan fits the local model (window_search.h); they join the candidates.
  WindowSearchParams window_search;
  bool window_search_without_odometry = true;
  /// With odometry, the window search runs only for a scan that found no trusted match, in a
  /// window this many times smaller (the odometry prediction is close).
  bool window_search_fallback = true;
  double window_search_odometry_scale = 0.5;
  /// The window search scores samples of the scan every this many metres.
  double window_search_spacing_m = 0.2;
  RefinementParams refinement;       ///< Ceres refinement after the restricted ICP
  /// The refinement against the whole visible map first runs with this wider association gate
  /// (metres), so that it converges from odometry-size errors, then with refinement's own.
  double coarse_gate_m = 0.6;
  MapUpdateParams map_update;        ///< §5.2
  KeyframeParams keyframe;
  SubmapParams submaps;
  LoopClosureParams loop_closure;   ///< loop_closure.h
  OdometryNoiseParams odometry_noise;
  OdometryCalibrationParams odometry_calibration;
  OdometryEdgeParams odometry_edges;  ///< odometry_noise.h
  /// Also match each scan against the last keyframe scan's polylines (besides the visible map):
  /// a fresh, undistorted view of the same place that keeps tracking robust where the map is
  /// still thin or imperfect. Not in the paper, which matches against the map alone.
  bool use_last_keyframe = true;
  /// Use the log's odometry to predict poses; when false (or the log has none) §4.3 applies.
  bool use_odometry = true;
  /// Without odometry: the largest motion between consecutive scans that an estimate may
  /// imply (metres, radians). Shape matching without a guess can find look-alike places
  /// anywhere in view (the other side of a symmetric block, a parallel corridor); no robot
  /// jumps there between two scans. Generous on purpose: logs scanned every second or two
  /// (aces turns 78 deg between two of its scans; 1.2 rad refused that turn).
  double max_motion_per_scan_m = 1.5;
  double max_turn_per_scan_rad = 1.6;
  /// Without odometry, candidates are ranked by fit less a constant-velocity motion prior
  /// (CandidateSelectionParams::prior_*): between fits that differ little, as along a
  /// corridor, the motion nearer the last one wins. With odometry the prior comes from the
  /// odometry noise model instead.
  double motion_prior_weight = 0.03;
  /// ... and its penalty is at most this (CandidateSelectionParams::prior_max_penalty): a
  /// candidate that explains this much more of the scan wins over the constant velocity, which
  /// is wrong whenever the robot starts, stops or turns between two scans (0: unbounded).
  double motion_prior_max_penalty = 0.08;
  /// Without odometry, the candidates' fit leaves out the samples that continue the model's
  /// polylines past their open ends, up to max_motion_per_scan_m beyond them
  /// (CandidateSelectionParams::open_end_m): space the model has not seen yet. Counted as misses,
  /// they make a scan fit best short of its true pose along a corridor, and the constant velocity
  /// then decays to a standstill.
  bool motion_unknown_beyond_ends = true;
  /// Without odometry, the prediction of the next scan's motion (constant velocity).
  MotionModelParams motion_model;
  double motion_prior_sigma_m = 0.5;     ///< metres
  double motion_prior_sigma_rad = 0.5;   ///< radians
  /// Without odometry, after k consecutive scans without a trusted match the motion bound and
  /// the search window grow by 1 + k, up to this factor (the robot went on while we were lost);
  /// such scans are placed at the constant-velocity prediction.
  double max_lost_growth = 3.0;
  /// Without odometry, a scan that found no trusted match is matched again with the seed counts
  /// of scan-to-scan matching (scan_match_*); localize turns this off while it searches
  /// (LocalizerParams::search_retry).
  bool thorough_retry = true;
  /// With odometry, an estimate farther than this many standard deviations (Mahalanobis, of
  /// the odometry noise model) from the prediction is rejected as a false match.
  double max_prior_mahalanobis = 4.0;
  /// Odometry as a prior, not a gate (not in the paper): a scan that fits the model less than
  /// this (fraction within matcher.inlier_distance_m) at the odometry's estimate is matched
  /// again without the odometry, from the last pose (§4.3); that match wins when it fits at
  /// least odometry_override_margin better. One odometry glitch (a heading jump) then costs one
  /// extra search instead of a map turned by the glitch. 0: off.
  double odometry_check_fit = 0.5;
  double odometry_override_margin = 0.2;
  /// ... unless it moves the robot farther than both the odometry's step and
  /// odometry_override_step_ratio times the robot's longest step of the last scans
  /// (motion_model.velocity_window of them), plus odometry_override_slack_m
  /// (odometry_override_within_step): a glitch turns the heading or scales a step, a slip
  /// shortens it, odometry that stalls for a scan lags the robot's recent steps, and none of
  /// them makes the robot leap; a match that goes farther found a look-alike place or a scan
  /// gone wrong. Not by the timestamps: on the MRPT sample log they jitter by 0.2-0.55 s
  /// between scans of like steps. With odometry, 5 noisy copies: freiburg-079's gross local
  /// errors 2 -> 1 per copy (median), intel every 2nd scan 0.759 -> 0.119 m ATE, every other
  /// development log and variant unchanged, odom-stall included (a ratio of 0, the odometry's
  /// step alone, fails there; docs/design.md, "Odometry as a prior").
  bool odometry_override_within_step = true;
  double odometry_override_step_ratio = 1.0;
  double odometry_override_slack_m = 0.2;
  /// ... nor turns it farther than both the odometry's turn and the robot's largest turn of the
  /// last scans, plus this (rad; with odometry_override_within_step). A glitch makes the
  /// odometry turn where the robot did not, so the match that mends it turns less; wheels do
  /// not miss a quarter turn. A match that turns the robot by far more than both found a
  /// look-alike view (intel half-beams, a build with centred samples: 99 deg where the
  /// odometry said 3 deg and the last turns 19 deg at most, 8 m ATE; docs/notebook.md). The
  /// 20 deg of slack stay above poor odometry's heading errors (an unseen log of issue 22:
  /// 4 deg per step median, 12 deg p90).
  double odometry_override_turn_slack_rad = 0.35;
  /// ... and unless it moves the robot along the odometry's step by less than this fraction of
  /// that step, less odometry_override_slack_m (steps under odometry_override_judged_step_m are
  /// not judged: their direction is the odometry's noise as much as the wheels'): the
  /// wheels' direction of travel holds through a heading glitch and most slips. A match that
  /// moved the robot backwards, or stopped it, where the odometry drove on had found a place
  /// that looks alike: behind the robot the scan's new part meets map that is already there,
  /// and fits better than at the true pose (intel, every 2nd scan: 1.83 m ATE, 0.76 m with it;
  /// docs/design.md, "Odometry as a prior"). Nor one that shortened the step to less than
  /// 0.7 of it: at a corridor's open end the true pose sees past the map and a pose half a step
  /// behind does not (intel with every 2nd beam: overrides to 0.38-0.41 of a 1 m step, where
  /// the glitches and poor odometry the overrides are for kept 0.87-0.98 of it). A low value
  /// (-100) is off.
  double odometry_override_min_along = 0.7;
  double odometry_override_judged_step_m = 0.5;
  /// A scan whose odometry pose equals the last scan's while the robot's longest step of the
  /// last scans reached this (m) is matched as if without odometry (the motion model, §4.3):
  /// the odometry stalled (a message late, or published less often than the scans), it did
  /// not see the robot stop. The next scan with fresh odometry is predicted from the last
  /// scan that had some, so the late motion is not counted twice. Not in the paper; a large
  /// value (e.g. 1000) is off.
  double stale_odometry_min_step_m = 0.05;
  /// A scan whose pose no match confirmed still updates the map when less than this fraction
  /// of it lies within new_territory_distance_m (metres) of the visible map: new territory.
  double max_untrusted_coverage = 0.3;
  double new_territory_distance_m = 1.0;
  /// A match is trusted when at least this fraction of the scan lies on the map afterwards.
  double min_inlier_ratio = 0.30;
  /// Fast track (not in the paper), with odometry only: the odometry prediction is first
  /// finished by the quick ICP and refined alone; when the scan then fits the model at least this
  /// well (fraction within matcher.inlier_distance_m), the estimate lies within
  /// fast_track_max_correction_* of the prediction and passes the odometry gate, it is taken
  /// without shape matching. Shape matching would find the same pose (ties go to the estimate
  /// nearest the prediction); it is for the scans the prediction does not explain: odometry
  /// errors, revisits. Without odometry the constant-velocity prediction slides along corridors
  /// (intel --no-odometry 0.72 -> 9.4 m ATE with it), so it is not used there. At 0.85 the
  /// fast-tracked poses lay within about 1 cm of the full match's, but the loop closure of
  /// infinite-corridor came out worse in six runs of six (docs/design.md, "Speed"): 0.95 takes only the
  /// scans that leave no doubt. Above 1: off.
  double fast_track_min_fit = 0.95;
  double fast_track_max_correction_m = 0.15;    ///< metres
  double fast_track_max_correction_rad = 0.05;  ///< radians
  /// Keyframe track (not in the paper): with odometry (and without, keyframe_track_without_odometry)
  /// a scan whose prediction lies short of the next keyframe (keyframe.min_*) gets the fast
  /// track against the last keyframe's polylines alone, fit at least this, before the map's
  /// visible shape is even computed; the map is matched as usual only when that falls short.
  /// Such a scan mostly gives only a pose, which the next keyframe's match against the map checks
  /// (it is a keyframe itself only where its refined pose crosses keyframe.min_*): on dense logs
  /// most scans are of this kind. Above 1: off.
  double keyframe_track_min_fit = 0.85;
  /// The keyframe track without odometry as well (after a trusted match): the constant-velocity
  /// motion stands for the odometry's increment, its prediction and prior, and the estimate may
  /// turn up to keyframe_track_turn_without_odometry_rad from it (a constant velocity lags a
  /// turn that speeds up: of freiburg-079 copy 0's 2700 scans between keyframes, 669 turned
  /// more than fast_track_max_correction_rad, 0.05, from it). Only dense logs have scans short
  /// of the next keyframe; a log whose scans are all keyframes is unchanged.
  bool keyframe_track_without_odometry = true;
  double keyframe_track_turn_without_odometry_rad = 0.2;
  /// Cell size of the map's spatial index, metres.
  double index_cell_size_m = 2.0;
  /// Scan-to-scan registration without a guess (scan_matcher.h: `shape-slam match`, the MRPT
  /// aligner): there one match decides everything and no map backs it up, so §4.3 tries more
  /// of the most reliable pairs than per-scan tracking does (matcher.max_seed_pairs and
  /// matcher.num_seeds): about twice the time, markedly fewer wrong seeds.
  int scan_match_seed_pairs = 25;
  int scan_match_seeds = 6;

  void Validate() const;
};

/// The scan-to-scan registration settings that agree with the mapper's (shapes, matcher,
/// refinement, selection and window search; the seed counts of scan_match_*).
ScanMatchParams ToScanMatchParams(const ShapeSlamParams& params);

/// The scan insertion settings of the mapper's map update (shapes, visibility, map update), for
/// inserting scans at known poses as the mapper inserts its keyframes.
ScanInsertionParams ToScanInsertionParams(const ShapeSlamParams& params);

/// What the mapper made of the log's odometry so far. Real logs come without odometry (no
/// odometry at all, or every pose zero): odometry that has never moved since the first scan is
/// treated as absent, and such scans are matched by shape alone (§4.3), as with use_odometry =
/// false. Once it moves it predicts every later scan.
enum class OdometryStatus {
  kDisabled,  ///< ShapeSlamParams::use_odometry is false
  kAbsent,    ///< no scan carried an odometry pose
  kConstant,  ///< every scan's odometry pose equals the first one's
  kUsed,      ///< the odometry moved; it predicts the poses from then on
};

struct OdometryReport {
  OdometryStatus status = OdometryStatus::kAbsent;
  int scans = 0;                   ///< scans processed
  int scans_with_odometry = 0;     ///< of which carried an odometry pose
  int scans_predicted = 0;         ///< of which were predicted by odometry
  int scans_stale = 0;  ///< of the others, whose odometry stalled (stale_odometry_min_step_m)
  /// The learned scale of the odometry noise model's translation and rotation sigmas
  /// (OdometryNoiseParams::learn; 1 until learned).
  double noise_scale_xy = 1.0;
  double noise_scale_theta = 1.0;
  /// The learned heading error of the raw increments (OdometryCalibrator; 0 until learned).
  double heading_per_m = 0.0;
  double heading_per_rad = 0.0;
};

/// A short name for the status: "disabled", "absent", "constant", "used".
const char* ToString(OdometryStatus status);

/// What the mapper did with one scan.
struct ScanReport {
  double timestamp_s = 0.0;
  Pose2 T_map_robot;                 ///< the estimated robot pose
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of (x, y, theta), when matched
  bool matched = false;              ///< the pose comes from a trusted match (else prediction)
  bool keyframe = false;             ///< the map was updated with this scan
  bool fast_track = false;           ///< matched by the fast track (fast_track_min_fit)
  bool keyframe_tracked = false;     ///< matched by the keyframe track (keyframe_track_min_fit)
  bool used_odometry = false;        ///< the prediction used odometry
  /// The odometry's prediction was overridden by a clearly better match without it
  /// (ShapeSlamParams::odometry_check_fit).
  bool odometry_overridden = false;
  int matched_pairs = 0;             ///< correspondences of eq. (4)
  int polylines = 0;                 ///< polylines extracted from the scan
  double inlier_ratio = 0.0;         ///< see ShapeMatchResult
  double rms_error_m = 0.0;          ///< refinement RMS
  MapUpdateStats map_update;
};

class ShapeSlam {
 public:
  /// Throws std::invalid_argument when a parameter is invalid (the message names it).
  explicit ShapeSlam(const ShapeSlamParams& params = {});

  /// Continues mapping in a saved map (`shape-slam run --map`): `initial_map` (map frame) is
  /// the starting map, kept and extended by the new scans like a map the mapper built itself
  /// (its polylines are merged with what the new scans see, §5.2). It is a frozen submap: the
  /// new scans are tracked against submaps of their own, and every keyframe is registered
  /// against it at its pose in the graph (the drive since the last keyframe registered there
  /// as the prior; verified by [loop_closure] min_inlier_ratio). Its frame is
  /// a fixed node of the pose graph, to which a keyframe so registered is tied by a robust
  /// edge, so that loop closures among the new keyframes keep them in that frame. The first
  /// scan is predicted at `T_map_robot_first` (the Localizer's global search or a known pose)
  /// and localized in the map from there; the local frame starts as the map's. Throws
  /// std::invalid_argument for invalid params, an empty map or a pose that is not finite.
  ShapeSlam(const ShapeSlamParams& params, const PolylineMap& initial_map,
            const Pose2& T_map_robot_first);

  /// Processes the next scan. Throws std::invalid_argument for a malformed scan (sizes differ,
  /// non-finite angles or timestamp); a scan without valid points is not an error (it is
  /// localised by prediction and leaves the map unchanged).
  ScanReport Process(const LaserScan& scan);

  /// At the end of the log: every few keyframes and the last ones searched for loops once more,
  /// from every heading (LoopClosureParams::final_sweep_every and final_searches; once per last
  /// keyframe), then a final optimisation of
  /// the pose graph (when it holds loop edges). Call it before writing the outputs; Process
  /// may still be called afterwards.
  void Finish();

  /// The global map: the loaded map (if any) and every keyframe merged into it (§5.2) at its
  /// optimised pose, made on demand and remade only after new keyframes or an optimisation.
  const PolylineMap& Map() const;
  const ShapeSlamParams& Params() const { return params_; }

  /// The pose of every processed scan, corrected by the latest pose-graph optimisation (each
  /// scan rides on the keyframe it was localized from). This is the trajectory to report.
  std::vector<StampedPose> Trajectory() const;
  /// The pose of every processed scan in the frame it was tracked in: the local frame, which
  /// loop closures never change.
  std::vector<StampedPose> LocalTrajectory() const;
  /// The keyframe pose graph (nodes: keyframes in order; edges: consecutive and loop closures).
  const PoseGraph& Graph() const { return graph_; }
  /// Loop-closure edges accepted so far.
  int NumLoopClosures() const { return loop_closer_.NumLoopClosures(); }
  /// Loop searches run so far, and closures they found before the consistency check.
  int NumLoopSearches() const { return loop_closer_.NumSearches(); }
  int NumLoopClosuresFound() const { return loop_closer_.NumFound(); }
  /// Every loop closure found and what became of it (LoopCloser::Events); keyframe indices as
  /// in Keyframes().
  const std::vector<LoopEvent>& LoopEvents() const { return loop_closer_.Events(); }
  /// Continuing a loaded map: the keyframes tied to its frame by a trusted registration in it.
  int NumKeyframesInLoadedMap() const { return num_map_anchors_; }
  /// A submap (SubmapParams): polylines in the local tracking frame, from num_keyframes
  /// keyframes in order from first_keyframe.
  struct Submap {
    PolylineMap map;
    int first_keyframe = 0;
    int num_keyframes = 0;
  };
  /// Submaps (SubmapParams): the finished ones (local tracking frame, never changed once
  /// finished) and how many are active.
  const std::vector<Submap>& FinishedSubmaps() const { return finished_submaps_; }
  int NumActiveSubmaps() const { return static_cast<int>(active_submaps_.size()); }
  /// Whether the log's odometry was used (see OdometryStatus).
  const OdometryReport& Odometry() const { return odometry_; }

  /// A keyframe: the scan that updated the map (beams counter-clockwise) and the robot pose,
  /// corrected by the latest pose-graph optimisation. The scan is the mapper's own, not a copy
  /// (a long log's keyframe scans weigh tens of MB): valid while the mapper lives and is given
  /// no further scan.
  struct KeyframeView {
    const LaserScan* scan = nullptr;
    Pose2 T_map_robot;
  };
  /// Every keyframe in order, at its corrected pose (e.g. to build an occupancy grid).
  std::vector<KeyframeView> Keyframes() const;

  /// What a finished run leaves for its outputs, without the mapper's working state (submaps,
  /// the keyframes' shapes, the pose graph, the loop search): the map, the keyframes at their
  /// corrected poses, the loop events and the odometry report.
  struct Result {
    /// A keyframe: its scan (beams counter-clockwise) and corrected robot pose.
    struct Keyframe {
      LaserScan scan;
      Pose2 T_map_robot;
    };
    PolylineMap map;                    ///< Map()
    std::vector<Keyframe> keyframes;    ///< as Keyframes(), the scans owned
    std::vector<LoopEvent> loop_events; ///< LoopEvents()
    OdometryReport odometry;            ///< Odometry()
    /// Views of `keyframes` as Keyframes() gives them, valid while `keyframes` is unchanged.
    std::vector<KeyframeView> KeyframeViews() const;
  };
  /// Hands the result over (after Finish, and after reading anything else wanted, such as
  /// Trajectory()) and frees the rest at once: the outputs of a long log then need not share
  /// the memory with the mapping state. The mapper is left moved-from: destroy it, use it no
  /// more.
  Result TakeResult() &&;

 private:
  struct Prediction {
    Pose2 T_map_robot;
    std::optional<Pose2> T_pred_robot_velocity;  // constant-velocity hint (no odometry)
    std::optional<Pose2> odometry_delta;          // T_prev_cur from odometry, calibrated
    std::optional<Pose2> raw_odometry_delta;      // ... as the log gives it
    bool odometry_stale = false;  // the odometry stalled (stale_odometry_min_step_m)
  };
  struct Keyframe {
    LaserScan scan;                      // counter-clockwise beams
    bool trusted = false;                // its pose was confirmed by a match
    Pose2 T_local_robot;                 // its pose in the tracking frame (never moved)
    std::optional<Pose2> T_odometry;     // its dead-reckoned pose, with fresh odometry
  };
  struct ScanAnchor {
    double timestamp_s = 0.0;
    int keyframe = 0;
    Pose2 T_keyframe_robot;
  };
  // What placed a keyframe: a trusted match; the prediction (odometry, or without it the
  // constant-velocity guess) left unconfirmed; or the motion model's guess after a lost scan
  // that starts new submaps (SubmapParams::restart_when_lost).
  enum class Placement { kMatched, kUnconfirmed, kGuessed };
  // The map each scan is registered against: the older active submap (local frame).
  const PolylineMap& TrackingMap() const;
  Pose2 TrackingPose(int keyframe) const;
  // The global pose of a pose in the tracking frame (the latest keyframe's correction).
  Pose2 GlobalPose(const Pose2& T_track_robot) const;
  MapUpdateStats InsertIntoSubmaps(const std::vector<Polyline>& perceived,
                                   const Pose2& T_local_sensor,
                                   const std::vector<VisiblePolyline>& visible_front,
                                   const LaserScan& scan, Placement placement);
  void TrackOdometry(const LaserScan& scan);
  Prediction Predict(const LaserScan& scan) const;
  std::vector<Polyline> LastKeyframeIn(const std::vector<Polyline>& polylines,
                                       const Pose2& T_map_sensor) const;
  internal::Localization LocalizeAt(const ScanShapes& shapes, const LaserScan& scan,
                                    const Pose2& T_map_sensor_pred,
                                    const std::optional<Pose2>& odometry_delta,
                                    const std::optional<Pose2>& velocity_hint,
                                    std::vector<Polyline> recent_fine,
                                    std::vector<VisiblePolyline>& visible) const;
  bool KeyframeTrackWithoutOdometry(const ScanShapes& shapes, const LaserScan& scan,
                                    const Prediction& prediction, const Pose2& T_map_sensor_pred,
                                    internal::Localization& loc) const;
  bool OdometrySupportsOverride(const Pose2& match_step, const Pose2& odometry_step) const;
  void CheckOdometry(const ScanShapes& shapes, const LaserScan& scan,
                     const Pose2& T_map_sensor_pred, const Pose2& T_map_sensor_last,
                     internal::Localization& loc, std::vector<VisiblePolyline>& visible) const;
  // The per-scan stages of Process: register, keep the motion state, update map and graph.
  struct Registration;  // pipeline.cpp
  Registration Register(const ScanShapes& shapes, const LaserScan& scan,
                        const Prediction& prediction, const Pose2& T_map_sensor_pred,
                        ScanReport& report) const;
  void UpdateMotion(const Pose2& T_track_robot, bool reset_lost);
  void LearnOdometry(const Prediction& prediction, const internal::Localization& loc);
  void LearnOdometryNoise(const Pose2& odometry_delta, const Pose2& correction);
  void UpdateMapAndGraph(ScanShapes shapes, const LaserScan& scan, const Pose2& T_map_sensor,
                         Registration& registration, ScanReport& report);
  bool IsKeyframe(const Pose2& T_map_robot) const;
  Pose2 KeyframePose(int keyframe) const;
  void AddOdometryEdge(const PoseGraphEdge& scan_edge, Placement placement,
                       const std::optional<Pose2>& T_dead_reckoned);
  PoseGraphEdge SequentialEdge(const std::vector<Polyline>& fine, const LaserScan& scan,
                               const Pose2& T_map_robot, Placement placement,
                               const Eigen::Matrix3d& covariance) const;
  // Returns whether an edge to the loaded map asks for an optimisation (AnchorInLoadedMap).
  bool AddKeyframe(const LaserScan& scan, std::vector<Polyline> coarse, std::vector<Polyline> fine,
                   const Pose2& T_track_robot, Placement placement,
                   const Eigen::Matrix3d& covariance, const std::optional<Pose2>& T_dead_reckoned);
  internal::Localization LocalizeInLoadedMap(const ScanShapes& shapes, const LaserScan& scan,
                                             const Pose2& T_map_sensor_pred,
                                             const std::optional<Pose2>& drive) const;
  bool AnchorInLoadedMap(const LaserScan& scan, const ScanShapes& shapes, int node,
                         const Pose2& T_map_robot);
  void AddMapAnchor(int node, const Pose2& T_map_robot, bool trusted,
                    const Eigen::Matrix3d& covariance);
  void Optimize();
  void BuildGlobalMap() const;
  /// Keyframe k's scan inserted (§5.2) into `map` at its optimised pose.
  MapUpdateStats InsertKeyframe(PolylineMap& map, int k, const ScanInsertionParams& insertion) const;
  std::vector<StampedPose> AnchoredPoses(bool tracking_frame) const;

  ShapeSlamParams params_;
  mutable PolylineMap map_;  // a cache made by Map()
  // The keyframes and optimisations map_ was made from (-1: never made).
  mutable std::pair<int, int> map_made_from_{-1, -1};
  int num_optimizations_ = 0;
  int num_map_anchors_ = 0;  // keyframes tied to the loaded map by a trusted registration
  int last_map_anchor_node_ = -1;  // the node of the last of them
  PolylineMap initial_map_;  // the map given to start from (empty when mapping from scratch)
  PoseGraph graph_;
  std::vector<Keyframe> keyframes_;
  std::vector<Submap> active_submaps_;    // oldest first: the one scans are registered against
  std::vector<Submap> finished_submaps_;  // never changed again
  std::vector<LoopKeyframe> places_;  // the keyframes' shapes, node and travel (same order)
  LoopCloser loop_closer_;
  std::vector<ScanAnchor> anchors_;
  std::optional<Pose2> last_T_map_robot_;
  // The last scan whose odometry moved on: its odometry pose and its pose (tracking frame),
  // where the next odometry increment starts (a stalled scan is skipped).
  struct OdometryAnchor {
    Pose2 T_odom_robot;
    Pose2 T_track_robot;
  };
  std::optional<OdometryAnchor> odometry_anchor_;
  OdometryMotionCheck odometry_motion_;  // odometry that never moved is none
  OdometryReport odometry_;
  OdometryNoiseLearner odometry_noise_;  // the log's odometry noise (odometry_noise.learn)
  OdometryCalibrator odometry_calibrator_;  // the log's odometry heading error
  OdometryEdgeNoise odometry_edge_noise_;   // the noise of the graph's odometry edges
  // The calibrated odometry's increments composed since the first scan (odometry edges).
  Pose2 T_dead_reckoned_;
  ShapeSlamParams tracking_params_;      // params_ with the learned odometry noise
  ShapeSlamParams keyframe_stages_;      // params_ for the keyframe track without odometry
  ConstantVelocity velocity_;            // the last motions: the prediction without odometry
  double travel_m_ = 0.0;
  int lost_scans_ = 0;  // consecutive scans without a trusted match
};

}  // namespace shape_slam
