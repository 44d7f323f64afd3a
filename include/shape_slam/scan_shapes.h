// A scan's shapes (paper §3.1): the polylines of one laser scan, grouped and simplified twice --
// by DCE to the shape that matching compares (§4), and lightly, within a deviation bound, to the
// polylines whose samples drive the alignment (§5.1). The one scan-to-polylines step of the
// mapper, scan-to-scan registration and loop closure.
#pragma once

#include <vector>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/types.h"

namespace shape_slam {

struct ScanShapesParams {
  ExtractionParams extraction;  ///< §3.1 grouping
  DceParams dce;                ///< §3.1 simplification before shape matching
  /// Shape matching compares polylines with at most this many vertices (DCE continued): bounds
  /// the cost of S on cluttered scans; S* evolves further where that helps (§4.1).
  int max_shape_vertices = 16;
  /// Lighter DCE of the same polylines whose samples drive the alignment (§5.1), metres ...
  double alignment_dce_threshold_m = 0.005;
  /// ... never moving them farther than this from the scan points (metres).
  double alignment_max_deviation_m = 0.02;

  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// A scan's polylines in the sensor frame, counter-clockwise when the scan is.
struct ScanShapes {
  std::vector<Polyline> coarse;  ///< as shape matching sees them
  std::vector<Polyline> fine;    ///< the same polylines for the alignment (same count, order)
};

/// Extraction (§3.1) and the two simplifications of one scan.
ScanShapes ExtractScanShapes(const LaserScan& scan, const ScanShapesParams& params);

/// A polyline as shape matching sees it: DCE at the matching threshold, vertex count bounded.
Polyline ForShapeMatching(const Polyline& polyline, const ScanShapesParams& params);

}  // namespace shape_slam
