#include "shape_slam/visibility.h"

#include "shape_slam/internal/localization.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace shape_slam {
namespace {

struct MapFixture {
  std::unordered_map<PolylineId, Polyline> polylines;
  SegmentIndex index{2.0};
  void Add(PolylineId id, const Polyline& p) {
    polylines[id] = p;
    index.Insert(id, p);
  }
  std::vector<VisiblePolyline> See(const Pose2& T, VisibilityParams params = {},
                                   const SeenRays* seen = nullptr) const {
    return ComputeVisibleShape(polylines, index, T, params, seen);
  }
};

double Bearing(const Point2& p) { return std::atan2(p.y(), p.x()); }

TEST(VisibilityTest, WallBehindAWallIsCutAtTheShadowRays) {
  MapFixture map;
  map.Add(0, {{2, -1}, {2, 1}});    // near wall, x = 2, y in [-1, 1]
  map.Add(1, {{4, -4}, {4, 4}});    // far wall, x = 4: hidden for |y| < 2
  const std::vector<VisiblePolyline> v = map.See(Pose2());
  ASSERT_EQ(v.size(), 3u);  // far wall below, near wall, far wall above (CCW)
  EXPECT_EQ(v[0].source, 1u);
  EXPECT_EQ(v[1].source, 0u);
  EXPECT_EQ(v[2].source, 1u);
  // The shadow edges are at y = +-2 on the far wall, up to one sweep bin (0.25 deg at ~4.5 m).
  const double bin = 4.5 * 0.25 * M_PI / 180;
  EXPECT_NEAR(v[0].points_sensor.back().y(), -2.0, 2 * bin);
  EXPECT_NEAR(v[2].points_sensor.front().y(), 2.0, 2 * bin);
  EXPECT_NEAR(v[0].points_sensor.front().y(), -4.0, 1e-9);
  // Source intervals on the far wall (arc length from (4, -4)).
  EXPECT_NEAR(v[0].source_from_m, 0.0, 1e-9);
  EXPECT_NEAR(v[0].source_to_m, 2.0, 2 * bin);
  EXPECT_NEAR(v[2].source_to_m, 8.0, 1e-9);
  for (const VisiblePolyline& p : v) {  // counter-clockwise along each piece
    EXPECT_LT(Bearing(p.points_sensor.front()), Bearing(p.points_sensor.back()));
  }
}

TEST(VisibilityTest, WallsWithinTheOcclusionToleranceAreSeenAndWallsBeyondItAreNot) {
  // The occlusion test's tolerance: a short wall 3 cm behind a wall is seen whole, walls farther
  // behind it than the tolerance in every bin they span are left out whole, and one that reaches
  // past the near walls' bins is seen there, from the shadow edge on.
  MapFixture map;
  map.Add(0, {{2, -1}, {2, 1}});
  map.Add(1, {{2.03, -0.1}, {2.03, 0.1}});   // 3 cm behind: within depth_tolerance_m (5 cm)
  map.Add(2, {{2.5, -1}, {2.5, 1}});         // hidden in every bin
  map.Add(3, {{2.5, -0.5}, {2.5, 0.5}});     // hidden, shorter
  map.Add(4, {{6, -1}, {6, 1}, {6, 9}});     // hidden, then seen above the near walls (y > 3)
  const std::vector<VisiblePolyline> v = map.See(Pose2());
  std::vector<PolylineId> sources;
  for (const VisiblePolyline& p : v) sources.push_back(p.source);
  std::sort(sources.begin(), sources.end());
  EXPECT_EQ(sources, (std::vector<PolylineId>{0, 1, 4}));
  for (const VisiblePolyline& p : v) {
    if (p.source == 0 || p.source == 1) {
      EXPECT_NEAR(p.source_from_m, 0.0, 1e-9);
      EXPECT_NEAR(p.source_to_m, p.source == 0 ? 2.0 : 0.2, 1e-9);
    } else {  // the shadow of |y| <= 1 at x = 2 reaches y = 3 at x = 6
      EXPECT_NEAR(p.points_sensor.front().y(), 3.0, 0.05);
      EXPECT_NEAR(p.source_to_m, 10.0, 1e-9);
    }
  }
}

TEST(VisibilityTest, AWallTheScanSawThroughNeitherHidesNorIsSeen) {
  // The map's near wall (x = 2, |y| <= 1) is gone: the scan's beams reach the far wall (x = 4)
  // through it. With the scan's rays the near wall is left out and the far wall is whole; where
  // a beam has no reading (NaN) the map decides as without rays.
  MapFixture map;
  map.Add(0, {{2, -1}, {2, 1}});
  map.Add(1, {{4, -4}, {4, 4}});
  LaserScan scan;
  scan.max_range_m = 30.0;
  for (int i = 0; i <= 180; ++i) {
    const double a = -M_PI / 2 + i * M_PI / 180;
    scan.angles_rad.push_back(a);
    scan.ranges_m.push_back(std::abs(std::cos(a)) > 1e-6 ? 4.0 / std::cos(a) : 30.0);
  }
  SeenRays seen = SeenRaysOf(scan, 0.5);
  std::vector<VisiblePolyline> v = map.See(Pose2(), {}, &seen);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].source, 1u);
  EXPECT_NEAR(v[0].source_from_m, 0.0, 1e-9);
  EXPECT_NEAR(v[0].source_to_m, 8.0, 1e-9);
  // A margin wider than the 2 m between the walls keeps the near wall, which hides the far.
  seen = SeenRaysOf(scan, 2.5);
  EXPECT_EQ(map.See(Pose2(), {}, &seen).size(), 3u);
  // No readings: the near wall hides the far one as before.
  std::fill(scan.ranges_m.begin(), scan.ranges_m.end(), std::nan(""));
  seen = SeenRaysOf(scan, 0.5);
  EXPECT_EQ(map.See(Pose2(), {}, &seen).size(), 3u);
  // "No return" is no reading either (glass, a dark surface).
  std::fill(scan.ranges_m.begin(), scan.ranges_m.end(), 30.0);
  seen = SeenRaysOf(scan, 0.5);
  EXPECT_EQ(map.See(Pose2(), {}, &seen).size(), 3u);
}

