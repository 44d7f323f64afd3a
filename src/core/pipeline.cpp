#include "shape_slam/pipeline.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/alignment.h"

namespace shape_slam {
namespace {

void Positive(double value, const std::string& name) {
  if (!(value > 0.0) || !std::isfinite(value)) throw std::invalid_argument(name + " must be > 0");
}

void NonNegative(double value, const std::string& name) {
  if (!(value >= 0.0) || !std::isfinite(value)) throw std::invalid_argument(name + " must be >= 0");
}

void ValidateScan(const LaserScan& scan) {
  if (scan.ranges_m.size() != scan.angles_rad.size()) {
    throw std::invalid_argument("scan at t=" + std::to_string(scan.timestamp_s) + " has " +
                                std::to_string(scan.ranges_m.size()) + " ranges but " +
                                std::to_string(scan.angles_rad.size()) + " angles");
  }
  if (!std::isfinite(scan.timestamp_s)) throw std::invalid_argument("scan timestamp is not finite");
  for (const double a : scan.angles_rad) {
    if (!std::isfinite(a)) throw std::invalid_argument("scan has a non-finite beam angle");
  }
}

// The scan with its beams in increasing angle, so that polylines run counter-clockwise like
// the visible map shape (§3: both are ordered counter-clockwise).
LaserScan CounterClockwise(const LaserScan& scan) {
  if (scan.angles_rad.size() < 2 || scan.angles_rad.front() <= scan.angles_rad.back()) return scan;
  LaserScan ccw = scan;
  std::reverse(ccw.ranges_m.begin(), ccw.ranges_m.end());
  std::reverse(ccw.angles_rad.begin(), ccw.angles_rad.end());
  return ccw;
}

// Angular coverage of a scan: span of its beams plus one beam step.
double FieldOfView(const LaserScan& scan) {
  const std::size_t n = scan.angles_rad.size();
  if (n < 2) return 0.0;
  const double span = scan.angles_rad.back() - scan.angles_rad.front();
  return span + span / (n - 1);
}

// The scan's polylines (sensor frame): simplified for shape matching, and finer for alignment.
struct Shapes {
  std::vector<Polyline> coarse;
  std::vector<Polyline> fine;
};

Shapes ExtractShapes(const LaserScan& scan, const ShapeSlamParams& params) {
  Shapes shapes;
  for (const Polyline& raw : ExtractPolylines(scan, params.extraction)) {
    shapes.coarse.push_back(SimplifyDce(raw, params.dce.threshold_m));
    shapes.fine.push_back(SimplifyDce(raw, params.alignment_dce_threshold_m));
  }
  return shapes;
}

// Covariance of the odometry increment T_prev_cur, as a prior on the correction.
Eigen::Matrix3d OdometryCovariance(const Pose2& delta, const OdometryNoiseParams& noise) {
  const double distance = delta.Translation().norm();
  const double turn = std::abs(delta.theta);
  const double sxy = noise.sigma_xy_m + noise.sigma_xy_per_m * distance;
  const double sth =
      noise.sigma_theta_rad + noise.sigma_theta_per_rad * turn + noise.sigma_theta_per_m * distance;
  return Eigen::Vector3d(sxy * sxy, sxy * sxy, sth * sth).asDiagonal();
}

std::vector<Point2> AlignmentSamples(const std::vector<Polyline>& fine, double spacing_m) {
  std::vector<Point2> samples;
  for (const Polyline& p : fine) {
    const std::vector<Point2> s = SamplePolyline(p, spacing_m);
    samples.insert(samples.end(), s.begin(), s.end());
  }
  return samples;
}

// The estimated correction T_pred_sensor (sensor frame at the prediction -> at the estimate).
struct Localization {
  Pose2 correction;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  bool trusted = false;
  int matched_pairs = 0;
  double inlier_ratio = 0.0;
  double rms_error_m = 0.0;
};

}  // namespace

void KeyframeParams::Validate() const {
  NonNegative(min_translation_m, "KeyframeParams::min_translation_m");
  NonNegative(min_rotation_rad, "KeyframeParams::min_rotation_rad");
}

void OdometryNoiseParams::Validate() const {
  Positive(sigma_xy_m, "OdometryNoiseParams::sigma_xy_m");
  Positive(sigma_theta_rad, "OdometryNoiseParams::sigma_theta_rad");
  NonNegative(sigma_xy_per_m, "OdometryNoiseParams::sigma_xy_per_m");
  NonNegative(sigma_theta_per_rad, "OdometryNoiseParams::sigma_theta_per_rad");
  NonNegative(sigma_theta_per_m, "OdometryNoiseParams::sigma_theta_per_m");
}

void ShapeSlamParams::Validate() const {
  extraction.Validate();
  dce.Validate();
  Positive(alignment_dce_threshold_m, "ShapeSlamParams::alignment_dce_threshold_m");
  visibility.Validate();
  NonNegative(visibility_fov_margin_rad, "ShapeSlamParams::visibility_fov_margin_rad");
  matcher.Validate();
  refinement.Validate();
  map_update.Validate();
  keyframe.Validate();
  odometry_noise.Validate();
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    throw std::invalid_argument("ShapeSlamParams::min_inlier_ratio must be in [0, 1]");
  }
  Positive(index_cell_size_m, "ShapeSlamParams::index_cell_size_m");
  Positive(coarse_gate_m, "ShapeSlamParams::coarse_gate_m");
}

