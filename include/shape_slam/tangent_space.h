// Tangent space of polylines (paper §4.1, after Arkin et al.) and their decomposition into
// maximal same-bent arcs (§4.1, footnote 5).
#pragma once

#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

/// Turning function T(s) of an open polyline over normalised arc length s in [0, 1]: a step
/// function whose value on segment i is the direction of that segment, unwrapped so that
/// consecutive values differ by the turn angle in (-pi, pi]. Zero-length segments are skipped.
/// A polyline of zero length has breaks {0, 1} and angles {0}.
struct TurningFunction {
  std::vector<double> breaks;  ///< size k + 1: 0 = s_0 < s_1 < ... < s_k = 1
  std::vector<double> angles;  ///< size k: the value on [s_i, s_{i+1}), radians
  double length_m = 0.0;       ///< arc length of the polyline

  /// T(s); s outside [0, 1] is clamped.
  double operator()(double s) const;
};

TurningFunction ComputeTurningFunction(const Polyline& polyline);

/// A maximal arc: vertices first_vertex..last_vertex (inclusive) of the polyline.
struct Arc {
  int first_vertex = 0;
  int last_vertex = 0;
};

/// Maximal same-bent arcs of an open polyline (§4.1, footnote 5: "left- or right-arcuated"):
/// maximal runs of consecutive segments whose turns all have the same sign. Where the sign
/// changes at vertex i, the segment (i-1, i) joins two opposite turns; it belongs to both arcs
/// (the first ends at vertex i, the next starts at vertex i-1), as the maximal convex/concave
/// arcs of Latecki & Lakämper share their inflection parts. Turns of zero (collinear vertices,
/// zero-length segments) continue the current arc. A polyline without turns is one arc; fewer
/// than two vertices give no arc.
std::vector<Arc> MaximalArcs(const Polyline& polyline);

}  // namespace shape_slam
