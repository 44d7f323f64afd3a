// Localization in a finished polyline map (`shape-slam localize`): the map is never changed.
//
// Per scan the localizer is in one of four states:
//   searching  no pose yet: a global search over the whole map proposes hypotheses
//   ambiguous  two or more distinct hypotheses explain the scans about equally well: each is
//              tracked (propagated by the scan-to-scan motion) until one wins
//   tracking   one pose, tracked like the mapper's per-scan localization (§4.2-§5.1) against
//              the visible shape of the map from the prediction (§3) and, as the mapper's
//              last keyframe, the last matched scan a keyframe's distance back: where the map
//              is thin or holds clutter the scan does not see, that fresh view keeps the pose
//              from sliding, and its matches keep a right pose from being declared lost. With
//              odometry, map parts the scan saw through (people, the walls of a wrong loop
//              closure) are left out of the visible map, and a scan without a match is tried
//              again with a wider occlusion tolerance
//   lost       tracking failed (several scans without a trusted match, or a sudden drop of
//              the fit: the kidnapped robot); the global search runs again until it recovers.
//              The pose tracked until then stays a hypothesis, with the evidence it gathered:
//              after a passing occlusion it matches again and wins at once (a tracking fit
//              suffices for it); after a kidnapping it misses and is dropped like any other
//
// The global search is one branch and bound over every translation of the map and all turns
// (WindowSearch::SearchMap, window_search.h) on the map's likelihood field and pyramid, built
// once when the map is loaded; it stops when no unexplored pose can beat the best few or at a
// bound on its work, and its poses are verified by the candidate selection and refinement of
// the per-scan localization.
// Hypotheses are ranked by an evidence score, a decaying sum of the samples they explain.
// Deterministic: the same map, scans and parameters give bit-identical results.
#pragma once

#include <optional>
#include <vector>

#include "shape_slam/motion_model.h"
#include "shape_slam/odometry_noise.h"
#include "shape_slam/orientation_histogram.h"
#include "shape_slam/pipeline.h"
#include "shape_slam/polyline_map.h"
#include "shape_slam/types.h"
#include "shape_slam/window_search.h"

