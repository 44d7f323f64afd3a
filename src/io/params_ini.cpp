#include "shape_slam_io/params_ini.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <variant>
#include <vector>

#include "shape_slam_io/json_writer.h"

namespace shape_slam::io {
namespace {

// One ini key bound to a parameter field.
struct Field {
  const char* section;
  const char* key;
  const char* doc;
  std::variant<double*, int*, bool*> target;
};

// Every tunable parameter of the mapper. fov_rad of the visibility is set per scan from the
// scan's own field of view and is therefore not a key.
std::vector<Field> Fields(ShapeSlamParams& p) {
  return {
      {"extraction", "max_gap_m", "split polylines where consecutive points are farther apart (m, paper §3.1: 0.20)", &p.shapes.extraction.max_gap_m},
      {"extraction", "gap_beam_spacing_factor", "... or farther than this many times the beam spacing at their range (0: off)", &p.shapes.extraction.gap_beam_spacing_factor},
      {"extraction", "min_range_m", "readings at or below this are invalid (m)", &p.shapes.extraction.min_range_m},
      {"extraction", "min_points", "polylines with fewer points are dropped", &p.shapes.extraction.min_points},
      {"dce", "threshold_m", "DCE stop threshold on the relevance K of eq. (1) before shape matching (m)", &p.shapes.dce.threshold_m},
      {"pipeline", "use_odometry", "predict poses from the log's odometry (false: paper §4.3 shape matching alone)", &p.use_odometry},
      {"pipeline", "use_last_keyframe", "also match each scan against the last keyframe's polylines (not only the map)", &p.use_last_keyframe},
      {"pipeline", "max_shape_vertices", "shape matching compares polylines with at most this many vertices", &p.shapes.max_shape_vertices},
      {"pipeline", "alignment_max_deviation_m", "the alignment polylines stay within this of the scan points (m)", &p.shapes.alignment_max_deviation_m},
      {"pipeline", "alignment_dce_threshold_m", "lighter DCE of the polylines whose samples drive the alignment (m)", &p.shapes.alignment_dce_threshold_m},
      {"pipeline", "visibility_fov_margin_rad", "visible map shape = scan field of view widened by this on each side (rad)", &p.visibility_fov_margin_rad},
      {"pipeline", "max_prior_mahalanobis", "with odometry, estimates beyond this many standard deviations of it are rejected", &p.max_prior_mahalanobis},
      {"pipeline", "max_motion_per_scan_m", "without odometry, estimates implying a larger motion since the last scan are rejected (m) ...", &p.max_motion_per_scan_m},
      {"pipeline", "max_turn_per_scan_rad", "... or a larger turn (rad)", &p.max_turn_per_scan_rad},
      {"pipeline", "velocity_window", "without odometry, the constant-velocity prediction is the mean motion of this many last scans", &p.motion_model.velocity_window},
      {"pipeline", "usual_speed_window", "... no slower than the median speed of this many last confirmed motions while driving straight (0: off)", &p.motion_model.usual_speed_window},
      {"pipeline", "usual_speed_max_turn_rad", "... straight: a predicted turn below this (rad per scan)", &p.motion_model.usual_speed_max_turn_rad},
      {"pipeline", "motion_prior_weight", "without odometry, candidates are ranked by fit less this * squared normalised motion from constant velocity", &p.motion_prior_weight},
      {"pipeline", "motion_prior_max_penalty", "... and that penalty is at most this (0: unbounded)", &p.motion_prior_max_penalty},
      {"pipeline", "motion_prior_sigma_m", "... translation scale (m)", &p.motion_prior_sigma_m},
      {"pipeline", "motion_prior_sigma_rad", "... rotation scale (rad)", &p.motion_prior_sigma_rad},
      {"pipeline", "motion_unknown_beyond_ends", "without odometry, samples continuing a model polyline past its open end are left out of the candidates' fit", &p.motion_unknown_beyond_ends},
      {"pipeline", "odometry_check_fit", "a scan fitting less than this at the odometry's estimate is also matched without odometry (0: off)", &p.odometry_check_fit},
      {"pipeline", "odometry_override_margin", "... and that match wins when it fits at least this much better", &p.odometry_override_margin},
      {"pipeline", "odometry_override_within_step", "... unless it moves the robot farther than both the odometry's step ...", &p.odometry_override_within_step},
      {"pipeline", "odometry_override_step_ratio", "... and this many times its longest recent step ...", &p.odometry_override_step_ratio},
      {"pipeline", "odometry_override_slack_m", "... plus this (m)", &p.odometry_override_slack_m},
      {"pipeline", "odometry_override_turn_slack_rad", "... nor turns it farther than both the odometry's turn and its largest recent turn plus this (rad)", &p.odometry_override_turn_slack_rad},
      {"pipeline", "odometry_override_min_along", "... and only if it moves the robot along the odometry's step by at least this fraction of it, less that slack (a lower value, e.g. -100: off)", &p.odometry_override_min_along},
      {"pipeline", "odometry_override_judged_step_m", "... judged so only where the odometry's step is at least this long (m)", &p.odometry_override_judged_step_m},
      {"pipeline", "stale_odometry_min_step_m", "a scan whose odometry pose equals the last scan's while the robot's recent steps reached this (m) is matched without odometry: the odometry stalled (a large value, e.g. 1000: off)", &p.stale_odometry_min_step_m},
      {"pipeline", "max_lost_growth", "without odometry, bound and window grow by 1 + scans without a match, up to this", &p.max_lost_growth},
      {"pipeline", "thorough_retry", "without odometry, a scan that found no trusted match is matched again with [scan_match]'s seed counts", &p.thorough_retry},
      {"pipeline", "max_untrusted_coverage", "an unconfirmed scan updates the map only if less than this fraction of it is near the map", &p.max_untrusted_coverage},
      {"pipeline", "new_territory_distance_m", "'near the map' distance of that rule (m)", &p.new_territory_distance_m},
      {"pipeline", "min_inlier_ratio", "a match is trusted when this fraction of the scan lies on the map after it", &p.min_inlier_ratio},
      {"pipeline", "fast_track_min_fit", "with odometry, take the refined prediction without shape matching when this fraction of the scan fits the map (above 1: always shape-match) ...", &p.fast_track_min_fit},
      {"pipeline", "fast_track_max_correction_m", "... and it lies within this of the prediction (m) ...", &p.fast_track_max_correction_m},
      {"pipeline", "fast_track_max_correction_rad", "... and this (rad)", &p.fast_track_max_correction_rad},
      {"pipeline", "keyframe_track_min_fit", "with odometry, a scan predicted short of the next keyframe first gets the fast track against the last keyframe alone, at this fit (the map only if that falls short; above 1: off)", &p.keyframe_track_min_fit},
      {"pipeline", "keyframe_track_without_odometry", "... and without odometry too, the constant-velocity motion standing for the odometry's (after a trusted match)", &p.keyframe_track_without_odometry},
      {"pipeline", "keyframe_track_turn_without_odometry_rad", "... its estimate turning at most this from the constant-velocity prediction (rad)", &p.keyframe_track_turn_without_odometry_rad},
      {"pipeline", "coarse_gate_m", "the refinement against the whole visible map starts with this wider gate (m)", &p.coarse_gate_m},
      {"pipeline", "index_cell_size_m", "cell size of the map's spatial index (m)", &p.index_cell_size_m},
      {"visibility", "max_range_m", "map polylines farther than this from the sensor are not visible (m)", &p.visibility.max_range_m},
      {"visibility", "angular_resolution_rad", "angular resolution of the visibility sweep (rad)", &p.visibility.angular_resolution_rad},
      {"visibility", "min_piece_length_m", "visible pieces shorter than this are dropped (m)", &p.visibility.min_piece_length_m},
      {"visibility", "depth_tolerance_m", "depth tolerance of the occlusion test (m)", &p.visibility.depth_tolerance_m},
      {"matcher", "lookahead", "S*: continue DCE while one of the next N removals improves similarity (paper §4.1: 3)", &p.matcher.similarity.lookahead},
      {"matcher", "skip_penalty_per_m", "P of eq. (4): penalty per metre of an unmatched polyline", &p.matcher.skip_penalty_per_m},
      {"matcher", "deviation_weight", "weight of D in eq. (4)", &p.matcher.deviation_weight},
      {"matcher", "deviation_sigma_m", "D: scale of the RMS distance of a pair under the estimate (m)", &p.matcher.deviation_sigma_m},
      {"matcher", "deviation_sigma_rad", "D: scale of the RMS direction difference of a pair (rad)", &p.matcher.deviation_sigma_rad},
      {"matcher", "max_misfit_m", "pairs farther apart than this under the estimate are not matched (m)", &p.matcher.max_misfit_m},
      {"matcher", "seeded_max_misfit_m", "the same gate in the second pass without odometry, after seeding (m)", &p.matcher.seeded_max_misfit_m},
      {"matcher", "max_angle_rad", "pairs turned more than this under the estimate are not matched (rad)", &p.matcher.max_angle_rad},
      {"matcher", "min_overlap_fraction", "a pair must overlap over this fraction of the shorter polyline", &p.matcher.min_overlap_fraction},
      {"matcher", "max_group_size", "largest group in 1-to-many / many-to-1 correspondences", &p.matcher.max_group_size},
      {"matcher", "num_seeds", "paper §4.3: most reliable pairs tried as seeds without odometry", &p.matcher.num_seeds},
      {"matcher", "max_seed_pairs", "paper §4.3: alignments induced by this many most reliable pairs are scored", &p.matcher.max_seed_pairs},
      {"matcher", "min_seed_length_m", "polylines shorter than this do not seed (m)", &p.matcher.min_seed_length_m},
      {"matcher", "rotation_prior_weight", "without odometry, prefer the smaller turn between equal fits by this weight", &p.matcher.rotation_prior_weight},
      {"matcher", "seed_icp_iterations", "ICP steps refining each seed before seeds are compared", &p.matcher.seed_icp_iterations},
      {"matcher", "seed_capture_distance_m", "association gate of those steps (m)", &p.matcher.seed_capture_distance_m},
      {"matcher", "seed_alignment_iterations", "ICP steps of a seed's induced alignment on its own pair", &p.matcher.seed_alignment_iterations},
      {"matcher", "fit_sample_spacing_m", "spacing of the samples that score seeds and final fits (m)", &p.matcher.fit_sample_spacing_m},
      {"matcher", "same_seed_m", "seeds inducing an alignment within this (m) ...", &p.matcher.same_seed_m},
      {"matcher", "same_seed_rad", "... and this (rad) of a finished earlier seed are the same", &p.matcher.same_seed_rad},
      {"matcher", "first_pass_group_size", "paper §4.3: largest group in the first pass", &p.matcher.first_pass_group_size},
      {"matcher", "inlier_distance_m", "a scan sample within this of the map counts as an inlier (m)", &p.matcher.inlier_distance_m},
      {"matcher", "deviation_sample_spacing_m", "spacing of the samples measuring D (m)", &p.matcher.deviation_sample_spacing_m},
      {"selection", "icp_iterations", "ICP steps finishing each candidate pose before candidates are compared", &p.selection.icp_iterations},
      {"selection", "equally_good_fit", "explained fractions closer than this count as equally good fits ...", &p.selection.equally_good_fit},
      {"selection", "turn_weight_m_per_rad", "... and the one nearest the prediction wins; distance = metres + this * radians", &p.selection.turn_weight_m_per_rad},
      {"selection", "max_refinements", "candidates refined at most, in order, until one is accepted", &p.selection.max_refinements},
      {"window_search", "without_odometry", "without odometry, search a pose window around the constant-velocity prediction", &p.window_search_without_odometry},
      {"window_search", "fallback", "with odometry, search a smaller window when no trusted match was found", &p.window_search_fallback},
      {"window_search", "odometry_scale", "... that window's size relative to the full one", &p.window_search_odometry_scale},
      {"window_search", "sample_spacing_m", "the search scores scan samples this far apart (m)", &p.window_search_spacing_m},
      {"window_search", "resolution_m", "cell size of the likelihood field (m)", &p.window_search.resolution_m},
      {"window_search", "hit_sigma_m", "width of the likelihood around the polylines (m)", &p.window_search.hit_sigma_m},
      {"window_search", "half_window_m", "translations searched: +- this in x and y (m)", &p.window_search.half_window_m},
      {"window_search", "half_window_rad", "rotations searched: +- this (rad)", &p.window_search.half_window_rad},
      {"window_search", "max_step_range_m", "the angular step moves samples up to this range by about one cell (m)", &p.window_search.max_step_range_m},
      {"window_search", "max_hypotheses", "distinct poses returned at most", &p.window_search.max_hypotheses},
      {"window_search", "distinct_m", "hypotheses closer than this (m) ...", &p.window_search.distinct_m},
      {"window_search", "distinct_rad", "... and this (rad) to a better one are the same", &p.window_search.distinct_rad},
      {"window_search", "min_relative_score", "hypotheses scoring below this fraction of the best are dropped", &p.window_search.min_relative_score},
      {"window_search", "prior_weight", "motion prior: score lowered by this * squared normalised distance from the centre", &p.window_search.prior_weight},
      {"window_search", "prior_sigma_m", "... translation scale (m)", &p.window_search.prior_sigma_m},
      {"window_search", "prior_sigma_rad", "... rotation scale (rad)", &p.window_search.prior_sigma_rad},
      {"window_search", "max_node_evaluations", "bound on the search's work (nodes scored)", &p.window_search.max_node_evaluations},
      {"alignment", "sample_spacing_m", "paper §5.1: sample the perceived polylines every (m)", &p.matcher.alignment.sample_spacing_m},
      {"alignment", "max_iterations", "ICP iterations at most", &p.matcher.alignment.max_iterations},
      {"alignment", "convergence_translation_m", "ICP stops when an update moves less than this (m) ...", &p.matcher.alignment.convergence_translation_m},
      {"alignment", "convergence_rotation_rad", "... and turns less than this (rad)", &p.matcher.alignment.convergence_rotation_rad},
      {"alignment", "max_correspondence_distance_m", "samples farther than this from their shape are ignored at first (m)", &p.matcher.alignment.max_correspondence_distance_m},
      {"alignment", "min_correspondence_distance_m", "the gate shrinks to no less than this (m)", &p.matcher.alignment.min_correspondence_distance_m},
      {"alignment", "reject_end_projections", "ignore samples projecting beyond a model polyline's open ends", &p.matcher.alignment.reject_end_projections},
      {"refinement", "loss_scale_m", "Ceres robust loss scale (m)", &p.refinement.loss_scale_m},
      {"refinement", "point_sigma_m", "standard deviation of a sample's distance to its wall (m)", &p.refinement.point_sigma_m},
      {"refinement", "max_correspondence_distance_m", "association gate (m)", &p.refinement.max_correspondence_distance_m},
      {"refinement", "outer_iterations", "association + solve rounds", &p.refinement.outer_iterations},
      {"refinement", "max_solver_iterations", "Ceres iterations per round", &p.refinement.max_solver_iterations},
      {"refinement", "min_correspondences", "fewer associated samples: the refinement is not trusted", &p.refinement.min_correspondences},
      {"refinement", "sample_spacing_m", "sample spacing of the refinement (m)", &p.refinement.sample_spacing_m},
      {"refinement", "reject_end_projections", "ignore samples projecting beyond a polyline's open ends", &p.refinement.reject_end_projections},
      {"map_update", "dce_threshold_m", "DCE threshold of merged and added map polylines (m)", &p.map_update.dce_threshold_m},
      {"map_update", "max_deviation_m", "... never moving a polyline farther than this from its points (m)", &p.map_update.max_deviation_m},
      {"map_update", "merge_sample_spacing_m", "bodies are averaged at points this far apart (m)", &p.map_update.merge_sample_spacing_m},
      {"map_update", "min_incidence_rad", "rays meeting a body at a smaller angle pair points along the normal instead (rad)", &p.map_update.min_incidence_rad},
      {"map_update", "max_support", "cap of a vertex's support (weight of the map in the average)", &p.map_update.max_support},
      {"map_update", "merge_max_misfit_m", "merge when the RMS distance over the overlap is at most (m)", &p.map_update.merge_max_misfit_m},
      {"map_update", "merge_max_angle_rad", "... the RMS direction difference at most (rad)", &p.map_update.merge_max_angle_rad},
      {"map_update", "merge_min_overlap_m", "... and the overlap at least this long (m)", &p.map_update.merge_min_overlap_m},
      {"map_update", "merge_min_overlap_fraction", "... or this fraction of the shorter polyline", &p.map_update.merge_min_overlap_fraction},
      {"map_update", "untrusted_clearance_m", "without a confirmed match, only polylines this far from the map are added (m)", &p.map_update.untrusted_clearance_m},
      {"map_update", "explained_distance_m", "a polyline within this of the map (m) ...", &p.map_update.explained_distance_m},
      {"map_update", "explained_fraction", "... over this fraction of its length is not added again", &p.map_update.explained_fraction},
      {"map_update", "min_new_length_m", "perceived polylines shorter than this are not added (m)", &p.map_update.min_new_length_m},
      {"map_update", "contradiction_margin_m", "a reading this far beyond a map polyline contradicts it (m)", &p.map_update.contradiction_margin_m},
      {"map_update", "untrusted_near_fraction", "... 'mostly': more than this fraction of its samples", &p.map_update.untrusted_near_fraction},
      {"map_update", "check_sample_spacing_m", "sample spacing of the new-territory, explained and contradiction checks (m)", &p.map_update.check_sample_spacing_m},
      {"map_update", "merge_check_spacing_m", "sample spacing of the check that a merge stays near its inputs (m)", &p.map_update.merge_check_spacing_m},
      {"map_update", "drop_max_observations", "drop rule: polylines seen at most this often ...", &p.map_update.drop_max_observations},
      {"map_update", "drop_min_contradictions", "... and contradicted at least this often are removed", &p.map_update.drop_min_contradictions},
      {"keyframe", "min_translation_m", "update the map after moving this far since the last update (m)", &p.keyframe.min_translation_m},
      {"keyframe", "min_rotation_rad", "... or turning this much (rad)", &p.keyframe.min_rotation_rad},
      {"submaps", "keyframes", "keyframes per submap (each keyframe goes into two)", &p.submaps.keyframes},
      {"submaps", "restart_when_lost", "without odometry, a scan no match confirmed is a keyframe that finishes the active submaps and starts new ones (its edge: guess_* in [loop_closure]) ...", &p.submaps.restart_when_lost},
      {"submaps", "restart_follow_m", "... unless its best candidate lies within this (m) ...", &p.submaps.restart_follow_m},
      {"submaps", "restart_follow_rad", "... and this (rad) of the constant-velocity prediction", &p.submaps.restart_follow_rad},
      {"loop_closure", "enabled", "search loop closures and optimise the keyframe pose graph", &p.loop_closure.enabled},
      {"loop_closure", "search_every", "keyframes between loop searches", &p.loop_closure.search_every},
      {"loop_closure", "search_radius_m", "old keyframes within this distance of the estimate are candidates (m) ...", &p.loop_closure.search_radius_m},
      {"loop_closure", "search_radius_per_m", "... plus this per metre of pose-graph distance to them (drift) ...", &p.loop_closure.search_radius_per_m},
      {"loop_closure", "max_search_radius_m", "... at most this (m)", &p.loop_closure.max_search_radius_m},
      {"loop_closure", "min_travel_m", "... if at least this much was driven since (m)", &p.loop_closure.min_travel_m},
      {"loop_closure", "max_view_angle_rad", "... and seen from within this heading difference (rad) ...", &p.loop_closure.max_view_angle_rad},
      {"loop_closure", "view_angle_per_m", "... plus this per metre of pose-graph distance (rad/m; up to pi)", &p.loop_closure.view_angle_per_m},
      {"loop_closure", "final_searches", "at the end of the log, this many last keyframes (2 apart) searched once more with candidates from every heading (0: off)", &p.loop_closure.final_searches},
      {"loop_closure", "final_sweep_every", "... and before them every this many keyframes, earliest first, from every heading (0: off)", &p.loop_closure.final_sweep_every},
      {"loop_closure", "max_candidates", "old places tried per search: the best-ranked, then the others in turn", &p.loop_closure.max_candidates},
      {"loop_closure", "ambiguity_m", "a search closes no loop when a match against another place puts the keyframe farther than this from the best match (m; 0: off) ...", &p.loop_closure.ambiguity_m},
      {"loop_closure", "ambiguity_fit_margin", "... and fits within this of the best (inlier ratio)", &p.loop_closure.ambiguity_fit_margin},
      {"loop_closure", "corridor_heading_rad", "look-alikes along one corridor: matches within the fit margin at one heading (within this, rad) ...", &p.loop_closure.corridor_heading_rad},
      {"loop_closure", "corridor_offset_m", "... and on one line (within this, m) keep the best for the heading and the offset across the line", &p.loop_closure.corridor_offset_m},
      {"loop_closure", "corridor_sigma_m", "... its position along the line the graph's, with this standard deviation (m; 0: off, ambiguous)", &p.loop_closure.corridor_sigma_m},
      {"loop_closure", "submap_travel_m", "an old place: the candidate and the keyframes within this much driving of it (m) ...", &p.loop_closure.submap_travel_m},
      {"loop_closure", "submap_step_m", "... one every this much driving (m)", &p.loop_closure.submap_step_m},
      {"loop_closure", "window_half_m", "window search over the old place: half window at most (m)", &p.loop_closure.window_half_m},
      {"loop_closure", "window_resolution_m", "... cell size of its likelihood field (m)", &p.loop_closure.window_resolution_m},
      {"loop_closure", "window_max_evaluations", "... search nodes scored at most", &p.loop_closure.window_max_evaluations},
      {"loop_closure", "min_inlier_ratio", "accept when this fraction of the new scan fits the old place (run --map: the loaded map) ...", &p.loop_closure.min_inlier_ratio},
      {"loop_closure", "min_reverse_inlier_ratio", "... and this fraction of the old place that the new scan could see fits it", &p.loop_closure.min_reverse_inlier_ratio},
      {"loop_closure", "max_match_sigma_m", "matches less certain than this in some direction (m) close no loop", &p.loop_closure.max_match_sigma_m},
      {"loop_closure", "covariance_scale", "edge covariance = refinement covariance times this", &p.loop_closure.covariance_scale},
      {"loop_closure", "sigma_floor_m", "edge standard deviation at least (m)", &p.loop_closure.sigma_floor_m},
      {"loop_closure", "sigma_floor_rad", "edge standard deviation at least (rad)", &p.loop_closure.sigma_floor_rad},
      {"loop_closure", "min_correction_m", "optimise when a loop edge disagrees with the graph by more than this (m) ...", &p.loop_closure.min_correction_m},
      {"loop_closure", "min_correction_rad", "... or this (rad)", &p.loop_closure.min_correction_rad},
      {"loop_closure", "max_correction_rad", "a closure may turn the estimate by at most this (rad) ...", &p.loop_closure.max_correction_rad},
      {"loop_closure", "max_correction_rad_per_m", "... plus this per metre of pose-graph distance (rad/m)", &p.loop_closure.max_correction_rad_per_m},
      {"loop_closure", "max_correction_m", "... and move it by at most this (m) ...", &p.loop_closure.max_correction_m},
      {"loop_closure", "max_correction_per_m", "... or this per metre of pose-graph distance, if more (within the search radius)", &p.loop_closure.max_correction_per_m},
      {"loop_closure", "quick_min_fit", "take a closure at the graph's estimate without shape matching when this fraction of the scan fits the old place (above 1: always search)", &p.loop_closure.quick_min_fit},
      {"loop_closure", "window_min_fit", "skip shape matching of a place where the window search's best pose scores below this mean likelihood", &p.loop_closure.window_min_fit},
      {"loop_closure", "refine_min_fit", "candidates of the full search fitting the old place less than this are not refined (the verification needs min_inlier_ratio)", &p.loop_closure.refine_min_fit},
      {"loop_closure", "strong_inlier_ratio", "a closure explaining this fraction both ways and correcting within max_correction_m/rad is used at once", &p.loop_closure.strong_inlier_ratio},
      {"loop_closure", "confirm_within_keyframes", "any other correcting closure waits for a consistent one within this many keyframes ...", &p.loop_closure.confirm_within_keyframes},
      {"loop_closure", "confirm_near_m", "... or, both asking more than max_correction_m, one whose new keyframe lies within this of its own (m; 0: off) ...", &p.loop_closure.confirm_near_m},
      {"loop_closure", "confirm_near_keyframes", "... within this many keyframes", &p.loop_closure.confirm_near_keyframes},
      {"loop_closure", "confirm_tolerance_m", "... consistent: the cycle of the two through the graph closes within this (m) ...", &p.loop_closure.confirm_tolerance_m},
      {"loop_closure", "confirm_tolerance_per_m", "... plus this per metre of its graph chains ...", &p.loop_closure.confirm_tolerance_per_m},
      {"loop_closure", "confirm_tolerance_rad", "... and within this (rad) ...", &p.loop_closure.confirm_tolerance_rad},
      {"loop_closure", "confirm_tolerance_rad_per_m", "... plus this per metre of its graph chains (rad/m)", &p.loop_closure.confirm_tolerance_rad_per_m},
      {"loop_closure", "verify_tolerance_m", "a correcting closure is tried first: earlier loop edges must still agree within this (m) ...", &p.loop_closure.verify_tolerance_m},
      {"loop_closure", "verify_tolerance_rad", "... and this (rad) ...", &p.loop_closure.verify_tolerance_rad},
      {"loop_closure", "max_broken_fraction", "... all but at most this fraction of those that agreed before", &p.loop_closure.max_broken_fraction},
      {"loop_closure", "candidate_turn_weight_m_per_rad", "candidates ordered by (distance plus this many metres per radian of heading difference) / search radius", &p.loop_closure.candidate_turn_weight_m_per_rad},
      {"loop_closure", "candidate_spacing_m", "candidates tried are at least this much driving apart (m)", &p.loop_closure.candidate_spacing_m},
      {"loop_closure", "unconfirmed_sigma_m", "edge of an unconfirmed keyframe: position standard deviation (m)", &p.loop_closure.unconfirmed_sigma_m},
      {"loop_closure", "unconfirmed_sigma_rad", "... heading standard deviation (rad)", &p.loop_closure.unconfirmed_sigma_rad},
      {"loop_closure", "guess_sigma_m", "with [submaps] restart_when_lost, the edge of a keyframe only the motion model placed: position standard deviation (m) ...", &p.loop_closure.guess_sigma_m},
      {"loop_closure", "guess_sigma_rad", "... heading standard deviation (rad) ...", &p.loop_closure.guess_sigma_rad},
      {"loop_closure", "guess_graph_m", "... and the driving the loop search counts it as (m)", &p.loop_closure.guess_graph_m},
      {"loop_closure", "ridge_max_shift_m", "without odometry, a keyframe's edge is widened along a ridge of fits (a featureless corridor): shifts up to this (m; 0: off) along its weakest direction are tried ...", &p.loop_closure.ridge_max_shift_m},
      {"loop_closure", "ridge_fit_margin", "... and fit as well when the fit drops by at most this", &p.loop_closure.ridge_fit_margin},
      {"loop_closure", "loss_scale", "Cauchy loss scale of loop edges, in standard deviations", &p.loop_closure.graph.loop_loss_scale},
      {"loop_closure", "initial_loss_scale", "... after a first solve with this wider scale (0: none)", &p.loop_closure.graph.initial_loop_loss_scale},
      {"loop_closure", "max_iterations", "pose-graph solver iterations at most", &p.loop_closure.graph.max_iterations},
      {"odometry_noise", "sigma_xy_m", "odometry prior: position standard deviation floor (m)", &p.odometry_noise.sigma_xy_m},
      {"odometry_noise", "sigma_xy_per_m", "... plus this per metre travelled", &p.odometry_noise.sigma_xy_per_m},
      {"odometry_noise", "sigma_theta_rad", "odometry prior: heading standard deviation floor (rad)", &p.odometry_noise.sigma_theta_rad},
      {"odometry_noise", "sigma_theta_per_rad", "... plus this per radian turned", &p.odometry_noise.sigma_theta_per_rad},
      {"odometry_noise", "sigma_theta_per_m", "... plus this per metre travelled", &p.odometry_noise.sigma_theta_per_m},
      {"odometry_noise", "learn", "scale the sigmas to the log: from the corrections trusted scan matches make to the odometry", &p.odometry_noise.learn},
      {"odometry_noise", "learn_window", "... over the last this many matches", &p.odometry_noise.learn_window},
      {"odometry_noise", "learn_min_samples", "... once this many are in", &p.odometry_noise.learn_min_samples},
      {"odometry_noise", "learn_min_scale", "... scaling the sigmas by at least this", &p.odometry_noise.learn_min_scale},
      {"odometry_noise", "learn_max_scale", "... and at most this", &p.odometry_noise.learn_max_scale},
      {"odometry_noise", "learn_max_scan_sigma_m", "... learning only from matches where the scan alone fixes the position to this (m) ...", &p.odometry_noise.learn_max_scan_sigma_m},
      {"odometry_noise", "learn_max_scan_sigma_rad", "... and the heading to this (rad)", &p.odometry_noise.learn_max_scan_sigma_rad},
      {"odometry_noise", "loss_sigmas", "heavy-tailed odometry prior: a Cauchy loss of this many standard deviations (0: Gaussian)", &p.odometry_noise.loss_sigmas},
      {"odometry_calibration", "enabled", "learn the odometry's heading error from the trusted matches and correct the increments by it (run and localize)", &p.odometry_calibration.enabled},
      {"odometry_calibration", "window", "... over the last this many matches", &p.odometry_calibration.window},
      {"odometry_calibration", "min_samples", "... once this many are in", &p.odometry_calibration.min_samples},
      {"odometry_calibration", "min_t", "... each term (per metre, per radian turned) only beyond this many standard errors from zero, shrunk near it", &p.odometry_calibration.min_t},
      {"odometry_calibration", "max_per_m", "... the heading error per metre travelled at most (rad/m)", &p.odometry_calibration.max_per_m},
      {"odometry_calibration", "max_per_rad", "... the heading error per radian turned at most", &p.odometry_calibration.max_per_rad},
      {"odometry_edges", "enabled", "pose graph: an odometry edge beside the scan edge between consecutive keyframes with fresh odometry, its noise learned from the log", &p.odometry_edges.enabled},
      {"odometry_edges", "variance_scale", "... the learned variances times this", &p.odometry_edges.variance_scale},
      {"odometry_edges", "position_variance_factor", "... the position variance this many times the learned one (the heading is what the wheels add)", &p.odometry_edges.position_variance_factor},
      {"odometry_edges", "loss_sigmas", "... Cauchy loss of this many standard deviations (0: none)", &p.odometry_edges.loss_sigmas},
      {"odometry_edges", "window", "... learned over the last this many matched keyframe steps", &p.odometry_edges.window},
      {"odometry_edges", "min_samples", "... no edge before this many are in", &p.odometry_edges.min_samples},
      {"odometry_edges", "straight_below_rad", "... a step turning less than this is straight (variance per metre), else turning (per radian)", &p.odometry_edges.straight_below_rad},
      {"odometry_edges", "min_group", "... with fewer straight or turning steps than this, every step per metre", &p.odometry_edges.min_group},
      {"odometry_edges", "distance_floor_m", "... added to each step's length (m)", &p.odometry_edges.distance_floor_m},
      {"scan_match", "seed_pairs", "scan-to-scan matching without a guess (shape-slam match): most reliable pairs tried", &p.scan_match_seed_pairs},
      {"scan_match", "seeds", "... of which this many go through the second pass", &p.scan_match_seeds},
  };
}

// The localizer's own settings (`shape-slam localize`, the first scan of `run --map`); its
// per-scan stages are the mapper's keys above.
std::vector<Field> LocalizerFields(LocalizerParams& p) {
  return {
      {"localizer", "min_inlier_ratio", "a scan is matched when its refined pose explains this fraction of it", &p.min_inlier_ratio},
      {"localizer", "relative_inlier_ratio", "... or, while tracking, this times the running mean of the fit, when lower (0: off)", &p.relative_inlier_ratio},
      {"localizer", "min_global_fit", "a pose of the global search is accepted once its fit reaches this", &p.min_global_fit},
      {"localizer", "global_tile_half_m", "global search: its coarsest nodes tile the map, about 2 * this wide (m)", &p.global_tile_half_m},
      {"localizer", "global_resolution_m", "... cell size of its likelihood field (m)", &p.global_resolution_m},
      {"localizer", "global_hit_sigma_m", "... width of its likelihood around the polylines (m)", &p.global_hit_sigma_m},
      {"localizer", "global_max_step_range_m", "... its angular step moves samples at this range by one cell (m)", &p.global_max_step_range_m},
      {"localizer", "global_node_evaluations", "... bound on its work: search nodes scored (each one look-up per scan sample)", &p.global_node_evaluations},
      {"localizer", "global_hypotheses", "... poses verified at most (best fit first, distinct)", &p.global_hypotheses},
      {"localizer", "max_hypotheses", "hypotheses kept between scans while ambiguous", &p.max_hypotheses},
      {"localizer", "distinct_m", "hypotheses closer than this (m) ...", &p.distinct_m},
      {"localizer", "distinct_rad", "... and this (rad) are one", &p.distinct_rad},
      {"localizer", "evidence_decay", "evidence per scan: this * evidence + the scan samples a hypothesis explains", &p.evidence_decay},
      {"localizer", "ambiguous_margin_samples", "ambiguous while another hypothesis's evidence is within this many samples of the best's", &p.ambiguous_margin_samples},
      {"localizer", "lost_after_scans", "lost after this many consecutive scans without a trusted match", &p.lost_after_scans},
      {"localizer", "fit_drop_ratio", "lost when the fit stays below this times its running mean ...", &p.fit_drop_ratio},
      {"localizer", "fit_drop_scans", "... for this many consecutive scans ...", &p.fit_drop_scans},
      {"localizer", "fit_mean_weight", "... the running mean weighting each scan by this", &p.fit_mean_weight},
      {"localizer", "retry_depth_tolerance_m", "while tracking with odometry, a scan without a match is matched again with the visibility's occlusion tolerance widened to this (m; 0: off)", &p.retry_depth_tolerance_m},
      {"localizer", "see_through_margin_m", "while tracking with odometry, map parts nearer than the scan's beam of the same bearing by more than this are left out: the beam went past them (m; 0: off)", &p.see_through_margin_m},
      {"localizer", "off_map_fit", "while tracking, a pose scoring below this in the global search's likelihood field (the map alone) is off the map: the global search runs ... (0: off)", &p.off_map_fit},
      {"localizer", "off_map_search_every", "... every this many such scans, and its best pose replaces the tracked one ...", &p.off_map_search_every},
      {"localizer", "off_map_margin", "... when it is matched at min_global_fit, scores this much more in the global search's field and no rival comes near ...", &p.off_map_margin},
      {"localizer", "off_map_confirm_scans", "... and has stayed so for this many more scans, tracked beside the pose", &p.off_map_confirm_scans},
      {"localizer", "recheck_every", "while tracking, every this many matched scans the map alone checks the tracked pose: the best pose of the global search's likelihood field nearby ... (0: off)", &p.recheck_every},
      {"localizer", "recheck_half_window_m", "... within this (m) ...", &p.recheck_half_window_m},
      {"localizer", "recheck_half_window_rad", "... and this (rad) of the tracked pose ...", &p.recheck_half_window_rad},
      {"localizer", "recheck_margin", "... replaces it when it scores this much more in that field, before and after the registration verified it", &p.recheck_margin},
      {"localizer", "recheck_poor_fit", "without odometry, the check also runs at every scan whose tracked pose scores below this in that field (0: never) ...", &p.recheck_poor_fit},
      {"localizer", "recheck_poor_half_window_m", "... within this (m) ...", &p.recheck_poor_half_window_m},
      {"localizer", "recheck_poor_half_window_rad", "... and this (rad) of the tracked pose", &p.recheck_poor_half_window_rad},
      {"localizer", "field_track_min_fit", "without odometry, while tracking, the map's likelihood field predicts the scan: its best pose near the constant velocity's, refined as an odometry prediction, is taken when this fraction of the scan fits (0: off) ...", &p.field_track_min_fit},
      {"localizer", "field_track_half_window_m", "... the field searched within this (m) ...", &p.field_track_half_window_m},
      {"localizer", "field_track_half_window_rad", "... and this (rad) of the constant velocity's pose ...", &p.field_track_half_window_rad},
      {"localizer", "field_track_tie", "... which stays the prediction when the field scores it within this of the best (along a corridor) ...", &p.field_track_tie},
      {"localizer", "field_track_prior_sigma_m", "... and the refinement's prior has this standard deviation (m) ...", &p.field_track_prior_sigma_m},
      {"localizer", "field_track_check_ratio", "... but when its fit falls below this times the running mean of the fit, the scan is matched without a prediction as well and the better fit wins (0: never)", &p.field_track_check_ratio},
      {"localizer", "field_track_turn_below", "... and when the field's best there scores below this (0: off), the field is searched again with the heading turned as much as the two scans' orientation histograms say the robot turned since the last scan; its best wins when it scores this itself and field_track_tie more than the first window's", &p.field_track_turn_below},
      {"localizer", "fast_track_min_fit", "with odometry, take the refined prediction without shape matching when this fraction of the scan fits the map, in place of [pipeline] fast_track_min_fit (lower: faster, a few scans a log taken a few degrees off; above 1: off)", &p.fast_track_min_fit},
      {"localizer", "search_retry", "while searching (the global search's poses verified, the hypotheses of a lost or ambiguous robot tracked after a miss), a pose the registration does not match at once is tried again as a tracked scan is (false: not; the search comes back at the next scan)", &p.search_retry},
      {"localizer", "first_pose_confirm_scans", "run --map without --initial: the first localized pose counts once this many more scans matched after it, the tracking never lost (0: at once)", &p.first_pose_confirm_scans},
  };
}

// Every key of the ini file: the mapper's stages, then the localizer's own.
std::vector<Field> AllFields(LocalizerParams& p) {
  std::vector<Field> fields = Fields(p.stages);
  for (Field& f : LocalizerFields(p)) fields.push_back(f);
  return fields;
}

std::string Trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const std::size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

// Drops an inline comment: '#' or ';' at the start or after whitespace.
std::string StripComment(const std::string& line) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    if ((line[i] == '#' || line[i] == ';') && (i == 0 || line[i - 1] == ' ' || line[i - 1] == '\t')) {
      return line.substr(0, i);
    }
  }
  return line;
}

