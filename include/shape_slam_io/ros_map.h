// An occupancy grid in ROS map_server form: an 8-bit binary PGM (P5) image and a YAML file
//
//   image: map.pgm                 <- relative to the YAML file
//   resolution: 0.05               <- metres per pixel
//   origin: [x, y, 0.0]            <- map-frame pose of the lower-left pixel
//   negate: 0
//   occupied_thresh: 0.65
//   free_thresh: 0.196
//
// Pixels: occupied 0 (black), free 254, unknown 205; the image's first row is the top of the
// map (highest y). map_server reads a pixel v as occupancy p = (255 - v) / 255 (negate 0):
// occupied when p > occupied_thresh, free when p < free_thresh, unknown otherwise.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/occupancy_grid.h"

namespace shape_slam::io {

constexpr unsigned char kPgmOccupied = 0;
constexpr unsigned char kPgmFree = 254;
constexpr unsigned char kPgmUnknown = 205;

/// The PGM file content of the grid.
std::string FormatPgm(const OccupancyGrid& grid);

/// The same content handed to `write` a row at a time (StagedFiles::Stage): a large grid's
/// image is never held whole.
void WritePgm(const OccupancyGrid& grid, const ByteWriter& write);

/// Reads back, a row at a time, the PGM that WritePgm wrote for a grid of `frame`'s width and
/// height (its cells are not used): `row(iy, cells)` for each row from the top (iy = height - 1)
/// down to iy = 0, so that a grid can be remade without the whole of it in memory. Throws
/// MapFileError naming the file when it cannot be read, is not such a PGM or is truncated.
void ReadPgmRows(const std::string& path, const OccupancyGrid& frame,
                 const std::function<void(int iy, const std::vector<CellState>& cells)>& row);

/// The YAML file content for the grid, naming `image_file` (e.g. "map.pgm").
std::string FormatMapYaml(const OccupancyGrid& grid, const std::string& image_file);

/// Reads a map_server map back (the YAML, then the image it names, P5 or P2), classifying each
/// pixel with the YAML's negate and thresholds as map_server does. Throws MapFileError
/// (map_file.h) naming the file for a missing file, a missing key or a malformed image.
OccupancyGrid LoadRosMap(const std::string& yaml_path);

}  // namespace shape_slam::io
