#include "shape_slam_io/ros_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "io/grid_scene.h"
#include "io/test_files.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/map_file.h"

namespace shape_slam::io {
namespace {

using testing::ReadFile;
using testing::RoomKeyframe;
using testing::RoomWalls;
using testing::TempDir;

double DistanceToWalls(const Point2& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Polyline& wall : RoomWalls()) {
    for (std::size_t i = 0; i + 1 < wall.size(); ++i) {
      const Point2 d = wall[i + 1] - wall[i];
      const double t = std::clamp((p - wall[i]).dot(d) / d.squaredNorm(), 0.0, 1.0);
      best = std::min(best, (wall[i] + t * d - p).norm());
    }
  }
  return best;
}

// Writes the grid of the room as map.pgm + map.yaml, reads them back as map_server would.
TEST(RosMapTest, RoundTripKeepsEveryCellAndTheGeometry) {
  OccupancyGridParams params;
  params.resolution_m = 0.05;
  const RoomKeyframe room_keyframe(Pose2(-0.5, 0.7, 1.0));
  const ShapeSlam::KeyframeView& keyframe = room_keyframe.view;
  const OccupancyGrid grid = BuildOccupancyGrid(RoomWalls(), {keyframe}, params);
  TempDir dir;
  WriteFileAtomically(dir.Path("map.pgm"), FormatPgm(grid));
  WriteFileAtomically(dir.Path("map.yaml"), FormatMapYaml(grid, "map.pgm"));
  EXPECT_NE(ReadFile(dir.Path("map.yaml")).find("free_thresh: 0.196"), std::string::npos);

  const OccupancyGrid loaded = LoadRosMap(dir.Path("map.yaml"));
  ASSERT_EQ(loaded.width, grid.width);
  ASSERT_EQ(loaded.height, grid.height);
  EXPECT_DOUBLE_EQ(loaded.resolution_m, 0.05);
  EXPECT_DOUBLE_EQ(loaded.origin_m.x(), grid.origin_m.x());
  EXPECT_DOUBLE_EQ(loaded.origin_m.y(), grid.origin_m.y());
  EXPECT_EQ(loaded.cells, grid.cells);

  // Occupied cells lie on the walls (centre within half a cell diagonal of a segment).
  const double half_diagonal = 0.5 * std::sqrt(2.0) * 0.05;
  std::size_t occupied = 0;
  for (int iy = 0; iy < loaded.height; ++iy) {
    for (int ix = 0; ix < loaded.width; ++ix) {
      const Point2 centre = loaded.origin_m + Point2(ix + 0.5, iy + 0.5) * 0.05;
      const CellState state = loaded.At(ix, iy);
      if (state == CellState::kOccupied) {
        ++occupied;
        EXPECT_LE(DistanceToWalls(centre), half_diagonal + 1e-9);
      } else if (std::abs(centre.x()) > 2.1 || std::abs(centre.y()) > 2.1) {
        EXPECT_EQ(state, CellState::kUnknown) << "outside the room: " << centre.transpose();
      }
    }
  }
  EXPECT_GT(occupied, 300u);
  // Cells along every beam, short of its return, are free.
  for (std::size_t i = 0; i < keyframe.scan->ranges_m.size(); i += 7) {
    const double angle = keyframe.T_map_robot.theta + keyframe.scan->angles_rad[i];
    for (double r = 0.0; r < keyframe.scan->ranges_m[i] - 0.1; r += 0.02) {
      const Point2 p =
          keyframe.T_map_robot.Translation() + r * Point2(std::cos(angle), std::sin(angle));
      const Eigen::Vector2i c = *loaded.CellOf(p);
      EXPECT_EQ(loaded.At(c.x(), c.y()), CellState::kFree) << "beam " << i << " at " << r;
    }
  }
}

TEST(RosMapTest, FirstImageRowIsTheTopOfTheMap) {
  OccupancyGrid grid;
  grid.resolution_m = 0.5;
  grid.width = 2;
  grid.height = 3;
  grid.cells.assign(6, CellState::kUnknown);
  grid.cells[2 * 2 + 0] = CellState::kOccupied;  // ix 0, iy 2: top left
  grid.cells[0 * 2 + 1] = CellState::kFree;      // ix 1, iy 0: bottom right
  const std::string pgm = FormatPgm(grid);
  const std::string pixels = pgm.substr(pgm.size() - 6);
  EXPECT_EQ(pgm.rfind("P5\n", 0), 0u);
  EXPECT_EQ(static_cast<unsigned char>(pixels[0]), kPgmOccupied);
  EXPECT_EQ(static_cast<unsigned char>(pixels[1]), kPgmUnknown);
  EXPECT_EQ(static_cast<unsigned char>(pixels[5]), kPgmFree);
}

TEST(RosMapTest, MissingOrBrokenFilesAreErrorsNamingTheFile) {
  TempDir dir;
  EXPECT_THROW(LoadRosMap(dir.Path("none.yaml")), MapFileError);
  dir.Write("a.yaml", "image: a.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                      "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  dir.Write("a.pgm", "P5\n4 4\n255\nxy");  // 2 of 16 pixels
  try {
    LoadRosMap(dir.Path("a.yaml"));
    FAIL() << "a truncated image must not load";
  } catch (const MapFileError& e) {
    EXPECT_NE(std::string(e.what()).find("a.pgm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shape_slam::io
