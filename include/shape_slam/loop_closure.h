// Loop closure over the keyframe pose graph (beyond the paper, which leaves cycle detection to
// future work, §7): candidates, matching, verification and acceptance.
//
//   candidates    old keyframes within a search region that grows with the uncertainty of the
//                 current pose relative to them: the distance along the pose graph (driving,
//                 shortened by the loops already closed) times a drift rate, so that the region
//                 is small right after a closure and covers the drift around a large loop;
//   matching      the new keyframe against a submap of the old place (the candidate keyframe and
//                 its neighbours along the old path), by shape without a guess (§4.3: the drift
//                 may exceed what a guess-based match tolerates) and with the estimate as guess,
//                 each finished by the Ceres refinement (alignment_refinement.h);
//   verification  both sides must explain each other (inlier ratios both ways), the match must
//                 constrain every direction (no closure along a featureless corridor), the
//                 correction it asks of the graph must lie within the uncertainty, and no other
//                 place of the same search may fit nearly as well elsewhere (look-alike places);
//   acceptance    a closure that corrects the graph by more than the base bound waits until
//                 another one agrees with it: the cycle the two form through the graph must close
//                 within a tolerance that grows with the length of its chains (pairwise
//                 consistency, as in Olson's single-cluster graph partitioning and Mangelson's
//                 PCM). Loop edges get a robust (Cauchy) loss in the graph (pose_graph.h).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "shape_slam/pose_graph.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam/types.h"

