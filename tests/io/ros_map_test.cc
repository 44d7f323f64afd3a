#include "shape_slam_io/ros_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "io/grid_scene.h"
#include "io/test_files.h"
#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/map_file.h"
#ifdef SHAPE_SLAM_HAVE_MRPT
#include "shape_slam_io/mrpt_maps.h"
#endif

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

// map.pgm written row by row is FormatPgm's content; read back row by row it gives every cell
// of the grid, each row once, from the top; an image of another grid, a truncated one and a
// pixel that is no cell state are errors naming the file.
TEST(RosMapTest, RowByRowWritingAndReadingKeepEveryCell) {
  OccupancyGridParams params;
  params.resolution_m = 0.05;
  const RoomKeyframe room_keyframe(Pose2(0.3, -0.2, 0.4));
  const OccupancyGrid grid = BuildOccupancyGrid(RoomWalls(), {room_keyframe.view}, params);
  TempDir dir;
  StagedFiles files;
  const std::string staged =
      files.Stage(dir.Path("map.pgm"), [&](const ByteWriter& write) { WritePgm(grid, write); });
  EXPECT_EQ(ReadFile(staged), FormatPgm(grid));

  OccupancyGrid frame = grid;
  frame.cells.clear();
  OccupancyGrid read = frame;
  read.cells.assign(grid.cells.size(), CellState::kOccupied);
  std::vector<int> rows;
  ReadPgmRows(staged, frame, [&](int iy, const std::vector<CellState>& cells) {
    ASSERT_EQ(cells.size(), static_cast<std::size_t>(grid.width));
    std::copy(cells.begin(), cells.end(), read.cells.begin() + static_cast<long>(iy) * grid.width);
    rows.push_back(iy);
  });
  EXPECT_EQ(read.cells, grid.cells);
  ASSERT_EQ(rows.size(), static_cast<std::size_t>(grid.height));
  EXPECT_EQ(rows.front(), grid.height - 1);
  EXPECT_EQ(rows.back(), 0);

  const auto fails_naming = [&](const std::string& path, const OccupancyGrid& g) {
    try {
      ReadPgmRows(path, g, [](int, const std::vector<CellState>&) {});
      ADD_FAILURE() << path << " must not be read";
    } catch (const MapFileError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  };
  OccupancyGrid wider = frame;
  wider.width += 1;
  fails_naming(staged, wider);
  const std::string pgm = FormatPgm(grid);
  fails_naming(dir.Write("short.pgm", pgm.substr(0, pgm.size() - 1)), frame);
  std::string odd = pgm;
  odd.back() = static_cast<char>(100);
  fails_naming(dir.Write("odd.pgm", odd), frame);
  fails_naming(dir.Path("none.pgm"), frame);
}

#ifdef SHAPE_SLAM_HAVE_MRPT
// map.gridmap made from map.pgm read back (what `run` does, so that the grid and MRPT's map are
// never both in memory) is the gridmap made from the grid itself, byte for byte.
TEST(RosMapTest, GridmapFromThePgmIsTheGridsGridmap) {
  OccupancyGridParams params;
  params.resolution_m = 0.05;
  const RoomKeyframe room_keyframe(Pose2(-0.4, 0.1, -2.0));
  const OccupancyGrid grid = BuildOccupancyGrid(RoomWalls(), {room_keyframe.view}, params);
  TempDir dir;
  const std::string pgm = dir.Write("map.pgm", FormatPgm(grid));
  OccupancyGrid frame = grid;
  frame.cells.clear();
  EXPECT_EQ(FormatMrptGridmap(frame, pgm), FormatMrptGridmap(grid));
  OccupancyGrid moved = grid;
  moved.origin_m.x() += 0.05;  // another grid's frame: another map
  EXPECT_NE(FormatMrptGridmap(moved, pgm), FormatMrptGridmap(grid));
}
#endif

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
