// A small synthetic scene for the occupancy grid tests: a 4 m x 4 m square room centred on the
// origin, its walls as one closed polyline, and a 360-beam scan taken from inside it.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"

namespace shape_slam::io::testing {

constexpr double kRoomHalfSide = 2.0;  // metres

inline std::vector<Polyline> RoomWalls() {
  const double h = kRoomHalfSide;
  return {{{-h, -h}, {h, -h}, {h, h}, {-h, h}, {-h, -h}}};
}

/// Range from `sensor_map` along the map-frame direction `angle_map` to the room's walls.
inline double RangeToWall(const Point2& sensor_map, double angle_map) {
  const Point2 d(std::cos(angle_map), std::sin(angle_map));
  double range = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 2; ++k) {
    if (std::abs(d[k]) < 1e-12) continue;
    range = std::min(range, ((d[k] > 0 ? kRoomHalfSide : -kRoomHalfSide) - sensor_map[k]) / d[k]);
  }
  return range;
}

/// A keyframe at `T_map_robot` (sensor on the robot's origin) seeing the room with 360 beams:
/// the scan, and the view of it that the grids take.
struct RoomKeyframe {
  explicit RoomKeyframe(const Pose2& T_map_robot) {
    scan.max_range_m = 30.0;
    for (int i = 0; i < 360; ++i) {
      const double angle = -M_PI + 2.0 * M_PI * i / 360.0;
      scan.angles_rad.push_back(angle);
      scan.ranges_m.push_back(RangeToWall(T_map_robot.Translation(), T_map_robot.theta + angle));
    }
    view = {&scan, T_map_robot};
  }
  RoomKeyframe(const RoomKeyframe&) = delete;  // the view points at this scan
  RoomKeyframe& operator=(const RoomKeyframe&) = delete;
  LaserScan scan;
  ShapeSlam::KeyframeView view;
};

}  // namespace shape_slam::io::testing