void Assign(const Field& field, const std::string& value, const std::string& where) {
  const std::string name = std::string(field.section) + "." + field.key;
  auto bad = [&](const char* expected) {
    return ConfigError(where + ": " + name + " = '" + value + "': expected " + expected);
  };
  errno = 0;
  char* end = nullptr;
  if (double* const* d = std::get_if<double*>(&field.target)) {
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v)) throw bad("a finite number");
    **d = v;
  } else if (int* const* i = std::get_if<int*>(&field.target)) {
    const long v = std::strtol(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || errno == ERANGE || v < -1000000000 || v > 1000000000) {
      throw bad("an integer");
    }
    **i = static_cast<int>(v);
  } else {
    bool* b = std::get<bool*>(field.target);
    if (value == "true" || value == "1" || value == "yes" || value == "on") {
      *b = true;
    } else if (value == "false" || value == "0" || value == "no" || value == "off") {
      *b = false;
    } else {
      throw bad("true or false");
    }
  }
}

std::string ValueText(const Field& field) {
  if (double* const* d = std::get_if<double*>(&field.target)) return FormatDouble(**d);
  if (int* const* i = std::get_if<int*>(&field.target)) return std::to_string(**i);
  return *std::get<bool*>(field.target) ? "true" : "false";
}

}  // namespace

