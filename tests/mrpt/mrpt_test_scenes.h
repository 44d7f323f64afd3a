// Test scenes for the MRPT layer: a room with known walls, scans simulated in it as MRPT
// observations, and helpers to build maps from them.
#pragma once

#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "shape_slam/types.h"
#include "shape_slam_mrpt/plugin.h"

namespace shape_slam::testing {

/// A wall from a to b, metres, world frame.
using Wall = std::pair<Point2, Point2>;

/// A 10 m x 6 m room with a pillar, a partition and a niche: every pose is constrained in x, y
/// and heading.
inline std::vector<Wall> RoomWalls() {
  const auto P = [](double x, double y) { return Point2(x, y); };
  return {
      {P(-5, -3), P(5, -3)},        {P(5, -3), P(5, 0.5)},          {P(5, 0.5), P(6, 0.5)},
      {P(6, 0.5), P(6, 1.5)},       {P(6, 1.5), P(5, 1.5)},         {P(5, 1.5), P(5, 3)},
      {P(5, 3), P(-5, 3)},          {P(-5, 3), P(-5, -3)},          {P(1, 1), P(1.6, 1)},
      {P(1.6, 1), P(1.6, 1.6)},     {P(1.6, 1.6), P(1, 1.6)},       {P(1, 1.6), P(1, 1)},
      {P(-2.5, -3), P(-2.5, -1.2)}, {P(-2.5, -1.2), P(-1.8, -1.2)},
  };
}

/// Distance from p to the nearest wall, metres.
inline double DistanceToWalls(const Point2& p, const std::vector<Wall>& walls) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : walls) {
    const Point2 ab = b - a;
    const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (p - (a + t * ab)).norm());
  }
  return best;
}

/// Range along a ray to the nearest wall, or +inf.
inline double CastRay(const Point2& origin, const Point2& direction,
                      const std::vector<Wall>& walls) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& [a, b] : walls) {
    const Point2 e = b - a;
    const double denominator = direction.x() * e.y() - direction.y() * e.x();
    if (std::abs(denominator) < 1e-12) continue;
    const Point2 w = a - origin;
    const double t = (w.x() * e.y() - w.y() * e.x()) / denominator;
    const double u = (w.x() * direction.y() - w.y() * direction.x()) / denominator;
    if (t > 1e-9 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
  }
  return best;
}

/// The sensor's mounting on the robot in the simulated scans (not the identity on purpose).
inline mrpt::poses::CPose3D SensorOnRobot() {
  return mrpt::poses::CPose3D(0.2, 0.05, 0.0, 0.03, 0, 0);
}

/// A 180 deg, 361-beam scan (SICK-like, right to left) taken by a robot at T_world_robot in the
/// room; beams without a wall within 30 m are invalid.
inline mrpt::obs::CObservation2DRangeScan SimulateScan(
    const Pose2& T_world_robot, const std::vector<Wall>& walls = RoomWalls()) {
  mrpt::obs::CObservation2DRangeScan scan;
  scan.sensorLabel = "SIM_LASER";
  scan.aperture = static_cast<float>(M_PI);
  scan.rightToLeft = true;
  scan.maxRange = 30.0f;
  scan.sensorPose = SensorOnRobot();
  scan.timestamp = mrpt::Clock::now();
  const std::size_t n = 361;
  scan.resizeScan(n);
  const mrpt::poses::CPose3D& s = scan.sensorPose;
  const Pose2 T_world_sensor = T_world_robot * Pose2(s.x(), s.y(), s.yaw());
  for (std::size_t i = 0; i < n; ++i) {
    const double angle = -M_PI / 2 + M_PI * static_cast<double>(i) / static_cast<double>(n - 1);
    const double bearing = T_world_sensor.theta + angle;
    const double range =
        CastRay(T_world_sensor.Translation(), Point2(std::cos(bearing), std::sin(bearing)), walls);
    const bool valid = std::isfinite(range) && range < scan.maxRange;
    scan.setScanRange(i, valid ? static_cast<float>(range) : 0.0f);
    scan.setScanRangeValidity(i, valid);
  }
  return scan;
}

/// The scan's points in the robot frame, as icp-slam builds them.
inline mrpt::maps::CSimplePointsMap ScanPoints(const mrpt::obs::CObservation2DRangeScan& scan) {
  mrpt::maps::CSimplePointsMap points;
  points.insertionOptions.minDistBetweenLaserPoints = 0.0f;
  points.insertObservation(scan);
  return points;
}

/// Poses along which the robot maps the room.
inline std::vector<Pose2> MappingPoses() {
  return {{-3.5, 0.0, 0.0}, {-1.0, 0.5, 0.3}, {2.5, -1.0, 0.8},
          {3.0, 1.8, 2.0},  {0.0, 2.0, 3.0},  {-3.0, 1.0, -2.5}};
}

inline mrpt::poses::CPose3D ToCPose3D(const Pose2& pose) {
  return mrpt::poses::CPose3D(pose.x, pose.y, 0.0, pose.theta, 0.0, 0.0);
}

/// Registers the plugin's classes once (and keeps the library linked under --as-needed).
class PluginEnvironment : public ::testing::Environment {
 public:
  void SetUp() override { RegisterMrptClasses(); }
};

}  // namespace shape_slam::testing
