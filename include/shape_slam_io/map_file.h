// The polyline map file (`map.polylines`): a small, line-oriented text format that shape-slam
// writes and loads, and that other tools can read without our code.
//
//   # comment lines start with '#'
//   shape-slam-polylines 1          <- format name and version
//   polylines N                     <- number of blocks that follow
//   polyline ID V OBS CONTRA        <- a block: id, vertex count, observations, contradictions
//   x y support                     <- V vertex lines: map frame, metres; support >= 0
//
// Numbers are written in the shortest form that reads back to the same double, so a save/load
// round trip is exact.
#pragma once

#include <stdexcept>
#include <string>

#include "shape_slam/polyline_map.h"

namespace shape_slam::io {

/// A map file that cannot be read; what() names the file and line.
class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The text of a map file for `map` (polylines in increasing id order).
std::string FormatMapFile(const PolylineMap& map);

/// Writes the map file atomically. Throws OutputError.
void SaveMapFile(const std::string& path, const PolylineMap& map);

/// Parses a map file's text; `name` is used in error messages. Throws MapFileError.
PolylineMap ParseMapFile(const std::string& text, const std::string& name);

/// Loads a map file. Throws MapFileError (missing file, bad format, truncated, bad numbers).
PolylineMap LoadMapFile(const std::string& path);

}  // namespace shape_slam::io
