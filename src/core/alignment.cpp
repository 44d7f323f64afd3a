#include "shape_slam/alignment.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "shape_slam/geometry.h"
#include "shape_slam/internal/median.h"
#include "shape_slam/internal/model_segments.h"

namespace shape_slam {
namespace {

// For zero-mean Gaussian residuals, sigma = 1.4826 * median(|r|) (the MAD estimator).
constexpr double kMadToSigma = 1.4826;
// The shrinking gate is this many robust standard deviations of the used distances.
constexpr double kGateSigmas = 3.0;
// A converged fit tightens the gate only when it shrinks below this fraction of the old one.
constexpr double kGateShrink = 0.9;
// Upper bound on the samples of one polyline (guards against a tiny spacing on a huge polyline).
constexpr double kMaxSamplesPerPolyline = 1e7;

void RequirePositive(double value, const char* field) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw std::invalid_argument(std::string("AlignmentParams::") + field +
                                " must be finite and > 0");
  }
}

// Index of the last segment of non-zero length (polyline.size() - 1 when there is none).
std::size_t LastProperSegment(const Polyline& polyline) {
  for (std::size_t i = polyline.size() - 1; i > 0; --i) {
    if (polyline[i] != polyline[i - 1]) return i - 1;
  }
  return polyline.size() - 1;
}

// One used sample: its position under the current pose and its nearest model point, map frame.
struct Correspondence {
  Point2 q = Point2::Zero();
  Point2 m = Point2::Zero();
  double weight = 1.0;
};

// The state of the restricted ICP: the samples with their pairs' segments and buffers that are
// reused by every iteration (no allocation inside the loop).
class RestrictedIcp {
 public:
  RestrictedIcp(internal::RestrictedProblem problem, bool reject_end_projections)
      : problem_(std::move(problem)), reject_end_projections_(reject_end_projections) {
    matches_.reserve(problem_.samples.size());
    distances_.reserve(problem_.samples.size());
  }

  // §5.1: every sample is matched with the nearest point of its own pair's model polylines;
  // samples beyond the gate (or projecting beyond a polyline end) are dropped. Returns the
  // number of samples used.
  int Associate(const Pose2& T_map_scan, double gate_m) {
    matches_.clear();
    distances_.clear();
    const Eigen::Matrix2d R = T_map_scan.Rotation();
    const Point2 t = T_map_scan.Translation();
    const double gate2 = gate_m * gate_m;
    for (const internal::RestrictedSample& s : problem_.samples) {
      const Point2 q = R * s.point + t;
      const internal::SegmentMatch m =
          internal::NearestSegment(q, problem_.segments, s.segments_begin, s.segments_end, gate2);
      if (m.segment < 0 || (reject_end_projections_ && m.beyond_end)) continue;
      matches_.push_back({q, m.point, s.weight});
      distances_.push_back(std::sqrt(m.squared_distance));
    }
    return static_cast<int>(matches_.size());
  }

  // The closed-form weighted rigid alignment of the matched samples with their nearest points
  // (2D Procrustes / Umeyama without scale, [7]), applied on top of T_map_scan, with the
  // weighted mean squared distance of the matches after it (m^2). Centred sums keep it exact
  // with large map coordinates; without a rotational signal (a single sample) the rotation is
  // kept and only the translation changes.
  std::pair<Pose2, double> Update(const Pose2& T_map_scan) const {
    double sum_w = 0.0;
    Point2 q_mean = Point2::Zero(), m_mean = Point2::Zero();
    const Point2 ref_q = matches_.front().q, ref_m = matches_.front().m;
    for (const Correspondence& c : matches_) {
      sum_w += c.weight;
      q_mean += c.weight * (c.q - ref_q);
      m_mean += c.weight * (c.m - ref_m);
    }
    q_mean = ref_q + q_mean / sum_w;
    m_mean = ref_m + m_mean / sum_w;
    double dot = 0.0, cross = 0.0, norms = 0.0;
    for (const Correspondence& c : matches_) {
      const Point2 q = c.q - q_mean, m = c.m - m_mean;
      dot += c.weight * q.dot(m);
      cross += c.weight * (q.x() * m.y() - q.y() * m.x());
      norms += c.weight * (q.squaredNorm() + m.squaredNorm());
    }
    const double dtheta = std::atan2(cross, dot);
    // sum w |R q - m|^2 = sum w (|q|^2 + |m|^2) - 2 (cos * dot + sin * cross), minimal at dtheta.
    const double mse = std::max(0.0, norms - 2.0 * std::hypot(dot, cross)) / sum_w;
    const Point2 t = Pose2(0.0, 0.0, dtheta) * (T_map_scan.Translation() - q_mean) + m_mean;
    return {{t.x(), t.y(), NormalizeAngle(T_map_scan.theta + dtheta)}, mse};
  }

