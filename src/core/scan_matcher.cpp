#include "shape_slam/scan_matcher.h"

#include <algorithm>
#include <utility>
#include <vector>

#include "shape_slam/internal/localization.h"
#include "shape_slam/internal/model_icp.h"
#include "shape_slam/shape_matcher.h"

namespace shape_slam {
namespace {

// Point-to-point ICP steps that finish each candidate before they are compared.
constexpr int kCandidateIcpIterations = 8;

// Inlier ratios closer than this count as equally good fits.
constexpr double kEquallyGoodFit = 0.05;

}  // namespace

ScanMatchResult MatchScans(const LaserScan& scan_i, const LaserScan& scan_j,
                           const std::optional<Pose2>& guess_T_i_j,
                           const ShapeSlamParams& params) {
  params.Validate();
  // Robot frames (the result) <-> sensor frames (where the shapes live).
  const auto to_sensor = [&](const Pose2& T_i_j) {
    return scan_i.T_robot_sensor.Inverse() * T_i_j * scan_j.T_robot_sensor;
  };
  const auto to_robot = [&](const Pose2& T_si_sj) {
    return scan_i.T_robot_sensor * T_si_sj * scan_j.T_robot_sensor.Inverse();
  };
  ScanMatchResult result;
  result.T_i_j = guess_T_i_j.value_or(Pose2());
  const internal::Shapes shapes_i = internal::ExtractShapes(scan_i, params);
  const internal::Shapes shapes_j = internal::ExtractShapes(scan_j, params);
  const std::vector<Point2> samples =
      internal::AlignmentSamples(shapes_j.fine, params.matcher.alignment.sample_spacing_m);
  if (shapes_i.coarse.empty() || samples.empty()) return result;

  // Shape matching: with the guess (§4.2, D measured against it) and without any (§4.3,
  // seeded by the most reliable pairs, with "the robot did not move" as one more estimate). A
  // guess far off gates the right pairs out of the first; the second does not need it.
  std::optional<Pose2> guess;
  if (guess_T_i_j) guess = to_sensor(*guess_T_i_j);
  std::vector<Pose2> candidates;
  for (const bool use_guess : {true, false}) {
    if (use_guess && !guess) continue;
    ShapeMatchInput input;
    input.scan = shapes_j.coarse;
    input.scan_fine = shapes_j.fine;
    input.model = shapes_i.coarse;
    input.model_cyclic = !use_guess;
    if (!use_guess) input.hint_estimates.push_back(guess ? *guess : to_sensor(Pose2()));
    ShapeMatcherParams matcher = params.matcher;
    if (!use_guess) {
      matcher.max_seed_pairs = params.scan_match_seed_pairs;
      matcher.num_seeds = params.scan_match_seeds;
    }
    const ShapeMatchResult match =
        MatchShapes(input, use_guess ? guess : std::nullopt, matcher);
    if (match.matches.empty()) continue;
    candidates.push_back(match.T_model_scan);
    if (static_cast<int>(match.matches.size()) > result.matched_pairs) {
      result.matched_pairs = static_cast<int>(match.matches.size());
    }
    if (!use_guess) result.reliability = match.reliability;
  }
  if (guess) candidates.push_back(*guess);
  if (candidates.empty()) return result;

  // Each candidate finished by quick ICP and ranked by how much of scan J it explains; the
  // best one that the Ceres refinement accepts wins.
  const internal::ModelIcp icp(shapes_i.fine, params.coarse_gate_m,
                               params.matcher.inlier_distance_m);
  // Among fits explaining the scan about equally well, the one nearest the guess (or the
  // smaller motion) wins: repetitive places offer look-alike fits farther away.
  const Pose2 reference = guess.value_or(to_sensor(Pose2()));
  const auto distance = [&](const Pose2& T) {
    const Pose2 d = reference.Inverse() * T;
    return d.Translation().norm() + std::abs(d.theta);  // m + rad
  };
  std::vector<std::pair<double, Pose2>> ranked;
  for (const Pose2& candidate : candidates) {
    const Pose2 aligned = icp.Align(samples, candidate, kCandidateIcpIterations);
    ranked.emplace_back(icp.InlierRatio(samples, aligned), aligned);
  }
  std::stable_sort(ranked.begin(), ranked.end(), [&](const auto& a, const auto& b) {
    if (std::abs(a.first - b.first) > kEquallyGoodFit) return a.first > b.first;
    return distance(a.second) < distance(b.second);
  });
  for (const auto& [ratio, aligned] : ranked) {
    const RefinementResult refined =
        internal::RefineAgainstMap(samples, shapes_i.fine, aligned, std::nullopt, params);
    if (!refined.converged) continue;
    result.T_i_j = to_robot(refined.T_map_scan);
    // Covariance of the robot pose: the sensor offsets are constant, so it transforms with the
    // rotation of scan I's sensor on the robot.
    Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
    J.topLeftCorner<2, 2>() = scan_i.T_robot_sensor.Rotation();
    result.covariance = J * refined.covariance * J.transpose();
    result.iterations = refined.iterations;
    result.rms_error_m = refined.rms_error_m;
    result.inlier_ratio = icp.InlierRatio(samples, refined.T_map_scan);
    result.converged = result.inlier_ratio >= params.min_inlier_ratio;
    break;
  }
  return result;
}

}  // namespace shape_slam