namespace shape_slam {
namespace internal {
struct RegistrationResult;  // internal/registration.h
}

struct LoopClosureParams {
  bool enabled = true;
  /// Keyframes between loop searches. A search (shape matching against up to max_candidates
  /// old places, with and without the estimate as guess) costs several times a scan's
  /// tracking; measured on the development logs, searching every 4th keyframe instead of every
  /// 2nd closed the same loops as well and cut the median time per scan by a quarter.
  int search_every = 4;
  /// The search region around the estimate: search_radius_m plus search_radius_per_m times the
  /// distance along the pose graph to the old keyframe (driving, shortened by closed loops),
  /// at most max_search_radius_m. Shape matching needs no guess, so a wide region costs only
  /// the candidates tried; wrong candidates are caught by the verification.
  double search_radius_m = 8.0;
  double search_radius_per_m = 0.10;
  double max_search_radius_m = 60.0;
  double min_travel_m = 10.0;       ///< metres driven since the candidate keyframe
  /// Candidates must have looked within max_view_angle_rad of the current heading, plus
  /// view_angle_per_m per metre of graph distance (at most pi). The submap holds views from
  /// along the old path, so a place driven through the other way can be matched; where the
  /// graph is uncertain (a large loop) that is worth its risk; nearby it adds little and, in
  /// narrow corridors that look the same both ways, costs wrong closures. Measured (ATE
  /// infinite-corridor with odometry / intel without): no growth 17.0 / 0.56 m, every heading
  /// 3.1 / 4.7 m, 0.02 rad/m 1.95 / 5.7 m, 0.008 rad/m 1.17 / 0.94 m.
  double max_view_angle_rad = 1.2;
  double view_angle_per_m = 0.008;
  /// At the end of the log the last keyframes are searched once more (this many, 2 keyframes
  /// apart, so that a closure found at one can be confirmed by the next) with candidates from
  /// every heading: a robot's last metres often retrace its path the other way (aces: the last
  /// 10 scans, whose searches found no candidate within max_view_angle_rad, drifted 0.13 -> 0.29
  /// m), and no later keyframe will search there. Not in the paper. 0: off.
  int final_searches = 2;
  /// Before them, at the end of the log, every this many keyframes (0: off) are searched once
  /// more, earliest first, with candidates from every heading, as the final searches are: a
  /// corridor driven twice in opposite directions is closed, which max_view_angle_rad kept
  /// from the run's searches (infinite-corridor: such passes had no closure between them and
  /// the map held both passes' walls 0.2-0.3 m apart, where `localize` in the own map sat by
  /// either set). Searching from every heading during the whole run instead put one of 5 noisy
  /// copies of infinite-corridor 15.9 m off (every closure right by the reference, the graph
  /// bent); at the end the graph already holds every closure the run found. A correcting
  /// closure is optimised at once, as during the run. Not in the paper.
  int final_sweep_every = 8;
  /// A search closes no loop when a full match against another old place puts the new
  /// keyframe more than ambiguity_m from where the best match puts it and fits (inlier ratio)
  /// within ambiguity_fit_margin of the best: the places look alike (a long corridor's
  /// repeating doors and pillars), and the fits cannot say which is right. The closure the
  /// search would have kept is recorded as ambiguous. ambiguity_m 0: off. Measured on
  /// infinite-corridor with odometry: where the matches of a search disagreed, the one kept
  /// was wrong 22 times of 29; a clearly better fit (the margin) was mostly right, and a loop
  /// whose right place fits 0.12-0.26 better than the places its corridor slides to
  /// (LoopClosureTest) stays open with a margin of 0.25 or more (docs/design.md).
  double ambiguity_m = 1.0;
  double ambiguity_fit_margin = 0.2;
  /// Look-alikes along one corridor (not in the paper; AcrossCorridor): where the matches that
  /// fit within ambiguity_fit_margin of the best all put the keyframe at one heading (within
  /// corridor_heading_rad of the best's) and on one line (within corridor_offset_m of it),
  /// they disagree only along that line: the heading and the offset across it are known. The
  /// best match is then kept for those alone -- its position along the line is the graph's own,
  /// with corridor_sigma_m of standard deviation along it -- and decided as any closure
  /// (pending until a consistent one confirms it). Only with odometry (LoopKeyframe::odometry):
  /// without it the graph's position along a corridor is the scans' own, which is what slides
  /// there. corridor_sigma_m 0: off, such a search is ambiguous. Measured on infinite-corridor
  /// (docs/notebook.md, 2026-12-08): at its big loop's return every search was refused as
  /// ambiguous, most with their matches on one line, while the heading they agreed on was
  /// 10-25 deg off the graph's.
  double corridor_heading_rad = 0.05;
  double corridor_offset_m = 0.5;
  double corridor_sigma_m = 10.0;
  /// Old places tried per search (spread along the old path); the best verified match wins.
  /// The best-ranked one is tried at every search, the others in turn (the region can hold
  /// many more places than a search tries).
  int max_candidates = 3;
  /// The old place is the candidate keyframe and the keyframes within this much driving of it
  /// (before and after; every submap_step_m of driving, the candidate's frame), metres: a
  /// corridor driven the other way was seen by keyframes up to a scan's range ahead.
  double submap_travel_m = 6.0;
  double submap_step_m = 1.0;
  /// The window search (window_search.h) over the submap: the place's polylines as a
  /// likelihood field, searched around the estimate (half window = the correction bound, at
  /// most window_half_m) or, when the bound is larger, around the candidate itself, every
  /// heading the bound allows.
  double window_half_m = 6.0;
  double window_resolution_m = 0.15;
  int window_max_evaluations = 40000;
  double min_inlier_ratio = 0.6;    ///< of the new scan explained by the old place
  /// Of the old place's samples that the new scan could have seen (in its field of view and
  /// range, not behind what it saw), this fraction must be explained by the new scan.
  double min_reverse_inlier_ratio = 0.4;
  /// A match whose position standard deviation (refinement covariance, largest direction)
  /// exceeds this is degenerate (a corridor along its axis) and closes no loop, metres.
  double max_match_sigma_m = 0.02;
  /// Edge covariances are the refinement's (which treats samples as independent) times this.
  double covariance_scale = 10.0;
  double sigma_floor_m = 0.02;      ///< edge standard deviation at least, metres
  double sigma_floor_rad = 0.01;    ///< edge standard deviation at least, radians
  /// The uncertainty a closure may correct: at most max(max_correction_m, max_correction_per_m
  /// * graph distance) (and within the search region) and max_correction_rad +
  /// max_correction_rad_per_m * graph distance (at most pi): drift is bounded, look-alike
  /// places far off are not.
  double max_correction_m = 1.0;
  double max_correction_per_m = 0.1;
  double max_correction_rad = 0.5;
  double max_correction_rad_per_m = 0.003;
  /// A closure whose match explains at least this fraction both ways and that corrects the
  /// graph by at most max_correction_m and max_correction_rad is used at once; any other one
  /// that would correct the graph waits (confirm_within_keyframes keyframes, or see
  /// confirm_near_m) for a second closure that is consistent with it.
  double strong_inlier_ratio = 0.8;
  /// The quick check: when the new keyframe fits the old place at the graph's estimate (after
  /// the quick ICP and the refinement) by at least this fraction, and it passes the verification,
  /// the closure is taken without shape matching or window search (the graph is already right
  /// there). Above 1: every candidate gets the full search.
  double quick_min_fit = 0.85;
  /// A place where the window search's best pose has a mean likelihood (window_search.h) below
  /// this is not shape-matched: no pose of the window overlaps it. A match the verification
  /// accepts (min_inlier_ratio of the scan within 10 cm) scores about 0.5 on the window grid;
  /// this keeps half of that as margin.
  double window_min_fit = 0.25;
  /// A candidate pose of the full search that fits the place (fraction of the scan within
  /// inlier_distance_m after the quick ICP) less than this is not refined: the verification
  /// needs min_inlier_ratio at the refined pose, and the refinement moves a candidate only by
  /// centimetres from where the quick ICP left it. On the development logs no candidate that
  /// the verification accepted fitted less than 0.52 before refinement.
  double refine_min_fit = 0.45;
  int confirm_within_keyframes = 10;
  /// A pending closure that asks for more than max_correction_m (the graph drifted; it could
  /// never be taken alone) may also be confirmed later, up to confirm_near_keyframes after it,
  /// by a closure that asks for more than max_correction_m too and whose new keyframe lies
  /// within confirm_near_m of its own (graph poses): the same visit of the same spot, however
  /// many keyframes the robot spent wandering there (a robot turning on the spot makes a
  /// keyframe at every turn). 0 switches it off.
  double confirm_near_m = 3.0;
  int confirm_near_keyframes = 40;
  /// Two closures are consistent when the cycle they form through the graph (old keyframe ->
  /// loop -> new keyframe -> graph -> other new keyframe -> loop -> other old keyframe -> graph
  /// -> first old keyframe) closes within confirm_tolerance_m (+ confirm_tolerance_per_m per
  /// metre of its two graph chains) and confirm_tolerance_rad (+ confirm_tolerance_rad_per_m).
  double confirm_tolerance_m = 0.2;
  double confirm_tolerance_per_m = 0.02;
  double confirm_tolerance_rad = 0.05;
  double confirm_tolerance_rad_per_m = 0.002;
  /// Closures that would correct the graph are tried on a copy first: optimised with them, the
  /// graph must still agree (within verify_tolerance_m and _rad) with more than
  /// 1 - max_broken_fraction of the earlier loop edges that it agreed with before.
  double verify_tolerance_m = 0.3;
  double verify_tolerance_rad = 0.05;
  double max_broken_fraction = 0.1;
  /// Candidates are ordered by (distance plus this many metres per radian of heading
  /// difference) relative to their search radius ...
  double candidate_turn_weight_m_per_rad = 2.0;
  /// ... and spread along the old path: no two tried within this much driving of each other.
  double candidate_spacing_m = 2.0;
  /// A keyframe whose pose no match confirmed is tied to the previous one by an edge with these
  /// standard deviations (a weak constraint), metres and radians.
  double unconfirmed_sigma_m = 0.3;
  double unconfirmed_sigma_rad = 0.1;
  /// With SubmapParams::restart_when_lost (submaps, no odometry), a keyframe no match confirmed
  /// is the motion model's guess: its edge has these standard deviations ...
  double guess_sigma_m = 0.5;
  double guess_sigma_rad = 0.5;
  /// ... and the loop search counts it as this much driving (m): the search region, heading
  /// range and correction bounds beyond it grow as after that much drift.
  double guess_graph_m = 100.0;
  /// Without odometry, a keyframe's edge to the previous one is widened along
  /// a ridge of fits (internal::WidenedAlongRidge): shifts of up to this much (metres; 0: off)
  /// along the direction it constrains least are tried ...
  double ridge_max_shift_m = 1.0;
  /// ... and count as fitting as well when the fit drops by at most this much.
  double ridge_fit_margin = 0.05;
  /// A loop edge that disagrees with the graph by more than this triggers optimisation.
  double min_correction_m = 0.05;
  double min_correction_rad = 0.01;
  PoseGraphParams graph;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// Covariance of a pose-graph edge from a refinement covariance: scaled by covariance_scale
/// (the refinement treats samples as independent), floored, kept positive definite.
Eigen::Matrix3d EdgeCovariance(const Eigen::Matrix3d& refined, const LoopClosureParams& params);

/// A keyframe as loop closure sees it.
struct LoopKeyframe {
  int node = 0;             ///< its pose-graph node
  ScanShapes shapes;        ///< its polylines, sensor frame (coarse: matching; fine: alignment)
  Pose2 T_robot_sensor;
  double travel_m = 0.0;    ///< distance driven when it was taken
  /// The log's odometry was in use when it was taken: the graph's positions are then the
  /// wheels' between closures, and AcrossCorridor may keep one of them along a corridor.
  bool odometry = false;
};

/// A loop closure found by a search.
struct LoopClosure {
  PoseGraphEdge edge;       ///< robot frames; edge.loop is true
  int old_keyframe = 0;
  int new_keyframe = 0;
  Pose2 correction;         ///< what the edge asks of the new keyframe's pose, in its frame
  double inlier_ratio = 0.0;
  double reverse_inlier_ratio = 0.0;
  double graph_distance_m = 0.0;  ///< along the graph between the two keyframes, when found
  /// The edge holds the heading and the offset across a corridor only (AcrossCorridor): along
  /// the direction along_rad (in the old keyframe's frame) it is the graph's own estimate.
  bool across_only = false;
  double along_rad = 0.0;
};

/// What became of a closure a search found (LoopCloser::Events).
enum class LoopDecision {
  kAgreed,     ///< agreed with the graph already: added, nothing to correct
  kTaken,      ///< strong (strong_inlier_ratio both ways, small correction): added at once
  kPending,    ///< waits for a second closure that agrees with it
  kConfirmed,  ///< added with the closures it agrees with (a pending one is listed again)
  kRefused,    ///< with it the graph broke earlier closures (BreaksEarlierLoops): dropped
  kAmbiguous,  ///< other old places matched elsewhere in the same search (ambiguity_m): dropped
};

/// The name of a decision as loops.csv writes it ("agreed", "taken", ...).
const char* LoopDecisionName(LoopDecision decision);

/// One closure found by a search, and what became of it.
struct LoopEvent {
  LoopClosure closure;
  LoopDecision decision = LoopDecision::kPending;
};

struct RankedCandidate;  // candidate_selection.h

class LoopCloser {
 public:
  /// `match`: the shape matching, selection and refinement settings (the mapper's own,
  /// ToScanMatchParams). Throws std::invalid_argument on invalid parameters.
  LoopCloser(const LoopClosureParams& params, const ScanMatchParams& match);