  // Root mean square distance of the samples from the scan origin, metres (at least 1 mm): the
  // length that makes rotations comparable with translations.
  double SampleRadius() const {
    double sum = 0.0;
    for (const internal::RestrictedSample& s : problem_.samples) sum += s.point.squaredNorm();
    const double n = static_cast<double>(std::max<std::size_t>(problem_.samples.size(), 1));
    return std::max(1e-3, std::sqrt(sum / n));
  }

  // 1.4826 * median of the used distances (reorders the distance buffer).
  double RobustSigma() {
    if (distances_.empty()) return 0.0;
    return kMadToSigma * internal::MedianInPlace(distances_);
  }

  double Rms() const {
    if (distances_.empty()) return 0.0;
    double sum = 0.0;
    for (const double d : distances_) sum += d * d;
    return std::sqrt(sum / static_cast<double>(distances_.size()));
  }

 private:
  internal::RestrictedProblem problem_;
  bool reject_end_projections_ = true;
  std::vector<Correspondence> matches_;
  std::vector<double> distances_;
};

// Besl & McKay's accelerated ICP (PAMI 14(2), 1992, §IV-C). Point-to-point ICP creeps along
// weakly constrained directions (a corridor's axis held only by door jambs): successive updates
// then point the same way. When the last three updates, as vectors (x, y, L * theta) with L the
// samples' radius, turn by less than 10 degrees, the registration error along that line is fit
// by a line and a parabola through the last three (arc position, error) points and the pose
// jumps to the nearer of the line's zero and the parabola's minimum, at most 25 update lengths
// ahead. The history restarts after a jump and whenever the gate changes.
class Accelerator {
 public:
  explicit Accelerator(double length_m) : length_m_(length_m) {}

  void Reset() { count_ = 0; }

  // Records the pose after an update with its registration error (m^2) and returns the pose to
  // continue from (extrapolated, or the same).
  Pose2 Next(const Pose2& pose, double mse) {
    if (count_ == 4) {
      std::rotate(poses_, poses_ + 1, poses_ + 4);
      std::rotate(mse_, mse_ + 1, mse_ + 4);
      --count_;
    }
    poses_[count_] = pose;
    mse_[count_] = mse;
    if (++count_ < 4) return pose;
    const Eigen::Vector3d d1 = Delta(2, 3), d2 = Delta(1, 2), d3 = Delta(0, 1);
    const double n1 = d1.norm(), n2 = d2.norm(), n3 = d3.norm();
    if (n1 == 0.0 || n2 == 0.0 || n3 == 0.0 || d1.dot(d2) < kCosMaxTurn * n1 * n2 ||
        d2.dot(d3) < kCosMaxTurn * n2 * n3) {
      return pose;
    }
    const double step = Extrapolation(-(n1 + n2), -n1, n1);
    if (!(step > 0.0)) return pose;
    Reset();
    const Eigen::Vector3d v = (step / n1) * d1;
    return {pose.x + v.x(), pose.y + v.y(), NormalizeAngle(pose.theta + v.z() / length_m_)};
  }

 private:
  static constexpr double kCosMaxTurn = 0.98480775301220802;  // cos(10 deg)
  static constexpr double kMaxStepsAhead = 25.0;

  Eigen::Vector3d Delta(int from, int to) const {
    return {poses_[to].x - poses_[from].x, poses_[to].y - poses_[from].y,
            length_m_ * NormalizeAngle(poses_[to].theta - poses_[from].theta)};
  }

  // Distance to jump from the newest pose (arc position 0; the two before at u2 < u1 < 0).
  double Extrapolation(double u2, double u1, double last_step) const {
    const double e2 = mse_[1], e1 = mse_[2], e0 = mse_[3];
    const double v_max = kMaxStepsAhead * last_step;
    double v = v_max;
    const double slope = (e0 - e2) / -u2;  // line through (u2, e2) and (0, e0)
    if (slope < 0.0) v = std::min(v, -e0 / slope);
    // Parabola e(u) = a u^2 + b u + e0 through the three points.
    const double s1 = (e1 - e0) / u1, s2 = (e2 - e0) / u2;  // = a u + b at u1, u2
    const double a = (s2 - s1) / (u2 - u1), b = s1 - a * u1;
    if (a > 0.0 && -b / (2.0 * a) > 0.0) v = std::min(v, -b / (2.0 * a));
    return slope < 0.0 ? v : 0.0;
  }

