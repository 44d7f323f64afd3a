// Reusable gmock matchers for poses (Cartographer style):
//   EXPECT_THAT(result.T_map_scan, IsNearly(expected, 0.01, 0.002));
#pragma once

#include <gmock/gmock.h>

#include <cmath>
#include <ostream>
#include <string>

#include "shape_slam/types.h"

namespace shape_slam {

/// gtest prints poses as "(x, y, theta)".
inline void PrintTo(const Pose2& pose, std::ostream* os) {
  *os << "(" << pose.x << " m, " << pose.y << " m, " << pose.theta << " rad)";
}

/// Matches a Pose2 whose translation lies within eps_m (Euclidean distance, metres) of
/// `expected` and whose heading differs by at most eps_rad (wrapped, radians).
MATCHER_P3(IsNearly, expected, eps_m, eps_rad,
           std::string(negation ? "is not" : "is") + " within " + ::testing::PrintToString(eps_m) +
               " m and " + ::testing::PrintToString(eps_rad) + " rad of " +
               ::testing::PrintToString(expected)) {
  const double translation_error = std::hypot(arg.x - expected.x, arg.y - expected.y);
  const double rotation_error = std::abs(NormalizeAngle(arg.theta - expected.theta));
  *result_listener << "translation error " << translation_error << " m, rotation error "
                   << rotation_error << " rad";
  return translation_error <= eps_m && rotation_error <= eps_rad;
}

}  // namespace shape_slam