  /// Called after every new keyframe (the last of `keyframes`, whose node the graph holds).
  /// Every search_every keyframes: searches, verifies and adds the accepted loop edges to the
  /// graph. Returns true when an accepted edge disagrees with the graph (optimise it).
  bool Update(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph);
  /// At the end of the log: every final_sweep_every-th keyframe, then the last keyframes
  /// (final_searches), searched once more from every heading and decided as Update decides.
  /// The sweep calls `optimize` after each correcting closure, so that the next keyframe is
  /// searched in the corrected graph (the graph's owner optimises, as after Update). Once per
  /// last keyframe. Returns true when a closure of the final searches asks for an optimisation
  /// (as Update).
  bool FinalUpdate(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph,
                   const std::function<void()>& optimize);

  /// Loop edges accepted so far.
  int NumLoopClosures() const { return num_accepted_; }
  /// Loop searches run and closures found (verified, before acceptance) so far.
  int NumSearches() const { return num_searches_; }
  int NumFound() const { return num_found_; }
  /// Groups of closures refused because the graph with them broke earlier closures.
  int NumRejected() const { return num_rejected_; }
  /// Searches whose matches disagreed (LoopClosureParams::ambiguity_m).
  int NumAmbiguous() const { return num_ambiguous_; }
  /// Every closure found so far and what became of it, in order (a pending closure that a
  /// later one confirms is listed twice): the record that says which closures bent the map.
  const std::vector<LoopEvent>& Events() const { return events_; }

