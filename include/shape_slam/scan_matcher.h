// Scan-to-scan registration by shape (paper §4.2, §4.3, §5.1): the pose of one laser scan in the
// frame of another, from the two scans alone, with or without a pose guess.
//
// Both scans go through the mapper's own extraction and simplification (§3.1, scan_shapes.h). The scan J is
// matched against the polylines of scan I by shape (eq. 4): with a guess, D is measured against
// it; without one, the most reliable pairs by Q (eq. 5) seed the alignment (§4.3). Each
// candidate (the shape match, and the guess itself when given) is finished by a few
// point-to-point ICP steps, the best fit gets the Ceres refinement of alignment_refinement.h
// (no prior: a guess only starts the search, it is not believed), which also gives the
// covariance.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <optional>

#include "shape_slam/alignment_refinement.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/scan_shapes.h"
#include "shape_slam/shape_matcher.h"
#include "shape_slam/types.h"
#include "shape_slam/window_search.h"

namespace shape_slam {

/// Settings of scan-to-scan registration. The mapper's own settings give one
/// (ToScanMatchParams in pipeline.h), so that `shape-slam match` and the mapper agree.
struct ScanMatchParams {
  ScanShapesParams shapes;            ///< §3.1, both scans
  ShapeMatcherParams matcher;         ///< §4.2-§4.3, §5.1
  RefinementParams refinement;        ///< Ceres refinement of the chosen candidate
  CandidateSelectionParams selection; ///< the choice among the candidates
  /// The window around the guess (or "did not move") searched for where scan J fits scan I;
  /// all turns by default: one match decides everything here.
  WindowSearchParams window_search = [] {
    WindowSearchParams w;
    w.half_window_rad = M_PI;
    return w;
  }();
  double window_search_spacing_m = 0.2;  ///< samples scored by the window search, metres
  /// The refinement first runs with this wider association gate (metres), then with its own.
  double coarse_gate_m = 0.6;
  /// The match counts as converged when at least this fraction of J lies on I afterwards.
  double min_inlier_ratio = 0.30;
  /// Without a guess, §4.3 seeds from this many most reliable pairs, of which `seeds` go
  /// through the second pass: more than per-scan tracking, since no map backs a match up.
  int seed_pairs = 25;
  int seeds = 6;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

struct ScanMatchResult {
  /// Pose of scan J's robot frame in scan I's robot frame (x, y metres; theta radians): the
  /// sensor poses on the robot are taken into account, as in the logs' odometry.
  Pose2 T_i_j;
  /// Covariance of (x, y, theta) of T_i_j (m^2, m rad, rad^2) from the refinement.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  /// The refinement converged and explains at least ScanMatchParams::min_inlier_ratio of scan
  /// J's samples.
  bool converged = false;
  int matched_pairs = 0;  ///< polyline groups in the eq. (4) correspondence
  /// Q (eq. 5) of the seed pair when matched without a guess; NaN otherwise.
  double reliability = std::numeric_limits<double>::quiet_NaN();
  int iterations = 0;          ///< refinement rounds (association + Ceres solve)
  double rms_error_m = 0.0;    ///< RMS point-to-segment distance at the end
  double inlier_ratio = 0.0;   ///< fraction of J's samples within inlier distance of I
};

/// Registers scan_j against scan_i. `guess_T_i_j`: a pose estimate in the same convention as
/// the result, or std::nullopt to match without any (§4.3). Scans without usable points give
/// converged = false and T_i_j = guess (or identity). Throws std::invalid_argument on invalid
/// parameters.
ScanMatchResult MatchScans(const LaserScan& scan_i, const LaserScan& scan_j,
                           const std::optional<Pose2>& guess_T_i_j,
                           const ScanMatchParams& params = {});

}  // namespace shape_slam
