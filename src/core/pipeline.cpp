#include "shape_slam/pipeline.h"

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/alignment.h"
#include "shape_slam/internal/model_segments.h"

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

// DCE continued until at most `max_vertices` remain: bounds the cost of S (O(m n (m + n)) in
// the arcs) on cluttered scans; S* evolves further where that helps (§4.1).
Polyline LimitVertices(const Polyline& polyline, int max_vertices) {
  if (static_cast<int>(polyline.size()) <= max_vertices) return polyline;
  CurveEvolution evolution(polyline);
  while (evolution.CanRemove() && evolution.NumVertices() > max_vertices) evolution.RemoveNext();
  return evolution.Current();
}

// The polyline as shape matching sees it: DCE at the matching threshold, vertex count bounded.
Polyline ForShapeMatching(const Polyline& polyline, const ShapeSlamParams& params) {
  return LimitVertices(SimplifyDce(polyline, params.dce.threshold_m), params.max_shape_vertices);
}

Shapes ExtractShapes(const LaserScan& scan, const ShapeSlamParams& params) {
  Shapes shapes;
  for (const Polyline& raw : ExtractPolylines(scan, params.extraction)) {
    shapes.coarse.push_back(ForShapeMatching(raw, params));
    shapes.fine.push_back(SimplifyDceBounded(raw, params.alignment_dce_threshold_m,
                                             params.alignment_max_deviation_m));
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
  double coverage = 0.0;  // fraction of the scan within new_territory_distance_m of the map
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
  Positive(alignment_max_deviation_m, "ShapeSlamParams::alignment_max_deviation_m");
  if (max_shape_vertices < 2) {
    throw std::invalid_argument("ShapeSlamParams::max_shape_vertices must be >= 2");
  }
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
  Positive(new_territory_distance_m, "ShapeSlamParams::new_territory_distance_m");
  if (!(max_untrusted_coverage >= 0.0 && max_untrusted_coverage <= 1.0)) {
    throw std::invalid_argument("ShapeSlamParams::max_untrusted_coverage must be in [0, 1]");
  }
  Positive(max_prior_mahalanobis, "ShapeSlamParams::max_prior_mahalanobis");
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

// Fraction of the samples within the grid's radius of the model at an estimate.
double InlierRatio(const std::vector<Point2>& samples, const internal::SegmentGrid& grid,
                   const Pose2& T_model_scan) {
  int inliers = 0;
  for (const Point2& p : samples) inliers += grid.Nearest(T_model_scan * p).segment >= 0 ? 1 : 0;
  return samples.empty() ? 0.0 : static_cast<double>(inliers) / samples.size();
}

// Whether an estimate lies within max_sigma standard deviations (Mahalanobis) of the prior.
bool WithinPrior(const Pose2& estimate, const PosePrior& prior, double max_sigma) {
  const Pose2 d = prior.T_map_scan.Inverse() * estimate;
  const Eigen::Vector3d e(d.x, d.y, d.theta);
  return e.dot(prior.covariance.ldlt().solve(e)) <= max_sigma * max_sigma;
}

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

// What a scan is localized against, in the sensor frame of the prediction: the visible map shape
// and the polylines of the most recent keyframe scan.
struct LocalModel {
  std::vector<Polyline> map;         // visible map shape, CCW ordered
  std::vector<Polyline> map_coarse;  // the same, as shape matching sees it
  bool map_cyclic = false;
  std::vector<Polyline> recent_coarse;  // last keyframe's polylines (shape matching)
  std::vector<Polyline> recent_fine;    // the same, finer (refinement)
};

// Shape matching (§4.2, §4.3) of the scan against one model; its alignment is a candidate.
std::optional<Pose2> ShapeCandidate(const Shapes& shapes, const std::vector<Polyline>& model,
                                    bool model_cyclic, const std::optional<Pose2>& guess,
                                    const std::optional<Pose2>& velocity_hint,
                                    const ShapeSlamParams& params, int& matched_pairs) {
  if (model.empty()) return std::nullopt;
  ShapeMatchInput input;
  input.scan = shapes.coarse;
  input.scan_fine = shapes.fine;
  input.model = model;
  input.model_cyclic = model_cyclic || !guess;
  if (!guess) {
    input.hint_estimates.push_back(Pose2());  // the robot did not move
    if (velocity_hint) input.hint_estimates.push_back(*velocity_hint);
  }
  const ShapeMatchResult match = MatchShapes(input, guess, params.matcher);
  matched_pairs = std::max(matched_pairs, static_cast<int>(match.matches.size()));
  if (match.matches.empty()) return std::nullopt;
  return match.T_model_scan;
}

// Candidates from shape matching against the map and against the last keyframe, and the
// prediction itself, are each refined against both; the one explaining most of the scan wins.
Localization Localize(const Shapes& shapes, const LocalModel& model,
                      const std::optional<Pose2>& odometry_delta,
                      const std::optional<Pose2>& velocity_hint, const ShapeSlamParams& params) {
  Localization loc;
  std::optional<Pose2> guess;
  std::optional<PosePrior> prior;
  if (odometry_delta) {
    guess = Pose2();  // the model is already seen from the odometry prediction
    prior = PosePrior{Pose2(), OdometryCovariance(*odometry_delta, params.odometry_noise)};
  }
  std::vector<Pose2> candidates;
  for (const auto& [shape_model, cyclic] :
       {std::pair{&model.map_coarse, model.map_cyclic}, std::pair{&model.recent_coarse, false}}) {
    if (auto c = ShapeCandidate(shapes, *shape_model, cyclic, guess, velocity_hint, params,
                                loc.matched_pairs)) {
      candidates.push_back(*c);
    }
  }
  if (guess) candidates.push_back(*guess);
  std::vector<Polyline> all = model.map;
  all.insert(all.end(), model.recent_fine.begin(), model.recent_fine.end());
  const std::vector<Point2> samples =
      AlignmentSamples(shapes.fine, params.matcher.alignment.sample_spacing_m);
  if (samples.empty() || all.empty()) return loc;
  const internal::SegmentGrid grid(internal::MakeModelSegments(all), params.matcher.inlier_distance_m);
  double best_ratio = -1.0;
  for (const Pose2& candidate : candidates) {
    const RefinementResult refined = RefineAgainstMap(samples, all, candidate, prior, params);
    if (!refined.converged) continue;
    if (prior && !WithinPrior(refined.T_map_scan, *prior, params.max_prior_mahalanobis)) continue;
    const double ratio = InlierRatio(samples, grid, refined.T_map_scan);
    if (ratio <= best_ratio) continue;
    best_ratio = ratio;
    loc.correction = refined.T_map_scan;
    loc.covariance = refined.covariance;
    loc.rms_error_m = refined.rms_error_m;
    loc.inlier_ratio = ratio;
    loc.trusted = ratio >= params.min_inlier_ratio;
  }
  if (!loc.trusted) loc.correction = Pose2();
  const internal::SegmentGrid near_grid(internal::MakeModelSegments(all),
                                        params.new_territory_distance_m);
  loc.coverage = InlierRatio(samples, near_grid, loc.correction);
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
    LocalModel model;
    for (const VisiblePolyline& v : visible) model.map.push_back(v.points_sensor);
    for (const Polyline& p : model.map) model.map_coarse.push_back(ForShapeMatching(p, params_));
    model.map_cyclic = visibility.fov_rad >= 2.0 * M_PI - 1e-9;
    if (last_keyframe_) {
      const Pose2 T_pred_keyframe = T_map_sensor_pred.Inverse() * last_keyframe_->T_map_sensor;
      for (const Polyline& p : last_keyframe_->coarse) model.recent_coarse.push_back(Transform(T_pred_keyframe, p));
      for (const Polyline& p : last_keyframe_->fine) model.recent_fine.push_back(Transform(T_pred_keyframe, p));
    }
    std::optional<Pose2> velocity_hint;
    if (prediction.T_pred_robot_velocity) {
      velocity_hint = scan.T_robot_sensor.Inverse() * *prediction.T_pred_robot_velocity *
                      scan.T_robot_sensor;
    }
    loc = Localize(shapes, model, prediction.odometry_delta, velocity_hint, params_);
  }
  const Pose2 T_map_sensor = T_map_sensor_pred * loc.correction;
  report.T_map_robot = T_map_sensor * scan.T_robot_sensor.Inverse();
  report.matched = loc.trusted;
  report.covariance = loc.covariance;
  report.matched_pairs = loc.matched_pairs;
  report.inlier_ratio = loc.inlier_ratio;
  report.rms_error_m = loc.rms_error_m;

  // A scan whose pose no match confirmed updates the map only where the map knows nothing yet
  // (new territory); elsewhere it would blur or duplicate what is there.
  const bool may_update = loc.trusted || map_.Empty() ||
                          loc.coverage < params_.max_untrusted_coverage;
  if (!shapes.fine.empty() && may_update && IsKeyframe(report.T_map_robot)) {
    std::vector<Polyline> perceived_map;
    for (const Polyline& p : shapes.fine) perceived_map.push_back(Transform(T_map_sensor, p));
    const Pose2 correction_inverse = loc.correction.Inverse();
    for (VisiblePolyline& v : visible) v.points_sensor = Transform(correction_inverse, v.points_sensor);
    report.map_update =
        UpdateMap(map_, perceived_map, T_map_sensor, visible, scan, loc.trusted || map_.Empty(),
                  params_.map_update);
    report.keyframe = true;
    last_keyframe_T_map_robot_ = report.T_map_robot;
    if (params_.use_last_keyframe) last_keyframe_ = KeyframeShapes{T_map_sensor, shapes.coarse, shapes.fine};
  }
  previous_T_map_robot_ = last_T_map_robot_;
  last_T_map_robot_ = report.T_map_robot;
  if (scan.T_odom_robot) last_T_odom_robot_ = scan.T_odom_robot;
  return report;
}

}  // namespace shape_slam
