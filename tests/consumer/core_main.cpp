// Uses the core alone: extracts the polylines of a synthetic scan of a corner.
#include <cmath>
#include <iostream>

#include "shape_slam/polyline_extraction.h"
#include "shape_slam/types.h"

int main() {
  shape_slam::LaserScan scan;
  scan.max_range_m = 30.0;
  for (int i = 0; i <= 180; ++i) {
    const double angle = -M_PI / 2 + M_PI * i / 180.0;
    // Walls x = 2 and y = 2 seen from the origin.
    const double range = std::min(std::abs(std::cos(angle)) > 1e-9 ? 2.0 / std::cos(angle) : 1e9,
                                  std::abs(std::sin(angle)) > 1e-9 ? 2.0 / std::sin(angle) : 1e9);
    scan.angles_rad.push_back(angle);
    scan.ranges_m.push_back(range > 0.0 ? range : NAN);
  }
  const auto polylines = shape_slam::ExtractPolylines(scan, shape_slam::ExtractionParams{});
  std::cout << "consumer_core: " << polylines.size() << " polyline(s)\n";
  return polylines.empty() ? 1 : 0;
}
