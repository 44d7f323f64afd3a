#include "shape_slam/polyline_extraction.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace shape_slam {
namespace {

// A scan whose beams are spread over `fov` with the given ranges.
LaserScan ScanOf(const std::vector<double>& ranges, double fov, double max_range = 10.0) {
  LaserScan scan;
  scan.max_range_m = max_range;
  scan.ranges_m = ranges;
  const int n = static_cast<int>(ranges.size());
  const bool full = fov >= 2 * M_PI - 1e-9;
  for (int i = 0; i < n; ++i) {
    scan.angles_rad.push_back(-fov / 2 + i * (full ? fov / n : fov / (n - 1)));
  }
  return scan;
}

TEST(PolylineExtractionTest, SplitsAtGapsAndInvalidReadings) {
  // 1 degree apart at 2 m: 3.5 cm between neighbours; a jump to 3 m is a gap.
  std::vector<double> r(40, 2.0);
  for (int i = 10; i < 15; ++i) r[i] = 3.0;
  r[25] = std::numeric_limits<double>::quiet_NaN();
  r[30] = 10.0;  // max range: no return
  r[33] = 0.01;  // below min range
  const std::vector<Polyline> p = ExtractPolylines(ScanOf(r, 39 * M_PI / 180), ExtractionParams{});
  ASSERT_EQ(p.size(), 6u);
  EXPECT_EQ(p[0].size(), 10u);
  EXPECT_EQ(p[1].size(), 5u);
  EXPECT_EQ(p[2].size(), 10u);
  EXPECT_EQ(p[3].size(), 4u);
  EXPECT_EQ(p[4].size(), 2u);
  EXPECT_EQ(p[5].size(), 6u);
  // Points are in the sensor frame, in beam order.
  EXPECT_NEAR(p[0].front().norm(), 2.0, 1e-12);
  EXPECT_LT(std::atan2(p[0].front().y(), p[0].front().x()),
            std::atan2(p[0].back().y(), p[0].back().x()));
}

TEST(PolylineExtractionTest, GapThresholdAndMinPoints) {
  // Two points 0.19 m apart stay together, 0.21 m apart split; single points are dropped.
  LaserScan scan;
  scan.max_range_m = 30;
  scan.ranges_m = {1.0, 1.0, 1.0};
  const double a = 2 * std::asin(0.19 / 2.0), b = 2 * std::asin(0.21 / 2.0);
  scan.angles_rad = {0.0, a, a + b};
  ExtractionParams fixed_gap;
  fixed_gap.gap_beam_spacing_factor = 0.0;  // the paper's rule alone
  const std::vector<Polyline> p = ExtractPolylines(scan, fixed_gap);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].size(), 2u);
  ExtractionParams keep_singletons = fixed_gap;
  keep_singletons.min_points = 1;
  EXPECT_EQ(ExtractPolylines(scan, keep_singletons).size(), 2u);
}

// A wall 20 m away seen by a 1 deg scanner: its points lie 0.35 m apart, yet it is one
// polyline; near the sensor the 20 cm rule still splits.
TEST(PolylineExtractionTest, GapThresholdGrowsWithTheBeamSpacing) {
  const double step = M_PI / 180.0;
  LaserScan far;
  far.max_range_m = 50;
  for (int i = -5; i <= 5; ++i) {
    far.angles_rad.push_back(i * step);
    far.ranges_m.push_back(20.0 / std::cos(i * step));  // the wall x = 20
  }
  const std::vector<Polyline> wall = ExtractPolylines(far, ExtractionParams{});
  ASSERT_EQ(wall.size(), 1u);
  EXPECT_EQ(wall[0].size(), 11u);
  ExtractionParams fixed_gap;
  fixed_gap.gap_beam_spacing_factor = 0.0;
  EXPECT_TRUE(ExtractPolylines(far, fixed_gap).empty());  // every point alone, dropped

  LaserScan near;  // two objects at 1 m, 0.3 m apart between beams 1 deg apart: split
  near.max_range_m = 50;
  near.angles_rad = {0.0, step, 2 * step, 3 * step};
  near.ranges_m = {1.0, 1.0, 1.3, 1.3};
  EXPECT_EQ(ExtractPolylines(near, ExtractionParams{}).size(), 2u);
}

TEST(PolylineExtractionTest, FullCircleJoinsAcrossTheSeam) {
  const std::vector<double> r(360, 3.0);  // a circle around the sensor
  const std::vector<Polyline> full = ExtractPolylines(ScanOf(r, 2 * M_PI), ExtractionParams{});
  ASSERT_EQ(full.size(), 1u);
  EXPECT_EQ(full[0].size(), 360u);
  std::vector<double> broken = r;
  broken[100] = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Polyline> one = ExtractPolylines(ScanOf(broken, 2 * M_PI), ExtractionParams{});
  ASSERT_EQ(one.size(), 1u);  // the seam is joined, the NaN splits: one polyline from 101 to 99
  EXPECT_EQ(one[0].size(), 359u);
  // 180 deg: no seam.
  EXPECT_EQ(ExtractPolylines(ScanOf(std::vector<double>(181, 3.0), M_PI), {}).size(), 1u);
}

TEST(PolylineExtractionTest, RejectsBadInput) {
  LaserScan scan = ScanOf({1, 1, 1}, 0.1);
  scan.angles_rad.pop_back();
  EXPECT_THROW(ExtractPolylines(scan, {}), std::invalid_argument);
  ExtractionParams bad;
  bad.max_gap_m = 0;
  EXPECT_THROW(ExtractPolylines(ScanOf({1, 1}, 0.1), bad), std::invalid_argument);
  EXPECT_TRUE(ExtractPolylines(LaserScan{}, {}).empty());
  const std::vector<double> all_invalid(20, -1.0);
  EXPECT_TRUE(ExtractPolylines(ScanOf(all_invalid, 1.0), {}).empty());
}

}  // namespace
}  // namespace shape_slam