LocalizerParams ParseLocalizerParamsIni(const std::string& text, const std::string& name,
                                        const LocalizerParams& defaults) {
  LocalizerParams params = defaults;
  const std::vector<Field> fields = AllFields(params);
  std::set<std::string> sections, seen;
  for (const Field& f : fields) sections.insert(f.section);
  std::istringstream in(text);
  std::string line, section;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = name + ":" + std::to_string(number);
    const std::string content = Trim(StripComment(line));
    if (content.empty()) continue;
    if (content.front() == '[') {
      if (content.back() != ']') throw ConfigError(where + ": malformed section header '" + content + "'");
      section = Trim(content.substr(1, content.size() - 2));
      if (!sections.count(section)) throw ConfigError(where + ": unknown section [" + section + "]");
      continue;
    }
    const std::size_t eq = content.find('=');
    if (eq == std::string::npos) throw ConfigError(where + ": expected 'key = value', found '" + content + "'");
    const std::string key = Trim(content.substr(0, eq)), value = Trim(content.substr(eq + 1));
    if (section.empty()) {
      throw ConfigError(where + ": key '" + key + "' outside of any [section]");
    }
    const std::string full = section + "." + key;
    const Field* field = nullptr;
    for (const Field& f : fields) {
      if (section == f.section && key == f.key) field = &f;
    }
    if (field == nullptr) {
      // Keys of the global-map design, deleted on 2026-12-05 (issue 22).
      static const std::set<std::string> kRemoved = {
          "submaps.enabled", "loop_closure.rebuild_min_shift_m",
          "loop_closure.rebuild_min_shift_rad", "loop_closure.deform_max_shift_m",
          "loop_closure.deform_max_shift_rad", "loop_closure.rebuild_checkpoint_every"};
      const bool removed = kRemoved.count(full) > 0;
      throw ConfigError(where + ": unknown key '" + key + "' in [" + section + "]" +
                        (removed ? " (removed with the global-map design: the mapper always "
                                   "tracks against submaps; delete the line)"
                                 : ""));
    }
    if (!seen.insert(full).second) throw ConfigError(where + ": " + full + " given twice");
    Assign(*field, value, where);
  }
  try {
    params.Validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(name + ": invalid parameters: " + e.what());
  }
  return params;
}