namespace shape_slam {

struct LocalizerParams {
  /// The stages of the per-scan localization (shapes, visibility, matcher, selection, window
  /// search, refinement, odometry noise, gates), as in the mapper. Its map update, keyframe and
  /// loop-closure settings are unused.
  ShapeSlamParams stages;
  /// A scan is matched when its refined pose explains at least this fraction of it (the map is
  /// finished, so a good match explains more than the mapper's min_inlier_ratio asks).
  double min_inlier_ratio = 0.5;
  /// While tracking, a scan is also matched when its fit reaches this times the running mean of
  /// the fit (fit_mean_weight), if that is lower: in a map of a cluttered place a right pose
  /// explains less of each scan (0: off).
  double relative_inlier_ratio = 0.8;
  /// A hypothesis of the global search is accepted as the pose once its fit reaches this.
  double min_global_fit = 0.6;
  /// Global search: its coarsest nodes, which tile the map, are about 2 * global_tile_half_m
  /// wide (the pyramid's top level). Metres.
  double global_tile_half_m = 3.0;
  /// Cell size and likelihood width of the global search's field, metres (coarse: the
  /// verification refines the poses).
  double global_resolution_m = 0.2;
  double global_hit_sigma_m = 0.2;
  /// The global search's angular step moves samples at this range by one cell (metres).
  double global_max_step_range_m = 8.0;
  /// Bound on the global search's work: search nodes scored (each costs one look-up per
  /// sample), which bounds its time (the search alone 20-36 ms on infinite-corridor, the largest
  /// development map; a searching scan, with the verification and the hypotheses, at most 151 ms
  /// in bench/results/localize).
  int global_node_evaluations = 300000;
  /// At most this many poses of the global search (best fit first, distinct) are verified.
  int global_hypotheses = 8;
  /// Hypotheses kept between scans while ambiguous.
  int max_hypotheses = 4;
  /// Hypotheses closer than these are one (metres, radians).
  double distinct_m = 0.5;
  double distinct_rad = 0.3;
  /// Evidence of a hypothesis, per scan: evidence_decay * evidence + the number of scan samples
  /// it explains (samples every matcher.alignment.sample_spacing_m). Counting samples, not
  /// fractions, lets a few samples on a distinguishing detail (a pillar, a door) decide between
  /// places that look alike otherwise.
  double evidence_decay = 0.7;
  /// Ambiguous while another hypothesis's evidence is within this many samples of the best's.
  double ambiguous_margin_samples = 8.0;
  /// Lost after this many consecutive scans without a trusted match while tracking.
  int lost_after_scans = 3;
  /// Lost when the fit stays below fit_drop_ratio times its running mean (an exponential mean
  /// with weight fit_mean_weight per scan) for fit_drop_scans consecutive scans: the kidnapped
  /// robot still finds some match, but one far worse than before.
  double fit_drop_ratio = 0.6;
  int fit_drop_scans = 2;
  double fit_mean_weight = 0.2;
  /// While tracking with odometry, a scan that finds no match against the visible map is
  /// matched again with the visibility's occlusion tolerance widened to this (metres; at most
  /// the mapper's depth_tolerance_m: off). A map holds what no scan sees: a polyline crossing
  /// the corridor from a wrong closure or a person, which hides the real walls behind it from
  /// the predicted pose (infinite-corridor: 5 visible polylines explaining nothing of a scan
  /// that the whole map explains to 99 %). Without odometry the wider model, all around the
  /// robot, lets wrong poses fit as well, so the retry is left out there.
  double retry_depth_tolerance_m = 0.5;
  /// While tracking with odometry, the visible map leaves out what the scan saw through: map
  /// parts nearer than the scan's beam of the same bearing by more than this (metres; 0: off;
  /// SeenRays, visibility.h). A finished map keeps what is gone or was never there (people, the
  /// walls of a wrong closure), and from the predicted pose such a polyline hides the real walls
  /// behind it. Without odometry the prediction is too loose to tell (aces copy 1, own map, no
  /// odometry: 92.3 -> 52.3 % within 0.10 m), so it is left out there.
  double see_through_margin_m = 1.0;
  /// Off the map: while tracking, a scan whose tracked pose scores below off_map_fit in the
  /// global search's likelihood field (the map alone; the recent scan carries the tracking
  /// through places the map does not hold, and a drifted pose) runs the global search every
  /// off_map_search_every such scans. Its best verified pose, matched at min_global_fit,
  /// scoring off_map_margin more than the tracked pose in the field, with no other distinct
  /// pose explaining within ambiguous_margin_samples as many samples, is tracked beside the
  /// pose, and replaces it once it has stayed matched and that much better for
  /// off_map_confirm_scans more scans (0: at once). off_map_fit 0: off. On the development
  /// logs (bench/localize) it found the robot again after rooms the map does not hold, in the
  /// other half's map and after a kidnapping, and changed nothing in the own map with odometry
  /// (docs/notebook.md, 2026-12-05).
  double off_map_fit = 0.25;
  int off_map_search_every = 10;
  double off_map_margin = 0.2;
  int off_map_confirm_scans = 3;
  /// The map's check of the tracked pose (not in the paper): every recheck_every matched scans
  /// while tracking (0: off), the best pose of the global search's likelihood field (the map
  /// alone, built once at load) within recheck_half_window_m and recheck_half_window_rad of the
  /// tracked pose is found; when it scores recheck_margin more in that field than the tracked
  /// pose, and still does after the registration has verified it (matched at min_global_fit),
  /// it replaces the tracked pose and the recent scan is dropped. The tracking registers each
  /// scan against the map and its recent scan, and the recent scan's own error passes into the
  /// next scan; over a turn on the spot without odometry it grew to 8 deg and stayed for 170
  /// scans (freiburg-079 copy 0), the fit still 0.8-0.9. Own map without odometry, copies 0-2
  /// (within 0.10 m / 2 deg of the mapping run, off -> on): freiburg-079 92.7 / 86.4 / 93.3 ->
  /// 96.0 / 93.4 / 96.4 %, aces 49.3 / 86.4 / 97.3 -> 57.3 / 90.2 / 97.3 %, infinite-corridor
  /// 41.1 / 76.9 / 63.3 -> 42.3 / 77.1 / 76.6 %, intel 91.3 / 94.9 / 97.7 -> 90.9 / 94.4 / 97.7
  /// %; with odometry within 0.5 point of before on every copy but infinite-corridor copy 1
  /// (93.6 -> 95.6 %; docs/notebook.md, 2026-12-06).
  int recheck_every = 5;
  double recheck_half_window_m = 0.6;     ///< metres
  double recheck_half_window_rad = 0.26;  ///< radians
  double recheck_margin = 0.05;           ///< mean likelihood of the scan's samples, 0-1
  /// Without odometry the check also runs at every scan whose tracked pose the field scores
  /// below recheck_poor_fit (0: never), within the wider recheck_poor_half_window_m and
  /// recheck_poor_half_window_rad (where that window's best pose fails, a scheduled check is
  /// still made in its own window). In the map of a log's own run every right pose (within 0.10 m
  /// and 2 deg of the mapping run) scored 0.5 or more (aces copies 0 and 2, infinite-corridor
  /// copy 0, with and without odometry); below it, a tracked pose has slid along a corridor or turned,
  /// further than the scheduled check reaches, or the robot is where the map holds nothing (the
  /// verification by the registration guards that case). With odometry the prior holds the pose
  /// and the robot is off the map more often than slid: the poor-fit check is left out there.
  /// docs/notebook.md, 2026-12-07.
  double recheck_poor_fit = 0.5;
  double recheck_poor_half_window_m = 1.5;   ///< metres
  double recheck_poor_half_window_rad = 0.5;  ///< radians
  /// The field track (not in the paper), without odometry: the map's likelihood field (the global
  /// search's, built once at load) predicts the scan as odometry would. The field's best pose
  /// within field_track_half_window_m (rounded up to whole cells of the field: 0.4 m at
  /// global_resolution_m) and field_track_half_window_rad of the constant-velocity prediction is
  /// the prediction, unless the field scores the constant velocity's own pose within
  /// field_track_tie of it (along a corridor the field is flat and the motion decides); the
  /// registration then refines it as with odometry (the fast track, else shape matching near it)
  /// against the map and the recent scan, with a prior of field_track_prior_sigma_m. It is taken
  /// when it fits field_track_min_fit, else the scan is matched without a prediction as before (0:
  /// off); see field_track_check_ratio. While lost or ambiguous, each hypothesis that matched the
  /// scan before is field-tracked first as well. Shape matching without a prediction is what the
  /// tracking without odometry spent its time on; the field is a prediction the recent scan cannot
  /// pull aside. In bench/localize (own map without odometry, 3 noisy copies of each development
  /// log) the tracking median fell from 6.6-19 to 2.4-4.9 ms and the scans within 0.10 m / 2 deg of
  /// the mapping run rose on aces, freiburg-079 and infinite-corridor (intel 98.4 -> 98.2 %); the
  /// other half's near-map score fell on freiburg-079 and infinite-corridor
  /// (bench/results/localize/README.md, docs/notebook.md 2026-12-06).
  double field_track_min_fit = 0.8;
  double field_track_half_window_m = 0.3;    ///< metres
  double field_track_half_window_rad = 0.1;  ///< radians
  double field_track_tie = 0.03;             ///< mean likelihood of the scan's samples, 0-1
  double field_track_prior_sigma_m = 0.15;   ///< metres (the rotation's: odometry_noise's floor)
  /// When the field track's fit falls below field_track_check_ratio times the running mean of
  /// the fit, the scan is matched without a prediction as well and the better fit wins (0:
  /// never). A robot that starts to drive after a turn on the spot is beyond the window, and a
  /// pose inside it can still fit 0.87 (intel, scan 108 of each copy: 2.2 m off for 11 scans).
  double field_track_check_ratio = 0.9;
  /// The field track's heading from the scans (not in the paper): where the field's best pose in
  /// the constant velocity's window scores below field_track_turn_below (0: off), the window is
  /// searched again at the constant velocity's position with the heading the scan turned by since
  /// the last scan, measured on the two scans' orientation histograms (orientation_histogram.h,
  /// with field_track_turn: no pose guess needed), when that heading lies beyond the first
  /// window; its best is taken when it scores field_track_turn_below itself, and field_track_tie
  /// more than the first window's. A robot that turned on the spot, or more than the last scan
  /// did, is beyond the constant velocity's window.
  double field_track_turn_below = 0.7;
  OrientationHistogramParams field_track_turn;
  /// Where a log starts in a map (LocalizeFirstScan, run --map without --initial): the first
  /// localized pose counts once this many more scans have been matched after it with the
  /// tracking never lost in between (0: at once). A pose found by the global search alone can
  /// be a look-alike place, whose tracking then fails within a few scans; a continued map built
  /// on it is wrong for good (aces two sessions, one copy of five: 16 m ATE).
  int first_pose_confirm_scans = 3;
  /// While searching, a pose the registration does not match at once is not tried again: the
  /// poses of a search (the global one, the recheck, the search off the map) are verified, and
  /// the hypotheses of a robot that is lost or ambiguous are tracked after a scan they missed,
  /// without the second attempt of a tracked scan (with odometry the window search around the
  /// pose, window_search_fallback; without, more seed pairs, thorough_retry): the search comes
  /// back at the next scan anyway. The second attempts were most of the slowest scans' time
  /// (infinite-corridor's second half in its first half's map without odometry: four
  /// hypotheses tracked after a miss, 53 ms each, and eight poses of the global search, up to
  /// 10 ms each when they fail). true: the second attempts as in tracking.
  bool search_retry = false;
  /// The fast track's fit while tracking in the map, in place of the mapper's
  /// (ShapeSlamParams::fast_track_min_fit, with odometry: the prediction refined alone is taken
  /// when this fraction of the scan fits the map before and after; above 1: off). The same 0.95
  /// by default. Lower trades a little accuracy for speed: at 0.85, in the own map with
  /// odometry (3 noisy copies of each development log, idle machine), the tracking median fell
  /// from 3.5-3.8 to 2.0-2.2 ms on aces and 2.5-2.8 to 2.1-2.2 ms on freiburg-079, the p95 from
  /// 6.3-6.4 to 3.6-3.7 ms on infinite-corridor; the ATE against the reference stayed within 2
  /// mm, but a few scans a log took a heading 2-6.6 deg off that shape matching would have
  /// mended (intel: 3 scans of 910 more outside 0.10 m / 2 deg of the mapping run in each copy;
  /// docs/notebook.md, 2026-12-06).
  double fast_track_min_fit = 0.95;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

enum class LocalizerStatus { kSearching, kAmbiguous, kTracking, kLost };

/// A short name: "searching", "ambiguous", "tracking", "lost".
const char* ToString(LocalizerStatus status);

/// What the localizer made of one scan.
struct LocalizerReport {
  double timestamp_s = 0.0;
  LocalizerStatus status = LocalizerStatus::kSearching;
  bool localized = false;      ///< status is tracking: T_map_robot is the pose
  bool matched = false;        ///< this scan found a trusted match (else the pose is predicted)
  Pose2 T_map_robot;           ///< the pose (tracking) or the best hypothesis, if any
  double inlier_ratio = 0.0;   ///< fraction of the scan explained at T_map_robot
  int hypotheses = 0;          ///< hypotheses kept after this scan
  bool lost_event = false;     ///< tracking was lost at this scan
  bool recovered_event = false;  ///< the pose was found again after a loss at this scan
  bool rechecked = false;  ///< the map's check moved the tracked pose (LocalizerParams::recheck_*)
  /// Without odometry, the map's likelihood field predicted the scan
  /// (LocalizerParams::field_track_*).
  bool field_tracked = false;
};

class Localizer {
 public:
  /// Copies the map (it is never changed). Throws std::invalid_argument on invalid params or an
  /// empty map.
  explicit Localizer(PolylineMap map, const LocalizerParams& params = {});