  /// Whether two closures agree (the cycle they form through the graph closes, see
  /// confirm_tolerance_*). Never across a guessed step: where either chain of the cycle along
  /// the graph cannot avoid a keyframe only the motion model placed (guess_sigma_*), the cycle
  /// checks nothing.
  bool Consistent(const LoopClosure& a, const LoopClosure& b,
                  const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph) const;
  /// Whether a later closure may confirm a pending one: from a later keyframe, within
  /// confirm_within_keyframes of it or near it (confirm_near_m). `keyframes` reach both
  /// (exposed for tests).
  bool MayConfirm(const LoopClosure& pending, const LoopClosure& later,
                  const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph) const;

 private:
  /// Whether a closure asks for more than max_correction_m (and confirm_near_m is on).
  bool AsksLargeCorrection(const LoopClosure& closure) const;
  // The search path takes the keyframe searched, `current`, and sees only keyframes 0..current:
  // FinalUpdate searches earlier keyframes as if each were the last.

  /// Driving along the graph from keyframe `from` to each keyframe up to `current`, a guessed
  /// step counting guess_m more (LoopClosureParams::guess_graph_m, or more to find chains that
  /// avoid one).
  std::vector<double> GraphDistances(const std::vector<LoopKeyframe>& keyframes,
                                     const PoseGraph& graph, int from, double guess_m,
                                     int current) const;
  /// Candidates of keyframe `current`, seen within max_view_angle_rad (plus view_angle_per_m).
  std::vector<int> CandidatesAt(const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph,
                                const std::vector<double>& graph_distance, int current,
                                double max_view_angle_rad) const;
  bool ConsistentAt(const LoopClosure& a, const LoopClosure& b,
                    const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph,
                    int current) const;
  struct Sides;  // both sides of a candidate match (loop_closure.cpp)
  /// Both sides of a match of keyframe `current` against the place around `old`; null when
  /// either has nothing to match.
  std::unique_ptr<Sides> MakeSides(const std::vector<LoopKeyframe>& keyframes, const PoseGraph& graph,
                                   int old, int current, double graph_distance) const;
  /// The quick check at the graph's estimate (quick_min_fit) and the full search (window search,
  /// shape matching, selection); each returns the verified closure or nullopt.
  std::optional<LoopClosure> QuickMatch(const Sides& sides, const PoseGraph& graph) const;
  std::optional<LoopClosure> FullMatch(const Sides& sides, const PoseGraph& graph) const;
  // The best match of keyframe `current` among the candidates (quick checks first).
  std::optional<LoopClosure> Search(const std::vector<LoopKeyframe>& keyframes,
                                    const PoseGraph& graph, int current, double max_view_angle_rad);
  // Whether the graph optimised with `accepted` breaks too many earlier loop edges.
  bool BreaksEarlierLoops(const PoseGraph& graph, const std::vector<LoopClosure>& accepted) const;
  /// The refinement of one candidate against the place; nullopt unless it converged.
  std::optional<RefinementResult> Refine(const Sides& sides, const RankedCandidate& candidate) const;
  /// The closure a refined match implies, if it passes the verification (both sides explain
  /// each other, every direction constrained, correction within the uncertainty).
  std::optional<LoopClosure> Verify(const Sides& sides, const internal::RegistrationResult& registered,
                                    const PoseGraph& graph) const;
  double SearchRadius(double graph_distance_m) const;
  double CorrectionBoundM(double graph_distance_m) const;
  double CorrectionBoundRad(double graph_distance_m) const;

