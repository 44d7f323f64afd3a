#include "shape_slam/map_update.h"

#include <gtest/gtest.h>

#include <cmath>

#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

WeightedPolyline W(const Polyline& p, double w = 1.0) { return {p, std::vector<double>(p.size(), w)}; }

// Largest distance from any vertex of `a` to the polyline `b`.
double MaxDistance(const Polyline& a, const Polyline& b) {
  double worst = 0.0;
  for (const Point2& p : a) worst = std::max(worst, std::sqrt(ProjectOntoPolyline(p, b).squared_distance));
  return worst;
}

TEST(MergePolylinesTest, ExtendsAStraightWallWithATail) {
  const MapUpdateParams params;
  const WeightedPolyline merged =
      MergePolylines(W({{0, 0}, {4, 0}}), W({{2, 0.02}, {6, 0.02}}), {3, -2}, params);
  ASSERT_EQ(merged.points.size(), 2u);
  EXPECT_NEAR(merged.points.front().x(), 0.0, 1e-9);
  EXPECT_NEAR(merged.points.back().x(), 6.0, 1e-9);
  EXPECT_LT(MaxDistance(merged.points, {{0, 0}, {6, 0.02}}), 0.02);
}

TEST(MergePolylinesTest, ReversedPerceptionKeepsTheModelOrientation) {
  const MapUpdateParams params;
  const WeightedPolyline merged =
      MergePolylines(W({{0, 0}, {4, 0}}), W({{6, 0.02}, {2, 0.02}}), {3, -2}, params);
  ASSERT_GE(merged.points.size(), 2u);
  EXPECT_LT(merged.points.front().x(), merged.points.back().x());
  EXPECT_NEAR(merged.points.back().x(), 6.0, 1e-9);
}

TEST(MergePolylinesTest, WellSupportedWallMovesLittle) {
  MapUpdateParams params;
  const WeightedPolyline merged =
      MergePolylines(W({{0, 0}, {4, 0}}, 19.0), W({{0, 0.1}, {4, 0.1}}), {2, -2}, params);
  for (const Point2& p : merged.points) EXPECT_NEAR(p.y(), 0.005, 1e-6);
  for (const double w : merged.weights) EXPECT_DOUBLE_EQ(w, 20.0);
}

TEST(MergePolylinesTest, CornerSeenPartially) {
  const MapUpdateParams params;
  const Polyline model = {{0, 0}, {3, 0}, {3, 3}};
  const Polyline perceived = {{1.5, 0.01}, {3.01, 0.01}, {3.01, 1.0}};
  const WeightedPolyline merged = MergePolylines(W(model), W(perceived), {1, 1}, params);
  EXPECT_EQ(merged.points.size(), 3u);
  EXPECT_LT(MaxDistance(merged.points, model), 0.02);
  EXPECT_LT(MaxDistance(model, merged.points), 0.02);
}

TEST(MergePolylinesTest, NeverLeavesTheInputs) {
  // Random overlapping pairs: every merged vertex lies near one of the two inputs.
  const MapUpdateParams params;
  for (int k = 0; k < 50; ++k) {
    const double a = 0.1 * k, off = 0.05 * std::sin(k);
    const Polyline model = {{0, 0}, {2, 0.1 * std::cos(k)}, {4, 0}};
    const Polyline perceived = {{a * 0.5, off}, {2 + off, 0.1 * std::cos(k) + off}, {4 + a, off}};
    const WeightedPolyline merged = MergePolylines(W(model), W(perceived), {2, -3}, params);
    for (const Point2& p : merged.points) {
      const double d = std::min(std::sqrt(ProjectOntoPolyline(p, model).squared_distance),
                                std::sqrt(ProjectOntoPolyline(p, perceived).squared_distance));
      EXPECT_LT(d, 0.1) << "k=" << k;
    }
  }
}

}  // namespace
}  // namespace shape_slam