  /// Starts tracking from a known robot pose, skipping the global search.
  void SetInitialPose(const Pose2& T_map_robot);

  /// Localizes the next scan. Throws std::invalid_argument for a malformed scan.
  LocalizerReport Process(const LaserScan& scan);

  const PolylineMap& Map() const { return map_; }
  /// The params as given, but stages.fast_track_min_fit is the localizer's (fast_track_min_fit).
  const LocalizerParams& Params() const { return params_; }
  /// The odometry's heading error learned from the tracked scans (stages.odometry_calibration,
  /// as the mapper learns it) and taken out of each increment before it predicts a scan.
  const OdometryCalibrator& OdometryCalibration() const { return odometry_calibrator_; }

 private:
  struct Hypothesis {
    Hypothesis(const Pose2& pose, double evidence_samples, double fit_ratio,
               const MotionModelParams& motion_model)
        : T_map_robot(pose), evidence(evidence_samples), fit(fit_ratio), velocity(motion_model) {}
    Pose2 T_map_robot;
    double evidence = 0.0;
    double fit = 0.0;
    ConstantVelocity velocity;  // without odometry, predicts the next motion
    // Its pose at the last scan whose odometry moved on (the odometry's increments start
    // there; after a stalled scan, ShapeSlamParams::stale_odometry_min_step_m); unset: T_map_robot.
    std::optional<Pose2> T_map_robot_at_odometry;
    int misses = 0;             // consecutive scans without a trusted match
    bool tracked = false;  // the pose tracked until a loss: accepted again at min_inlier_ratio
  };
  // The last matched scan while tracking, a keyframe as in the mapper (use_last_keyframe,
  // keyframe.min_*): its polylines join the map in the model of the next scans.
  struct RecentScan {
    ScanShapes shapes;    // sensor frame
    Pose2 T_map_sensor;
  };
  struct Verified {
    Pose2 T_map_robot;
    double fit = 0.0;
    double explained = 0.0;  // samples explained: fit times the number of samples
    bool trusted = false;
    Pose2 correction;        // of the prediction (sensor frame), and its covariance
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  };
  bool Recheck(const ScanShapes& shapes, const LaserScan& scan,
               const std::vector<Point2>& samples, bool odometry, Verified& v,
               std::optional<double>& map_fit);
  // What only the tracked pose gets (TrackPose): its recent scan, the visible map without what
  // the scan saw through (with odometry), and the retry's wider occlusion tolerance.
  struct TrackingAids {
    const RecentScan* recent = nullptr;
    bool see_through = false;
    double depth_tolerance_m = 0.0;
    const ShapeSlamParams* stages = nullptr;  // in place of params_.stages (the field track's)
  };
  TrackingAids SearchAids() const;
  Verified Track(const ScanShapes& shapes, const LaserScan& scan, const Hypothesis& hypothesis,
                 const std::optional<Pose2>& odometry_delta, int lost_scans, double min_fit,
                 const TrackingAids& aids) const;
  std::optional<Verified> FieldTrack(const ScanShapes& shapes, const LaserScan& scan,
                                     const std::vector<Point2>& samples, const Hypothesis& h,
                                     double min_fit, const TrackingAids& aids) const;
  void KeepRecent(const ScanShapes& shapes, const LaserScan& scan, const Pose2& T_map_robot);
  double TrackingMinFit() const;
  bool FieldTrackOn(const std::optional<Pose2>& odometry_delta) const;
  Verified Verify(const ScanShapes& shapes, const LaserScan& scan, const Pose2& T_map_sensor,
                  double min_fit) const;
  Verified VerifyRobot(const ScanShapes& shapes, const LaserScan& scan, const Pose2& T_map_robot,
                       double min_fit, const TrackingAids& aids) const;
  std::vector<Verified> VerifiedGlobalPoses(const ScanShapes& shapes, const LaserScan& scan,
                                            const std::vector<Point2>& samples,
                                            double min_fit) const;
  void PropagateHypotheses(const ScanShapes& shapes, const LaserScan& scan,
                           const std::vector<Point2>& samples,
                           const std::optional<Pose2>& odometry_delta);
  void AddGlobalHypotheses(const ScanShapes& shapes, const LaserScan& scan,
                           const std::vector<Point2>& samples);
  void PruneHypotheses();
  LocalizerReport Search(const ScanShapes& shapes, const LaserScan& scan,
                         const std::optional<Pose2>& odometry_delta);
  Verified RegisterTracked(const ScanShapes& shapes, const LaserScan& scan, const Hypothesis& h,
                           const std::optional<Pose2>& odometry_delta,
                           const std::vector<Point2>& samples, TrackingAids& aids,
                           bool& field_tracked) const;
  LocalizerReport TrackPose(const ScanShapes& shapes, const LaserScan& scan,
                            const std::optional<Pose2>& raw_odometry_delta);
  std::optional<Pose2> Calibrated(const std::optional<Pose2>& raw_odometry_delta) const;
  void LearnOdometry(const Pose2& raw_odometry_delta, const Pose2& odometry_delta,
                     const Verified& v);
  std::vector<Point2> GlobalSamples(const ScanShapes& shapes) const;
  bool RelocalizeOffMap(const ScanShapes& shapes, const LaserScan& scan,
                        const std::vector<Point2>& samples,
                        const std::optional<Pose2>& odometry_delta, Verified& v,
                        const std::optional<double>& tracked_map_fit);
  std::optional<Verified> SearchOffMap(const ScanShapes& shapes, const LaserScan& scan,
                                       const std::vector<Point2>& samples,
                                       const Pose2& T_map_robot_tracked) const;
  static void Motion(Hypothesis& hypothesis, const Pose2& T_map_robot, bool confirmed);
  std::optional<Pose2> OdometryDelta(const LaserScan& scan, bool& stale);

