// Basic types shared by every stage of the core: points, polylines, 2D poses and laser scans.
// Units are SI (metres, radians, seconds) unless a name says otherwise.
#pragma once

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <cmath>
#include <optional>
#include <vector>

namespace shape_slam {

/// A point in the plane, metres.
using Point2 = Eigen::Vector2d;

/// An open polygonal line ("polyline", paper §3): vertices in order, metres. Consecutive
/// vertices are joined by straight segments. A polyline of one vertex is a single point.
using Polyline = std::vector<Point2>;

/// Wraps an angle into (-pi, pi].
inline double NormalizeAngle(double angle_rad) {
  const double wrapped = std::remainder(angle_rad, 2.0 * M_PI);
  return wrapped <= -M_PI ? wrapped + 2.0 * M_PI : wrapped;
}

/// A rigid motion of the plane. Name instances by their frames: `T_map_scan` maps points given
/// in the scan frame into the map frame.
struct Pose2 {
  double x = 0.0;      ///< translation, metres
  double y = 0.0;      ///< translation, metres
  double theta = 0.0;  ///< rotation, radians, counter-clockwise

  Pose2() = default;
  Pose2(double x_m, double y_m, double theta_rad) : x(x_m), y(y_m), theta(theta_rad) {}

  Eigen::Vector2d Translation() const { return {x, y}; }
  Eigen::Matrix2d Rotation() const {
    const double c = std::cos(theta), s = std::sin(theta);
    return (Eigen::Matrix2d() << c, -s, s, c).finished();
  }
  /// Maps a point from this pose's child frame into its parent frame.
  Point2 operator*(const Point2& p) const { return Rotation() * p + Translation(); }
  /// Composition: `T_a_c = T_a_b * T_b_c`.
  Pose2 operator*(const Pose2& other) const {
    const Point2 t = (*this) * other.Translation();
    return {t.x(), t.y(), NormalizeAngle(theta + other.theta)};
  }
  Pose2 Inverse() const {
    const Point2 t = -(Rotation().transpose() * Translation());
    return {t.x(), t.y(), NormalizeAngle(-theta)};
  }
};

/// A motion between two poses of a rigid body, re-expressed for a frame mounted on it at
/// T_body_frame (the same physical motion seen from the frame, e.g. the robot's odometry step as
/// the sensor's): T_body_frame^-1 * T_body_motion * T_body_frame.
inline Pose2 MotionInFrame(const Pose2& T_body_motion, const Pose2& T_body_frame) {
  return T_body_frame.Inverse() * T_body_motion * T_body_frame;
}

/// A covariance of (x, y, theta) given in frame b, in frame a (T_a_b: only its rotation acts,
/// on the (x, y) block): R * covariance * R^T with R = diag(T_a_b's rotation, 1).
inline Eigen::Matrix3d CovarianceInFrame(const Eigen::Matrix3d& covariance, const Pose2& T_a_b) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  R.topLeftCorner<2, 2>() = T_a_b.Rotation();
  return R * covariance * R.transpose();
}

/// Whether two poses lie closer than max_m in translation and max_rad in heading.
inline bool PosesWithin(const Pose2& a, const Pose2& b, double max_m, double max_rad) {
  return (a.Translation() - b.Translation()).norm() < max_m &&
         std::abs(NormalizeAngle(a.theta - b.theta)) < max_rad;
}

/// A pose prepared for mapping many points: its rotation is computed once, not per point.
class PointTransform {
 public:
  explicit PointTransform(const Pose2& T_b_a) : R_(T_b_a.Rotation()), t_(T_b_a.Translation()) {}
  Point2 operator()(const Point2& p_a) const { return R_ * p_a + t_; }
  const Eigen::Matrix2d& Rotation() const { return R_; }

 private:
  Eigen::Matrix2d R_;
  Point2 t_;
};

/// Applies a pose to every vertex of a polyline.
inline Polyline Transform(const Pose2& T_b_a, const Polyline& polyline_a) {
  const PointTransform T(T_b_a);
  Polyline out;
  out.reserve(polyline_a.size());
  for (const Point2& p : polyline_a) out.push_back(T(p));
  return out;
}

/// One planar laser scan, as every log reader delivers it (the common stream of the I/O layer).
struct LaserScan {
  double timestamp_s = 0.0;         ///< as given by the log, seconds
  std::vector<double> ranges_m;     ///< one per beam; NaN or <= 0 means "no reading"
  std::vector<double> angles_rad;   ///< beam directions in the sensor frame, counter-clockwise
  double max_range_m = 0.0;         ///< readings >= this are "no return"
  Pose2 T_robot_sensor;             ///< sensor mounting on the robot
  std::optional<Pose2> T_odom_robot;  ///< odometry pose of the robot, when the log gives one
};

}  // namespace shape_slam