ShapeSlam::ShapeSlam(const ShapeSlamParams& params)
    : params_(params), map_(params.index_cell_size_m) {
  params_.Validate();
}

ShapeSlam::Prediction ShapeSlam::Predict(const LaserScan& scan) const {
  Prediction prediction;
  if (!last_T_map_robot_) return prediction;  // the first scan defines the map frame
  prediction.T_map_robot = *last_T_map_robot_;
  if (params_.use_odometry && scan.T_odom_robot && last_T_odom_robot_) {
    const Pose2 delta = last_T_odom_robot_->Inverse() * *scan.T_odom_robot;
    prediction.odometry_delta = delta;
    prediction.T_map_robot = *last_T_map_robot_ * delta;
  } else if (previous_T_map_robot_) {
    const Pose2 velocity = previous_T_map_robot_->Inverse() * *last_T_map_robot_;
    prediction.T_pred_robot_velocity = velocity;
  }
  return prediction;
}

bool ShapeSlam::IsKeyframe(const Pose2& T_map_robot) const {
  if (!last_keyframe_T_map_robot_) return true;
  const Pose2 moved = last_keyframe_T_map_robot_->Inverse() * T_map_robot;
  return moved.Translation().norm() >= params_.keyframe.min_translation_m ||
         std::abs(moved.theta) >= params_.keyframe.min_rotation_rad;
}

namespace {

// Refines an estimate against every visible map polyline: with a wide gate first (odometry-size
// errors), then with the configured one.
RefinementResult RefineAgainstMap(const std::vector<Point2>& samples,
                                  const std::vector<Polyline>& model, const Pose2& init,
                                  const std::optional<PosePrior>& prior,
                                  const ShapeSlamParams& params) {
  RefinementParams coarse = params.refinement;
  coarse.max_correspondence_distance_m =
      std::max(params.coarse_gate_m, params.refinement.max_correspondence_distance_m);
  coarse.loss_scale_m = std::max(coarse.loss_scale_m, params.coarse_gate_m / 4.0);
  const RefinementResult first = RefineAlignment(samples, model, init, prior, coarse);
  return RefineAlignment(samples, model, first.T_map_scan, prior, params.refinement);
}

Localization Localize(const Shapes& shapes, const std::vector<VisiblePolyline>& visible,
                      const std::optional<Pose2>& odometry_delta,
                      const std::optional<Pose2>& velocity_hint_correction, bool model_cyclic,
                      const ShapeSlamParams& params) {
  ShapeMatchInput input;
  input.scan = shapes.coarse;
  input.scan_fine = shapes.fine;
  input.model_cyclic = model_cyclic;
  for (const VisiblePolyline& v : visible) input.model.push_back(v.points_sensor);
  std::optional<Pose2> guess;
  if (odometry_delta) {
    guess = Pose2();  // the model is already seen from the odometry prediction
  } else {
    input.hint_estimates.push_back(Pose2());  // the robot did not move
    if (velocity_hint_correction) input.hint_estimates.push_back(*velocity_hint_correction);
  }
  const ShapeMatchResult match = MatchShapes(input, guess, params.matcher);
  Localization loc;
  loc.matched_pairs = static_cast<int>(match.matches.size());
  std::optional<PosePrior> prior;
  if (odometry_delta) {
    prior = PosePrior{Pose2(), OdometryCovariance(*odometry_delta, params.odometry_noise)};
  }
  // Candidates: the shape matcher's alignment, and the prediction itself when the shape match
  // is weak; each is refined against the whole visible map and the best fit wins.
  std::vector<Pose2> candidates;
  if (!match.matches.empty()) candidates.push_back(match.T_model_scan);
  if (match.inlier_ratio < 0.9 && guess) candidates.push_back(*guess);
  const std::vector<Point2> samples =
      AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
  if (samples.empty()) return loc;
  double best_ratio = -1.0;
  for (const Pose2& candidate : candidates) {
    const RefinementResult refined = RefineAgainstMap(samples, input.model, candidate, prior, params);
    const double ratio = static_cast<double>(refined.num_residuals) / samples.size();
    if (ratio <= best_ratio) continue;
    best_ratio = ratio;
    loc.correction = refined.converged ? refined.T_map_scan : candidate;
    loc.covariance = refined.covariance;
    loc.rms_error_m = refined.rms_error_m;
    loc.inlier_ratio = ratio;
    loc.trusted = refined.converged && ratio >= params.min_inlier_ratio;
  }
  if (!loc.trusted) loc.correction = Pose2();
  return loc;
}

}  // namespace

