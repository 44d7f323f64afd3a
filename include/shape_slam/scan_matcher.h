// Scan-to-scan registration by shape (paper §4.2, §4.3, §5.1): the pose of one laser scan in the
// frame of another, from the two scans alone, with or without a pose guess.
//
// Both scans go through the pipeline's own extraction and simplification (§3.1). The scan J is
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

#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"

namespace shape_slam {

struct ScanMatchResult {
  /// Pose of scan J's robot frame in scan I's robot frame (x, y metres; theta radians): the
  /// sensor poses on the robot are taken into account, as in the logs' odometry.
  Pose2 T_i_j;
  /// Covariance of (x, y, theta) of T_i_j (m^2, m rad, rad^2) from the refinement.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
  /// The refinement converged and explains at least ShapeSlamParams::min_inlier_ratio of scan
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
                           const ShapeSlamParams& params = {});

}  // namespace shape_slam
