// Pictures of scans, polylines and maps: one scene description, rendered to SVG (text) or PNG
// (OpenCV, antialiased). Both renderings draw a 1 m grid, a scale bar and a legend; the world
// frame has x to the right and y up.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam::io {

struct Color {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// One kind of thing drawn in one style.
struct DrawingLayer {
  std::string name;                ///< shown in the legend
  std::vector<Polyline> polylines;  ///< drawn as connected lines
  std::vector<Point2> points;       ///< drawn as dots
  Color color;
  double line_width_px = 1.5;
  double point_radius_px = 1.5;
  bool mark_vertices = false;  ///< draw a small dot at every polyline vertex
};

struct Drawing {
  std::string title;
  std::vector<DrawingLayer> layers;  ///< drawn in order (later on top)
  double grid_spacing_m = 1.0;
  double margin_m = 1.0;
  /// Pixels per metre; reduced when the picture would exceed max_size_px on either side.
  double pixels_per_m = 40.0;
  int max_size_px = 4000;
};

/// The SVG document of a drawing.
std::string RenderSvg(const Drawing& drawing);

/// The PNG file content of a drawing (OpenCV, antialiased lines), drawn in strips of rows and
/// encoded row by row (zlib): a 4000-px picture never weighs 48 MB at once. Throws OutputError when
/// encoding fails.
std::string RenderPng(const Drawing& drawing);

}  // namespace shape_slam::io

#include "shape_slam/polyline_map.h"

namespace shape_slam::io {

/// The standard picture of a polyline map (black polylines) with an optional trajectory (blue
/// line, start marked green and end red).
Drawing MakeMapDrawing(const PolylineMap& map, const std::vector<Point2>& trajectory,
                       const std::string& title);

/// The same picture with the trajectory in pieces, each drawn on its own (not joined to the
/// next: e.g. the stretches a localizer tracked, apart where it was not localized); the start
/// is the first piece's first point, the end the last piece's last point.
Drawing MakeMapDrawing(const PolylineMap& map, const std::vector<Polyline>& trajectory_pieces,
                       const std::string& title);

}  // namespace shape_slam::io
