// Helper of the run-outputs test (run_outputs_test.sh): loads what `shape-slam run` wrote with
// MRPT itself and checks it against the ROS map of the same run.
//
//   map_outputs_check GRIDMAP YAML SIMPLEMAP KEYFRAMES
//
// map.gridmap: a COccupancyGridMap2D read as MRPT's apps read .gridmap files, with the size,
// resolution and origin of map.yaml and every cell in the same class (map_server's thresholds:
// occupied above 0.65, free below 0.196 occupancy). map.simplemap: KEYFRAMES entries, each
// a sensory frame with one 2D range scan and a pose.
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/COccupancyGridMap2D.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include "shape_slam_io/ros_map.h"

namespace {

using shape_slam::io::CellState;

// MRPT's cell value is the probability of being free. Occupied as MRPT's own isStaticCell
// decides it, with map_server's thresholds turned into free probabilities.
CellState ClassOf(const mrpt::maps::COccupancyGridMap2D& grid, int ix, int iy) {
  if (grid.isStaticCell(ix, iy, 1.0f - 0.65f)) return CellState::kOccupied;
  if (grid.getCell(ix, iy) > 1.0f - 0.196f) return CellState::kFree;
  return CellState::kUnknown;
}

int CheckGridmap(const std::string& gridmap_path, const std::string& yaml_path) {
  mrpt::maps::COccupancyGridMap2D grid;
  mrpt::io::CFileGZInputStream in(gridmap_path);
  auto archive = mrpt::serialization::archiveFrom(in);
  archive >> grid;
  const shape_slam::io::OccupancyGrid ros = shape_slam::io::LoadRosMap(yaml_path);
  std::cout << gridmap_path << ": " << grid.getSizeX() << " x " << grid.getSizeY() << " cells of "
            << grid.getResolution() << " m from (" << grid.getXMin() << ", " << grid.getYMin()
            << ")\n";
  if (static_cast<int>(grid.getSizeX()) != ros.width ||
      static_cast<int>(grid.getSizeY()) != ros.height ||
      std::abs(grid.getResolution() - ros.resolution_m) > 1e-6 ||
      std::abs(grid.getXMin() - ros.origin_m.x()) > 1e-3 ||
      std::abs(grid.getYMin() - ros.origin_m.y()) > 1e-3) {
    std::cerr << "size, resolution or origin differ from " << yaml_path << "\n";
    return 1;
  }
  std::size_t occupied = 0, free = 0, differ = 0;
  for (int iy = 0; iy < ros.height; ++iy) {
    for (int ix = 0; ix < ros.width; ++ix) {
      const CellState state = ClassOf(grid, ix, iy);
      occupied += state == CellState::kOccupied;
      free += state == CellState::kFree;
      differ += state != ros.At(ix, iy);
    }
  }
  std::cout << occupied << " occupied, " << free << " free, " << differ
            << " cells differ from the ROS map\n";
  return differ == 0 && occupied > 100 && free > occupied ? 0 : 1;
}

int CheckSimplemap(const std::string& path, std::size_t keyframes) {
  mrpt::maps::CSimpleMap simplemap;
  if (!simplemap.loadFromFile(path)) {
    std::cerr << "MRPT cannot load " << path << "\n";
    return 1;
  }
  std::cout << path << ": " << simplemap.size() << " entries\n";
  if (simplemap.size() != keyframes) {
    std::cerr << "expected " << keyframes << " entries (keyframes)\n";
    return 1;
  }
  for (std::size_t i = 0; i < simplemap.size(); ++i) {
    const auto [pose, frame] = simplemap.get(i);
    if (!pose || !frame || frame->size() != 1 ||
        !frame->getObservationByClass<mrpt::obs::CObservation2DRangeScan>()) {
      std::cerr << "entry " << i << " is not a pose with one 2D range scan\n";
      return 1;
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: map_outputs_check GRIDMAP YAML SIMPLEMAP KEYFRAMES\n";
    return 2;
  }
  try {
    const int grid = CheckGridmap(argv[1], argv[2]);
    const int simplemap = CheckSimplemap(argv[3], std::strtoul(argv[4], nullptr, 10));
    return grid != 0 || simplemap != 0 ? 1 : 0;
  } catch (const std::exception& e) {
    std::cerr << "map_outputs_check: " << e.what() << "\n";
    return 1;
  }
}
