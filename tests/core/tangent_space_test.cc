#include "shape_slam/tangent_space.h"

#include <gtest/gtest.h>

namespace shape_slam {
namespace {

TEST(TangentSpaceTest, TurningFunctionOfAnLIsATwoStepFunction) {
  // Legs of 1 m and 3 m: the step at s = 0.25, a left turn of pi/2.
  const TurningFunction f = ComputeTurningFunction({{0, 0}, {1, 0}, {1, 3}});
  ASSERT_EQ(f.angles.size(), 2u);
  EXPECT_DOUBLE_EQ(f.length_m, 4.0);
  EXPECT_EQ(f.breaks, std::vector<double>({0.0, 0.25, 1.0}));
  EXPECT_DOUBLE_EQ(f.angles[0], 0.0);
  EXPECT_DOUBLE_EQ(f.angles[1], M_PI / 2);
  EXPECT_DOUBLE_EQ(f(0.1), 0.0);
  EXPECT_DOUBLE_EQ(f(0.5), M_PI / 2);
  EXPECT_DOUBLE_EQ(f(2.0), M_PI / 2);  // clamped
}

TEST(TangentSpaceTest, TurningFunctionUnwrapsAndSkipsZeroLengthSegments) {
  // Three left turns around a square: 0, pi/2, pi, 3pi/2 (not wrapped back to -pi/2).
  const TurningFunction f =
      ComputeTurningFunction({{0, 0}, {1, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}});
  ASSERT_EQ(f.angles.size(), 4u);
  EXPECT_NEAR(f.angles[3], 3 * M_PI / 2, 1e-12);
  EXPECT_EQ(f.breaks.size(), 5u);
  const TurningFunction point = ComputeTurningFunction({{2, 2}});
  EXPECT_EQ(point.angles, std::vector<double>({0.0}));
  EXPECT_EQ(point.length_m, 0.0);
}

TEST(TangentSpaceTest, MaximalArcsShareTheInflectionSegment) {
  // S shape: left turns at 1 and 2, right turns at 3 and 4.
  const Polyline s = {{0, 0}, {1, 0}, {1.5, 1}, {1.5, 2}, {2, 3}, {3, 3}};
  const std::vector<Arc> arcs = MaximalArcs(s);
  ASSERT_EQ(arcs.size(), 2u);
  EXPECT_EQ(arcs[0].first_vertex, 0);
  EXPECT_EQ(arcs[0].last_vertex, 3);
  EXPECT_EQ(arcs[1].first_vertex, 2);  // segment (2, 3) belongs to both
  EXPECT_EQ(arcs[1].last_vertex, 5);
}

TEST(TangentSpaceTest, MaximalArcsOfSimpleCases) {
  EXPECT_EQ(MaximalArcs({{0, 0}, {5, 0}}).size(), 1u);
  EXPECT_EQ(MaximalArcs({{0, 0}, {1, 0}, {2, 0}, {3, 0}}).size(), 1u);       // no turn
  EXPECT_EQ(MaximalArcs({{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 2}}).size(), 2u);
  EXPECT_EQ(MaximalArcs({{0, 0}, {1, 0}, {1, 1}, {0, 1}}).size(), 1u);         // convex
  EXPECT_TRUE(MaximalArcs({{0, 0}}).empty());
  const std::vector<Arc> with_collinear = MaximalArcs({{0, 0}, {1, 0}, {2, 0}, {2, 1}});
  ASSERT_EQ(with_collinear.size(), 1u);
  EXPECT_EQ(with_collinear[0].last_vertex, 3);
}

}  // namespace
}  // namespace shape_slam
