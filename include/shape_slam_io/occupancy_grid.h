// An occupancy grid of a finished map, for tools that want cells instead of polylines (ROS
// map_server, MRPT's planners and localisers). Plain geometry, no I/O:
//  - free: every cell a keyframe beam crosses from the sensor to its endpoint (the endpoint's
//    own cell excluded); a beam without return (range >= the scan's max range) clears up to
//    max_free_range_m or the first wall, whichever comes first; a beam with no reading (NaN,
//    <= 0) clears nothing;
//  - occupied: every cell a segment of the map's polylines crosses (this wins over free);
//  - unknown: the rest.
// Cells are squares of resolution_m; cell (ix, iy) covers [origin + ix * res, origin + (ix + 1)
// * res) in x and likewise in y, so row iy = 0 is the lowest y. The origin is a multiple of the
// resolution.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"

namespace shape_slam::io {

enum class CellState : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };

struct OccupancyGridParams {
  double resolution_m = 0.05;      ///< cell side, metres
  double max_free_range_m = 20.0;  ///< a beam without return clears up to this, metres
  double margin_m = 0.5;           ///< unknown border around what was seen, metres
  std::size_t max_cells = 100'000'000;  ///< larger grids are refused (memory)
  /// Throws std::invalid_argument naming the field.
  void Validate() const;
};

struct OccupancyGrid {
  double resolution_m = 0.05;
  Point2 origin_m = Point2::Zero();  ///< map-frame corner of cell (0, 0): its lowest x and y
  int width = 0;                     ///< cells along x
  int height = 0;                    ///< cells along y
  std::vector<CellState> cells;      ///< row-major from iy = 0 (lowest y): cells[iy * width + ix]

  CellState At(int ix, int iy) const { return cells[static_cast<std::size_t>(iy) * width + ix]; }
  /// The cell (ix, iy) holding a map-frame point; nullopt outside the grid.
  std::optional<Eigen::Vector2i> CellOf(const Point2& p_map) const;
  std::size_t Count(CellState state) const;
};

/// The grid of `walls` (map-frame polylines) and the free space seen by `keyframes` (scans at
/// their map-frame poses, ShapeSlam::Keyframes()), covering both with a margin. Throws
/// std::invalid_argument for invalid params or when the grid would exceed params.max_cells (the
/// message gives its size).
OccupancyGrid BuildOccupancyGrid(const std::vector<Polyline>& walls,
                                 const std::vector<ShapeSlam::KeyframeView>& keyframes,
                                 const OccupancyGridParams& params);

/// Every cell the segment a-b passes through, in order from a's cell to b's (a grid traversal,
/// Amanatides & Woo 1987), as (ix, iy) pairs; cells outside the grid are left out.
std::vector<Eigen::Vector2i> CellsOnSegment(const OccupancyGrid& grid, const Point2& a,
                                            const Point2& b);

}  // namespace shape_slam::io