  double length_m_;
  Pose2 poses_[4];
  double mse_[4] = {0.0, 0.0, 0.0, 0.0};
  int count_ = 0;
};

bool SmallUpdate(const Pose2& before, const Pose2& after, const AlignmentParams& params) {
  return PosesWithin(after, before, params.convergence_translation_m, params.convergence_rotation_rad);
}

}  // namespace

void AlignmentParams::Validate() const {
  RequirePositive(sample_spacing_m, "sample_spacing_m");
  if (max_iterations < 1)
    throw std::invalid_argument("AlignmentParams::max_iterations must be >= 1");
  RequirePositive(convergence_translation_m, "convergence_translation_m");
  RequirePositive(convergence_rotation_rad, "convergence_rotation_rad");
  RequirePositive(max_correspondence_distance_m, "max_correspondence_distance_m");
  RequirePositive(min_correspondence_distance_m, "min_correspondence_distance_m");
  if (min_correspondence_distance_m > max_correspondence_distance_m) {
    throw std::invalid_argument(
        "AlignmentParams::min_correspondence_distance_m must not exceed "
        "max_correspondence_distance_m");
  }
}

std::vector<Point2> SamplePolyline(const Polyline& polyline, double spacing_m) {
  if (!std::isfinite(spacing_m) || spacing_m <= 0.0) {
    throw std::invalid_argument("SamplePolyline: spacing_m must be finite and > 0");
  }
  internal::CheckFinite(polyline, "SamplePolyline: polyline");
  if (polyline.empty()) return {};
  const double length = PolylineLength(polyline);
  if (length / spacing_m > kMaxSamplesPerPolyline) {
    throw std::invalid_argument("SamplePolyline: spacing_m too small for the polyline's length");
  }
  std::vector<Point2> samples;
  samples.reserve(static_cast<std::size_t>(length / spacing_m) + polyline.size() + 1);
  const std::size_t last = LastProperSegment(polyline);
  double s0 = 0.0, last_arc = 0.0;  // arc length at the segment start, of the last sample
  long k = 0;                       // index of the next regular sample, at arc k * spacing_m
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const Point2& a = polyline[i];
    const Point2 ab = polyline[i + 1] - a;
    const double len = ab.norm();
    if (len == 0.0) continue;
    const double s1 = s0 + len;
    bool sampled = false;
    for (; static_cast<double>(k) * spacing_m < s1; ++k, sampled = true) {
      last_arc = static_cast<double>(k) * spacing_m;
      samples.push_back(a + ((last_arc - s0) / len) * ab);
    }
    if (!sampled && i != last) {  // §5.1: at least one sample per segment
      last_arc = s0 + 0.5 * len;
      samples.push_back(a + 0.5 * ab);
    }
    s0 = s1;
  }
  // The end vertex replaces a sample that falls on it up to rounding.
  if (!samples.empty() && s0 - last_arc < 1e-9 * spacing_m) samples.pop_back();
  samples.push_back(polyline.back());
  return samples;
}

AlignmentResult AlignShapes(const std::vector<ShapePair>& pairs, const Pose2& T_map_scan_init,
                            const AlignmentParams& params) {
  params.Validate();
  internal::CheckFinite(T_map_scan_init, "AlignShapes: T_map_scan_init");
  RestrictedIcp icp(internal::MakeRestrictedProblem(pairs, params.sample_spacing_m),
                    params.reject_end_projections);
  AlignmentResult result;
  result.T_map_scan = T_map_scan_init;
  double gate_m = params.max_correspondence_distance_m;
  Accelerator accelerator(icp.SampleRadius());
  for (int iteration = 0; iteration < params.max_iterations; ++iteration) {
    if (icp.Associate(result.T_map_scan, gate_m) == 0) break;
    const auto [next, mse] = icp.Update(result.T_map_scan);
    const bool small = SmallUpdate(result.T_map_scan, next, params);
    ++result.iterations;
    if (!small) {
      result.T_map_scan = accelerator.Next(next, mse);
      continue;
    }
    result.T_map_scan = next;
    // Converged at this gate: tighten it to the fit (trimming) and go on, unless it would not
    // shrink significantly any more.
    const double tighter =
        std::clamp(kGateSigmas * icp.RobustSigma(), params.min_correspondence_distance_m, gate_m);
    if (tighter > kGateShrink * gate_m) {
      result.converged = true;
      break;
    }
    gate_m = tighter;
    accelerator.Reset();
  }
  result.num_correspondences = icp.Associate(result.T_map_scan, gate_m);
  result.rms_error_m = icp.Rms();
  result.converged = result.converged && result.num_correspondences > 0;
  return result;
}

}  // namespace shape_slam