ScanReport ShapeSlam::Process(const LaserScan& input_scan) {
  ValidateScan(input_scan);
  const LaserScan scan = CounterClockwise(input_scan);
  ScanReport report;
  report.timestamp_s = scan.timestamp_s;
  const Shapes shapes = ExtractShapes(scan, params_);
  report.polylines = static_cast<int>(shapes.coarse.size());
  const Prediction prediction = Predict(scan);
  report.used_odometry = prediction.odometry_delta.has_value();
  const Pose2 T_map_sensor_pred = prediction.T_map_robot * scan.T_robot_sensor;

  Localization loc;
  std::vector<VisiblePolyline> visible;
  if (!map_.Empty() && !shapes.coarse.empty()) {
    const bool no_estimate = !prediction.odometry_delta;
    VisibilityParams visibility = params_.visibility;
    visibility.fov_rad = no_estimate ? 2.0 * M_PI
                                     : std::min(2.0 * M_PI, FieldOfView(scan) +
                                                                2.0 * params_.visibility_fov_margin_rad);
    visible = map_.Visible(T_map_sensor_pred, visibility);
    std::optional<Pose2> velocity_hint;
    if (prediction.T_pred_robot_velocity) {
      velocity_hint = scan.T_robot_sensor.Inverse() * *prediction.T_pred_robot_velocity *
                      scan.T_robot_sensor;
    }
    const bool cyclic = visibility.fov_rad >= 2.0 * M_PI - 1e-9;
    loc = Localize(shapes, visible, prediction.odometry_delta, velocity_hint, cyclic, params_);
  }
  const Pose2 T_map_sensor = T_map_sensor_pred * loc.correction;
  report.T_map_robot = T_map_sensor * scan.T_robot_sensor.Inverse();
  report.matched = loc.trusted;
  report.covariance = loc.covariance;
  report.matched_pairs = loc.matched_pairs;
  report.inlier_ratio = loc.inlier_ratio;
  report.rms_error_m = loc.rms_error_m;

  if (!shapes.fine.empty() && IsKeyframe(report.T_map_robot)) {
    std::vector<Polyline> perceived_map;
    for (const Polyline& p : shapes.fine) perceived_map.push_back(Transform(T_map_sensor, p));
    const Pose2 correction_inverse = loc.correction.Inverse();
    for (VisiblePolyline& v : visible) v.points_sensor = Transform(correction_inverse, v.points_sensor);
    report.map_update =
        UpdateMap(map_, perceived_map, T_map_sensor, visible, scan, params_.map_update);
    report.keyframe = true;
    last_keyframe_T_map_robot_ = report.T_map_robot;
  }
  previous_T_map_robot_ = last_T_map_robot_;
  last_T_map_robot_ = report.T_map_robot;
  if (scan.T_odom_robot) last_T_odom_robot_ = scan.T_odom_robot;
  return report;
}

}  // namespace shape_slam