TEST(VisibilityTest, ClipsAtTheRangeCircleAndTheFieldOfView) {
  MapFixture map;
  map.Add(0, {{5, -20}, {5, 20}});
  VisibilityParams params;
  params.max_range_m = 10.0;
  params.fov_rad = M_PI;
  std::vector<VisiblePolyline> v = map.See(Pose2(), params);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_NEAR(v[0].points_sensor.front().norm(), 10.0, 1e-9);
  EXPECT_NEAR(v[0].points_sensor.back().norm(), 10.0, 1e-9);
  params.fov_rad = M_PI / 2;  // +-45 deg: the wall is cut at y = +-5, exactly at the edge rays
  v = map.See(Pose2(), params);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_NEAR(v[0].points_sensor.front().y(), -5.0, 1e-9);
  EXPECT_NEAR(v[0].points_sensor.back().y(), 5.0, 1e-9);
}

TEST(VisibilityTest, RoomSeenFromInsideIsOrderedCounterClockwise) {
  MapFixture map;
  map.Add(3, {{0, 0}, {6, 0}, {6, 4}, {0, 4}, {0, 0}});  // one closed polyline
  const Pose2 T_map_sensor(2.0, 1.5, 0.4);
  const std::vector<VisiblePolyline> v = map.See(T_map_sensor);
  ASSERT_GE(v.size(), 1u);
  ASSERT_LE(v.size(), 2u);  // the wrap at bearing -pi may split it once
  double total = 0.0;
  for (const VisiblePolyline& p : v) {
    for (std::size_t i = 0; i + 1 < p.points_sensor.size(); ++i) {
      total += NormalizeAngle(Bearing(p.points_sensor[i + 1]) - Bearing(p.points_sensor[i]));
      total += (p.points_sensor[i + 1] - p.points_sensor[i]).norm() * 0.0;
    }
  }
  EXPECT_NEAR(total, 2 * M_PI, 0.02);  // the whole room, once around
  // Outputs are in the sensor frame: map them back onto the walls.
  for (const VisiblePolyline& p : v) {
    for (const Point2& q : p.points_sensor) {
      const Point2 w = T_map_sensor * q;
      const double d = std::min({std::abs(w.x()), std::abs(w.x() - 6), std::abs(w.y()), std::abs(w.y() - 4)});
      EXPECT_LT(d, 1e-9);
    }
  }
}

TEST(VisibilityTest, DegenerateInputAndDeterminism) {
  MapFixture map;
  map.Add(0, {{1, 1}, {1, 1}, {2, 1}});  // zero-length segment
  map.Add(1, {{-1, 0}, {1, 0}});         // through the viewpoint
  map.Add(2, {{3, 3}});                  // one vertex
  const std::vector<VisiblePolyline> a = map.See(Pose2());
  const std::vector<VisiblePolyline> b = map.See(Pose2());
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].points_sensor, b[i].points_sensor);
  MapFixture empty;
  EXPECT_TRUE(empty.See(Pose2()).empty());
  VisibilityParams bad;
  bad.max_range_m = -1;
  EXPECT_THROW(empty.See(Pose2(), bad), std::invalid_argument);
}

// The model a scan is matched against reaches 1 m beyond the scan's farthest reading, around
// its field of view; without a pose estimate (the last pose predicts the scan) all around, and
// as much farther as the robot may have driven towards what the scan sees farthest.
TEST(ModelVisibilityTest, WithoutAnEstimateAllAroundAndAMotionFarther) {
  LaserScan scan;
  scan.max_range_m = 30.0;
  for (int i = 0; i <= 180; ++i) {
    scan.angles_rad.push_back((i - 90) * M_PI / 180.0);
    // one farthest reading (8 m) and one no-return (30 m)
    scan.ranges_m.push_back(i == 40 ? 8.0 : (i == 41 ? 30.0 : 5.0));
  }
  ShapeSlamParams params;
  params.max_motion_per_scan_m = 1.5;
  const VisibilityParams own = VisibilityForScan(scan, params.visibility,
                                                 params.shapes.extraction.min_range_m,
                                                 params.visibility_fov_margin_rad);
  EXPECT_DOUBLE_EQ(own.max_range_m, 9.0);
  EXPECT_NEAR(own.fov_rad, M_PI + M_PI / 180.0 + 2.0 * params.visibility_fov_margin_rad, 1e-12);
  const VisibilityParams predicted = internal::ModelVisibility(scan, false, params);
  EXPECT_DOUBLE_EQ(predicted.max_range_m, own.max_range_m);
  EXPECT_DOUBLE_EQ(predicted.fov_rad, own.fov_rad);
  const VisibilityParams last_pose = internal::ModelVisibility(scan, true, params);
  EXPECT_DOUBLE_EQ(last_pose.max_range_m, 10.5);
  EXPECT_DOUBLE_EQ(last_pose.fov_rad, 2.0 * M_PI);
  params.visibility.max_range_m = 10.0;  // never beyond the configured range
  EXPECT_DOUBLE_EQ(internal::ModelVisibility(scan, true, params).max_range_m, 10.0);
}

}  // namespace
}  // namespace shape_slam
