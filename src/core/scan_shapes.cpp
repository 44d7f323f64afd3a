#include "shape_slam/scan_shapes.h"

#include <stdexcept>

namespace shape_slam {
namespace {

// DCE continued until at most `max_vertices` remain: bounds the cost of S (O(m n (m + n)) in
// the arcs) on cluttered scans; S* evolves further where that helps (§4.1).
Polyline LimitVertices(const Polyline& polyline, int max_vertices) {
  if (static_cast<int>(polyline.size()) <= max_vertices) return polyline;
  CurveEvolution evolution(polyline);
  while (evolution.CanRemove() && evolution.NumVertices() > max_vertices) evolution.RemoveNext();
  return evolution.Current();
}

}  // namespace

void ScanShapesParams::Validate() const {
  extraction.Validate();
  dce.Validate();
  if (!(alignment_dce_threshold_m > 0.0)) {
    throw std::invalid_argument("ScanShapesParams::alignment_dce_threshold_m must be > 0");
  }
  if (!(alignment_max_deviation_m > 0.0)) {
    throw std::invalid_argument("ScanShapesParams::alignment_max_deviation_m must be > 0");
  }
  if (max_shape_vertices < 2) {
    throw std::invalid_argument("ScanShapesParams::max_shape_vertices must be >= 2");
  }
}

Polyline ForShapeMatching(const Polyline& polyline, const ScanShapesParams& params) {
  return LimitVertices(SimplifyDce(polyline, params.dce.threshold_m), params.max_shape_vertices);
}

ScanShapes ExtractScanShapes(const LaserScan& scan, const ScanShapesParams& params) {
  ScanShapes shapes;
  for (const Polyline& raw : ExtractPolylines(scan, params.extraction)) {
    shapes.coarse.push_back(ForShapeMatching(raw, params));
    shapes.fine.push_back(SimplifyDceBounded(raw, params.alignment_dce_threshold_m,
                                             params.alignment_max_deviation_m));
  }
  return shapes;
}

}  // namespace shape_slam