LocalizerParams LoadLocalizerParamsIni(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw ConfigError(path + ": is a directory");
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the configuration file");
  std::ostringstream text;
  text << in.rdbuf();
  return ParseLocalizerParamsIni(text.str(), path);
}

ShapeSlamParams ParseParamsIni(const std::string& text, const std::string& name,
                               const ShapeSlamParams& defaults) {
  LocalizerParams with_defaults;
  with_defaults.stages = defaults;
  return ParseLocalizerParamsIni(text, name, with_defaults).stages;
}

ShapeSlamParams LoadParamsIni(const std::string& path) {
  return LoadLocalizerParamsIni(path).stages;
}

std::string FormatParamsIni(const ShapeSlamParams& params) {
  LocalizerParams with_defaults;
  with_defaults.stages = params;
  return FormatParamsIni(with_defaults);
}

std::string FormatParamsIni(const LocalizerParams& params) {
  LocalizerParams copy = params;
  std::ostringstream out;
  out << "# ShapeSLAM parameters (shape-slam run|localize --config FILE.ini). Every key is\n"
         "# optional: a missing key keeps the default shown here. Units are in the key names (_m\n"
         "# metres, _rad radians). Unknown keys are errors. Paper sections refer to Wolter &\n"
         "# Latecki, \"Shape-Based Robot Mapping\". [localizer] is read by localize and by the\n"
         "# first scans of run --map; every other section by all of them.\n";
  std::string section;
  for (const Field& f : AllFields(copy)) {
    if (section != f.section) {
      section = f.section;
      out << "\n[" << section << "]\n";
    }
    out << "# " << f.doc << "\n" << f.key << " = " << ValueText(f) << "\n";
  }
  return out.str();
}

}  // namespace shape_slam::io
