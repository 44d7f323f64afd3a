// Small planar geometry helpers used by several stages (distances to segments and polylines,
// arc length). Header-only; everything in metres.
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>

#include "shape_slam/types.h"

namespace shape_slam {

/// Parameter in [0, 1] of the point of segment [a, b] nearest to `p` (0 for a zero-length
/// segment).
inline double SegmentParameter(const Point2& p, const Point2& a, const Point2& b) {
  const Point2 ab = b - a;
  const double len2 = ab.squaredNorm();
  return len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
}

/// Closest point to `p` on the segment [a, b].
inline Point2 ClosestPointOnSegment(const Point2& p, const Point2& a, const Point2& b) {
  return a + SegmentParameter(p, a, b) * (b - a);
}

/// Squared distance from `p` to the segment [a, b].
inline double SquaredDistanceToSegment(const Point2& p, const Point2& a, const Point2& b) {
  return (p - ClosestPointOnSegment(p, a, b)).squaredNorm();
}

/// Total length of a polyline (0 for fewer than two vertices).
inline double PolylineLength(const Polyline& polyline) {
  double length = 0.0;
  for (std::size_t i = 1; i < polyline.size(); ++i) length += (polyline[i] - polyline[i - 1]).norm();
  return length;
}

/// The point of a polyline nearest to `p`, with the index of its segment (segment i joins
/// vertices i and i + 1) and the parameter along it.
struct PolylineProjection {
  Point2 point = Point2::Zero();
  std::size_t segment = 0;
  double t = 0.0;
  double squared_distance = std::numeric_limits<double>::infinity();
};

/// Nearest point on a polyline by a linear scan over its segments. A one-vertex polyline
/// projects onto its vertex. Precondition: the polyline is not empty.
inline PolylineProjection ProjectOntoPolyline(const Point2& p, const Polyline& polyline) {
  PolylineProjection best;
  if (polyline.size() == 1) {
    best.point = polyline.front();
    best.squared_distance = (p - best.point).squaredNorm();
    return best;
  }
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const double t = SegmentParameter(p, polyline[i], polyline[i + 1]);
    const Point2 q = polyline[i] + t * (polyline[i + 1] - polyline[i]);
    const double d2 = (p - q).squaredNorm();
    if (d2 < best.squared_distance) best = {q, i, t, d2};
  }
  return best;
}

}  // namespace shape_slam