  LocalizerParams params_;
  PolylineMap map_;
  std::vector<Polyline> walls_;  // every map polyline, map frame
  WindowSearch global_search_;  // the map's likelihood field and pyramid, built once
  ShapeSlamParams field_stages_;  // the stages with the field track's prior (FieldTrack)
  ShapeSlamParams search_stages_;  // the stages of a search's registrations (search_retry)
  std::vector<Hypothesis> hypotheses_;  // best first; one while tracking
  std::optional<RecentScan> recent_;    // tracking only
  // field_track_turn_below: the last scan's orientation histogram (kept at every scan), and,
  // for a scan without an odometry increment, the turn from it to the scan being processed.
  OrientationHistogram last_histogram_;
  std::optional<double> scan_turn_;
  LocalizerStatus status_ = LocalizerStatus::kSearching;
  bool was_localized_ = false;
  int drop_scans_ = 0;   // tracking: consecutive scans with a dropped fit
  int off_map_scans_ = 0;  // tracking: consecutive scans the map alone explains poorly
  std::optional<Hypothesis> challenger_;  // off the map: a pose the map explains better
  int challenger_scans_ = 0;              // scans it has stayed so
  int recheck_scans_ = 0;  // tracking: matched scans since the map's last check
  double fit_mean_ = 0.0;
  std::optional<Pose2> last_T_odom_robot_;
  OdometryMotionCheck odometry_motion_;
  OdometryCalibrator odometry_calibrator_;
};

/// Where a log starts in a finished map (`shape-slam run --map`, then ShapeSlam's constructor
/// from a map): the first scan the Localizer localizes by its global search.
struct FirstPose {
  std::size_t scan = 0;  ///< index of that scan
  Pose2 T_map_robot;     ///< its pose in the map
};

/// Runs the scans through a Localizer of `map` and returns the first scan of [0, max_scans) it
/// localizes and then confirms (LocalizerParams::first_pose_confirm_scans; the confirming scans
/// may lie beyond max_scans; at the log's end an unconfirmed pose still counts), or nullopt
/// when none is. Throws std::invalid_argument for invalid params,
/// an empty map or a malformed scan.
std::optional<FirstPose> LocalizeFirstScan(const PolylineMap& map,
                                           const std::vector<LaserScan>& scans,
                                           std::size_t max_scans,
                                           const LocalizerParams& params = {});

}  // namespace shape_slam