  // The search and decision at keyframe `current` (Update: the last; FinalUpdate: the sweep's
  // and the last ones, from every heading).
  bool SearchAndDecide(const std::vector<LoopKeyframe>& keyframes, PoseGraph& graph, int current,
                       double max_view_angle_rad);

  LoopClosureParams params_;
  ScanMatchParams match_;
  int final_searched_ = -1;  // the last keyframe FinalUpdate searched
  std::vector<LoopClosure> pending_;
  std::vector<LoopEvent> events_;
  int round_robin_ = 0;  // turn of the candidates after the best-ranked one (Update advances it)
  int num_accepted_ = 0;
  int num_searches_ = 0;
  int num_found_ = 0;
  int num_rejected_ = 0;
  int num_ambiguous_ = 0;
};

/// The pose of a keyframe in the graph as a match against one old place puts it, and the fit.
struct ImpliedPose {
  Pose2 T_graph_keyframe;
  double fit = 0.0;
};

/// Whether a match fits within fit_margin of the best one yet puts the keyframe more than
/// ambiguity_m from where the best puts it (LoopClosureParams::ambiguity_m; never when 0).
bool AmbiguousMatches(const std::vector<ImpliedPose>& implied, double ambiguity_m,
                      double fit_margin);

/// An ambiguous search's best closure `best` (its implied pose the best of `implied`) kept for
/// the heading and the offset across a corridor, when every match within ambiguity_fit_margin
/// of the best lies on one line at one heading (LoopClosureParams::corridor_*); else none. Its
/// position along the line is the graph's (the correction asks nothing along it), its variance
/// along it corridor_sigma_m squared more.
std::optional<LoopClosure> AcrossCorridor(const std::vector<ImpliedPose>& implied,
                                          const LoopClosure& best, const PoseGraph& graph,
                                          const LoopClosureParams& params);

}  // namespace shape_slam
