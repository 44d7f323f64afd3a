#include "shape_slam_io/occupancy_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <utility>

#include "io/grid_scene.h"

namespace shape_slam::io {
namespace {

using testing::RoomKeyframe;
using testing::RoomWalls;

OccupancyGrid EmptyTestGrid(double resolution_m, int width, int height) {
  OccupancyGrid grid;
  grid.resolution_m = resolution_m;
  grid.width = width;
  grid.height = height;
  grid.cells.assign(static_cast<std::size_t>(width) * height, CellState::kUnknown);
  return grid;
}

TEST(CellsOnSegmentTest, HorizontalSegmentVisitsEachCellOnce) {
  const OccupancyGrid grid = EmptyTestGrid(0.1, 10, 10);
  const std::vector<Eigen::Vector2i> cells = CellsOnSegment(grid, {0.01, 0.05}, {0.26, 0.05});
  ASSERT_EQ(cells.size(), 3u);
  EXPECT_EQ(cells[0], Eigen::Vector2i(0, 0));
  EXPECT_EQ(cells[2], Eigen::Vector2i(2, 0));
}

// Oracle: every cell a dense sampling of the segment touches is visited, the cells form a
// 4-connected chain from a's cell to b's, and no cell is visited twice.
TEST(CellsOnSegmentTest, MatchesDenseSamplingOnRandomSegments) {
  const OccupancyGrid grid = EmptyTestGrid(0.05, 200, 200);
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> coordinate(0.0, 10.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Point2 a(coordinate(prng), coordinate(prng)), b(coordinate(prng), coordinate(prng));
    const std::vector<Eigen::Vector2i> cells = CellsOnSegment(grid, a, b);
    std::set<std::pair<int, int>> visited;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      EXPECT_TRUE(visited.insert({cells[i].x(), cells[i].y()}).second);
      if (i > 0) {
        EXPECT_EQ((cells[i] - cells[i - 1]).cwiseAbs().sum(), 1);
      }
    }
    EXPECT_EQ(cells.front(), *grid.CellOf(a));
    EXPECT_EQ(cells.back(), *grid.CellOf(b));
    for (int s = 0; s <= 1000; ++s) {
      const Eigen::Vector2i c = *grid.CellOf(a + (b - a) * (s / 1000.0));
      const Point2 centre = (c.cast<double>().array() + 0.5) * grid.resolution_m;
      // Samples within 1e-9 of a cell border may round either way.
      const Point2 offset = (a + (b - a) * (s / 1000.0) - centre).cwiseAbs();
      if (offset.maxCoeff() > 0.5 * grid.resolution_m - 1e-9) continue;
      EXPECT_TRUE(visited.count({c.x(), c.y()})) << "trial " << trial << " sample " << s;
    }
  }
}

TEST(OccupancyGridTest, WallsOccupiedBeamsFreeOutsideUnknown) {
  OccupancyGridParams params;
  params.resolution_m = 0.05;
  const RoomKeyframe keyframe(Pose2(0.3, -0.2, 0.4));
  const OccupancyGrid grid = BuildOccupancyGrid(RoomWalls(), {keyframe.view}, params);
  // Origin on a multiple of the resolution; the room plus the margin covered.
  EXPECT_NEAR(std::remainder(grid.origin_m.x(), 0.05), 0.0, 1e-9);
  EXPECT_LE(grid.origin_m.x(), -2.0 - params.margin_m + 1e-9);
  EXPECT_GE(grid.origin_m.x() + grid.width * 0.05, 2.0 + params.margin_m - 1e-9);
  for (double t = 0.0; t <= 1.0; t += 0.01) {  // on the walls: occupied
    for (const Point2& p : {Point2(-2.0 + 4.0 * t, 2.0), Point2(2.0, -2.0 + 4.0 * t)}) {
      const Eigen::Vector2i c = *grid.CellOf(p);
      EXPECT_EQ(grid.At(c.x(), c.y()), CellState::kOccupied) << p.transpose();
    }
  }
  for (double x = -1.8; x <= 1.8; x += 0.1) {  // inside the room, seen by every beam: free
    for (double y = -1.8; y <= 1.8; y += 0.1) {
      const Eigen::Vector2i c = *grid.CellOf({x, y});
      EXPECT_EQ(grid.At(c.x(), c.y()), CellState::kFree) << x << " " << y;
    }
  }
  for (const Point2& outside : {Point2(2.3, 0.0), Point2(-2.3, 1.0), Point2(0.0, -2.4)}) {
    const Eigen::Vector2i c = *grid.CellOf(outside);
    EXPECT_EQ(grid.At(c.x(), c.y()), CellState::kUnknown);
  }
  EXPECT_GT(grid.Count(CellState::kOccupied), 4u * 80u - 8u);  // 4 m walls at 5 cm
  EXPECT_LT(grid.Count(CellState::kOccupied), 4u * 80u * 2u);
}

TEST(OccupancyGridTest, BeamsWithoutReturnClearUpToTheCapAndNoReadingClearsNothing) {
  LaserScan scan;
  scan.max_range_m = 8.0;
  scan.angles_rad = {0.0, M_PI / 2};
  scan.ranges_m = {8.0, std::nan("")};  // no return along +x, no reading along +y
  ShapeSlam::KeyframeView keyframe;
  keyframe.scan = &scan;
  OccupancyGridParams params;
  params.resolution_m = 0.1;
  params.max_free_range_m = 1.5;
  params.margin_m = 1.0;
  const OccupancyGrid grid = BuildOccupancyGrid({}, {keyframe}, params);
  auto state = [&](const Point2& p) {
    const Eigen::Vector2i c = *grid.CellOf(p);
    return grid.At(c.x(), c.y());
  };
  EXPECT_EQ(state({1.0, 0.05}), CellState::kFree);
  EXPECT_EQ(state({1.45, 0.05}), CellState::kFree);
  EXPECT_EQ(state({2.0, 0.05}), CellState::kUnknown);
  EXPECT_EQ(state({0.05, 0.5}), CellState::kUnknown);
  // A wall across the beam without return: it clears up to the wall, not beyond.
  const OccupancyGrid walled =
      BuildOccupancyGrid({{{0.75, -1.0}, {0.75, 1.0}}}, {keyframe}, params);
  auto walled_state = [&](const Point2& p) {
    const Eigen::Vector2i c = *walled.CellOf(p);
    return walled.At(c.x(), c.y());
  };
  EXPECT_EQ(walled_state({0.5, 0.05}), CellState::kFree);
  EXPECT_EQ(walled_state({0.75, 0.05}), CellState::kOccupied);
  EXPECT_EQ(walled_state({1.0, 0.05}), CellState::kUnknown);
}

TEST(OccupancyGridTest, InvalidParamsAndHugeGridsAreRefused) {
  OccupancyGridParams params;
  params.resolution_m = 0.0;
  EXPECT_THROW(BuildOccupancyGrid(RoomWalls(), {}, params), std::invalid_argument);
  params.resolution_m = 1e-4;  // 5 m at 0.1 mm: 2.5e9 cells
  EXPECT_THROW(BuildOccupancyGrid(RoomWalls(), {}, params), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam::io
