// Matching a perceived shape (the scan's ordered polylines) against a model shape (the map's
// visible polylines, or another scan) -- paper §4.2 and §4.3 -- followed by the restricted
// alignment of §5.1.
//
// With a pose estimate (odometry, a guess) the correspondence of eq. (4) is solved once with the
// deviation term D measured against that estimate. Without one (§4.3) a first pass ignores D,
// the most reliable matched pairs by Q (eq. 5) each induce an alignment, a second pass uses D
// against it, and the seed whose final alignment fits the model best wins (the paper takes the
// single most reliable pair; trying the few best makes a wrong first choice recoverable at a
// small cost, see ShapeMatcherParams::num_seeds).
#pragma once

#include <limits>
#include <optional>
#include <vector>

#include "shape_slam/alignment.h"
#include "shape_slam/polyline_correspondence.h"
#include "shape_slam/shape_similarity.h"
#include "shape_slam/types.h"

namespace shape_slam {

struct ShapeMatcherParams {
  /// S* (§4.1): the lookahead of the continued evolution.
  EvolvedSimilarityParams similarity;
  /// P of eq. (4): penalty for leaving a polyline unmatched, per metre of its length (units of
  /// S per metre). Linear in size as §4.2 prescribes; a matched pair must cost less than the
  /// two penalties for the match to be taken.
  double skip_penalty_per_m = 0.5;
  /// D of eq. (4) = deviation_weight * ((misfit / deviation_sigma_m)^2 +
  /// (angle / deviation_sigma_rad)^2), where misfit and angle are the RMS distance (m) and
  /// direction difference (rad) of the perceived samples that overlap the model polyline(s)
  /// under the estimate. This measures how far the estimate is from the pair's induced
  /// alignment along the directions the pair constrains (a straight wall does not constrain
  /// sliding along itself, so comparing whole induced transforms would punish right matches).
  double deviation_weight = 1.0;
  double deviation_sigma_m = 0.5;     ///< metres
  double deviation_sigma_rad = 0.3;   ///< radians
  /// Gates (with an estimate): pairs whose misfit or angle exceed these are not considered.
  double max_misfit_m = 1.0;     ///< metres
  /// The misfit gate of §4.3's second pass, whose estimate comes from a seed already aligned
  /// to the model (metres).
  double seeded_max_misfit_m = 0.3;
  double max_angle_rad = 0.6;    ///< radians
  /// A pair must overlap over at least this fraction of the shorter of the two groups
  /// (projections that fall beyond a polyline's ends do not count as overlap).
  double min_overlap_fraction = 0.3;
  /// Largest group of neighbouring polylines in a 1-to-many / many-to-1 correspondence.
  int max_group_size = 3;
  /// §4.3 without an estimate: the alignments induced by the `max_seed_pairs` most reliable
  /// pairs are scored by their fit, and the best `num_seeds` go through the second pass.
  int max_seed_pairs = 12;
  int num_seeds = 3;
  /// Each seed's induced alignment is first improved by this many point-to-point ICP steps
  /// against the whole model, associating samples within seed_capture_distance_m (metres).
  int seed_icp_iterations = 6;
  double seed_capture_distance_m = 0.5;
  /// ICP steps of a seed's induced alignment on its own pair (InducedAlignment): it only needs
  /// to be roughly right, the steps above finish it.
  int seed_alignment_iterations = 10;
  /// Spacing of the samples that score seeds and final fits, metres.
  double fit_sample_spacing_m = 0.2;
  /// A seed whose induced alignment lies within these of a finished earlier seed is the same
  /// seed (metres, radians).
  double same_seed_m = 0.05;
  double same_seed_rad = 0.02;
  /// Without an estimate, candidates are ranked by inlier ratio - rotation_prior_weight *
  /// (theta / pi)^2: between equally good fits (symmetric places) the smaller turn wins.
  double rotation_prior_weight = 0.1;
  /// Polylines shorter than this do not seed (metres).
  double min_seed_length_m = 0.3;
  /// §4.3 first pass: largest group (1 = only 1-to-1, which is all the seed needs).
  int first_pass_group_size = 1;
  /// A sample is an inlier of the final fit when it lies within this distance of the model.
  double inlier_distance_m = 0.10;
  /// Spacing of the samples used to measure D, metres.
  double deviation_sample_spacing_m = 0.15;
  /// §5.1 restricted ICP after matching.
  AlignmentParams alignment;

  void Validate() const;
};

/// Input of MatchShapes. All polylines ordered counter-clockwise around their own viewpoint
/// and oriented with increasing bearing (as extraction and visibility produce them).
struct ShapeMatchInput {
  std::vector<Polyline> scan;  ///< perceived polylines after DCE, scan frame
  /// Optional finer versions of the same polylines (same count and order) used for the
  /// alignment samples; empty: `scan` is used.
  std::vector<Polyline> scan_fine;
  std::vector<Polyline> model;  ///< model polylines, model frame
  /// True when the model order has no known start (a 360 deg view, or no pose estimate).
  bool model_cyclic = false;
  /// Matching without a guess only: further estimates of T_model_scan (e.g. "the robot did not
  /// move") tried beside the alignments induced by the most reliable pairs; the best fit wins.
  std::vector<Pose2> hint_estimates;
};

struct ShapeMatchResult {
  std::vector<GroupMatch> matches;  ///< the correspondence of eq. (4), scan order
  double total_cost = std::numeric_limits<double>::infinity();  ///< its eq. (4) value
  Pose2 T_model_scan;               ///< after the restricted ICP of §5.1
  AlignmentResult alignment;        ///< that ICP's report
  bool used_guess = false;          ///< D was measured against the given guess
  /// Q (eq. 5) of the seed pair when no guess was given; NaN otherwise.
  double reliability = std::numeric_limits<double>::quiet_NaN();
  /// Fraction of the scan's samples within inlier_distance_m of any model polyline at the
  /// final pose: a quality measure for deciding whether to trust the match.
  double inlier_ratio = 0.0;
};

/// Matches the perceived shape against the model. `T_model_scan_guess`: the pose estimate, or
/// std::nullopt for matching without odometry (§4.3). Never throws for empty inputs (no
/// matches, T_model_scan = guess or identity); throws std::invalid_argument on invalid params
/// or inconsistent input sizes.
ShapeMatchResult MatchShapes(const ShapeMatchInput& input,
                             const std::optional<Pose2>& T_model_scan_guess,
                             const ShapeMatcherParams& params = {});

/// The alignment that a single pair of corresponding polylines induces (§4.3): T_model_scan
/// mapping `perceived` (scan frame) onto `model` (model frame), from a few closed-form
/// initialisations (equal normalised arc length; start, end and centre correspondences) each
/// refined by ICP on the pair; the one keeping most samples in its gate (then the smallest RMS
/// error) wins.
AlignmentResult InducedAlignment(const Polyline& perceived, const Polyline& model,
                                 const AlignmentParams& params = {});

}  // namespace shape_slam
