#include "shape_slam/scan_insertion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace shape_slam {
namespace {

// A scan of a straight wall 2 m ahead of the sensor (the line x = 2), 90 deg wide, 1 deg beams,
// counter-clockwise.
LaserScan WallScan() {
  LaserScan scan;
  scan.max_range_m = 30.0;
  for (int i = -45; i <= 45; ++i) {
    const double angle = i * M_PI / 180.0;
    scan.angles_rad.push_back(angle);
    scan.ranges_m.push_back(2.0 / std::cos(angle));
  }
  return scan;
}

TEST(InsertScanTest, WallLandsWhereThePoseSaysInTheMapFrame) {
  LaserScan scan = WallScan();
  scan.T_robot_sensor = {0.5, 0.0, 0.0};
  PolylineMap map;
  // Robot at (1, 0) facing +y: the sensor at (1, 0.5), the wall on the line y = 2.5.
  const ScanInsertionResult result = InsertScan(map, scan, {1.0, 0.0, M_PI / 2}, true, {});
  EXPECT_EQ(result.polylines, 1);
  EXPECT_EQ(result.map_update.added, 1);
  ASSERT_EQ(map.NumPolylines(), 1u);
  const MapPolyline& wall = map.Get(map.Ids().front());
  for (const Point2& p : wall.points) EXPECT_NEAR(p.y(), 2.5, 1e-6);
  const auto [lo, hi] = std::minmax_element(
      wall.points.begin(), wall.points.end(),
      [](const Point2& a, const Point2& b) { return a.x() < b.x(); });
  EXPECT_NEAR(lo->x(), 1.0 - 2.0, 1e-6);  // tan(45 deg) * 2 m each side of x = 1
  EXPECT_NEAR(hi->x(), 1.0 + 2.0, 1e-6);
}

TEST(InsertScanTest, ClockwiseScanGivesTheSameMap) {
  const LaserScan ccw = WallScan();
  LaserScan cw = ccw;
  std::reverse(cw.angles_rad.begin(), cw.angles_rad.end());
  std::reverse(cw.ranges_m.begin(), cw.ranges_m.end());
  PolylineMap a, b;
  InsertScan(a, ccw, {0.3, -0.2, 0.1}, true, {});
  InsertScan(b, cw, {0.3, -0.2, 0.1}, true, {});
  ASSERT_EQ(a.NumPolylines(), 1u);
  ASSERT_EQ(b.NumPolylines(), 1u);
  EXPECT_EQ(a.Get(a.Ids().front()).points, b.Get(b.Ids().front()).points);
}

TEST(InsertScanTest, SecondViewOfTheSameWallMergesInsteadOfAdding) {
  PolylineMap map;
  InsertScan(map, WallScan(), {0.0, 0.0, 0.0}, true, {});
  // 0.5 m further along the wall: the same wall x = 2 seen again.
  const ScanInsertionResult again = InsertScan(map, WallScan(), {0.0, 0.5, 0.0}, true, {});
  EXPECT_EQ(again.map_update.merged, 1);
  EXPECT_EQ(map.NumPolylines(), 1u);
}

TEST(InsertScanTest, ScanWithoutReadingsLeavesTheMapAlone) {
  LaserScan scan = WallScan();
  std::fill(scan.ranges_m.begin(), scan.ranges_m.end(), std::numeric_limits<double>::quiet_NaN());
  PolylineMap map;
  const ScanInsertionResult result = InsertScan(map, scan, {}, true, {});
  EXPECT_EQ(result.polylines, 0);
  EXPECT_TRUE(map.Empty());
}

TEST(InsertScanTest, BadInputThrows) {
  PolylineMap map;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(InsertScan(map, WallScan(), {nan, 0.0, 0.0}, true, {}), std::invalid_argument);
  ScanInsertionParams params;
  params.visibility_fov_margin_rad = -1.0;
  EXPECT_THROW(InsertScan(map, WallScan(), {}, true, params), std::invalid_argument);
  LaserScan scan = WallScan();
  scan.ranges_m.pop_back();
  EXPECT_THROW(InsertScan(map, scan, {}, true, {}), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
