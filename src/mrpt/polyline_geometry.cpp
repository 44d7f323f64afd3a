#include "polyline_geometry.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace shape_slam {
namespace {

// Arc length at each vertex.
std::vector<double> ArcLengths(const Polyline& polyline) {
  std::vector<double> arc(polyline.size(), 0.0);
  for (std::size_t i = 1; i < polyline.size(); ++i) {
    arc[i] = arc[i - 1] + (polyline[i] - polyline[i - 1]).norm();
  }
  return arc;
}

// The point at arc length s of a polyline with arc lengths `arc`.
Point2 PointAt(const Polyline& polyline, const std::vector<double>& arc, double s) {
  const auto upper = std::upper_bound(arc.begin(), arc.end(), s);
  if (upper == arc.end()) return polyline.back();
  const std::size_t i = static_cast<std::size_t>(upper - arc.begin());
  if (i == 0) return polyline.front();
  const double length = arc[i] - arc[i - 1];
  const double t = length > 0.0 ? (s - arc[i - 1]) / length : 0.0;
  return polyline[i - 1] + t * (polyline[i] - polyline[i - 1]);
}

// Number of samples of a polyline of length `length`: every spacing, plus the end point.
std::size_t NumSamples(double length, double spacing) {
  return static_cast<std::size_t>(std::ceil(length / spacing - 1e-9)) + 1;
}

}  // namespace

PolylineGeometry::PolylineGeometry(const PolylineMap& map, double sample_spacing_m,
                                   double cell_size_m)
    : index_(cell_size_m), spacing_m_(sample_spacing_m) {
  if (!(sample_spacing_m > 0.0)) throw std::invalid_argument("sample_spacing_m must be > 0");
  for (const PolylineId id : map.Ids()) {
    const Polyline& points = map.Get(id).points;
    if (points.empty()) continue;
    const auto position = static_cast<PolylineId>(polylines_.size());
    polylines_.push_back(points);
    arc_m_.push_back(ArcLengths(points));
    first_sample_.push_back(samples_.size());
    const double length = arc_m_.back().back();
    const std::size_t n = NumSamples(length, spacing_m_);
    for (std::size_t k = 0; k < n; ++k) {
      samples_.push_back(
          PointAt(points, arc_m_.back(), std::min(length, static_cast<double>(k) * spacing_m_)));
    }
    index_.Insert(position, points);
  }
}

std::optional<PolylineGeometry::Nearest> PolylineGeometry::NearestWithin(const Point2& p,
                                                                         double radius_m) const {
  // Non-finite or absurd input (a NaN particle, a broken point) matches nothing; the bound keeps
  // the index's integer cell coordinates in range.
  constexpr double kFarthest_m = 1e9;
  if (!(radius_m > 0.0) || !p.allFinite() || p.cwiseAbs().maxCoeff() + radius_m > kFarthest_m) {
    return std::nullopt;
  }
  std::optional<Nearest> best;
  double best_arc = 0.0;
  PolylineId best_polyline = 0;
  for (const SegmentRef& ref : index_.QueryDisc(p, radius_m)) {
    const Polyline& polyline = polylines_[ref.polyline];
    const Point2& a = polyline[ref.segment];
    const Point2& b = polyline.size() > 1 ? polyline[ref.segment + 1] : a;
    const Point2 ab = b - a;
    const double length2 = ab.squaredNorm();
    const double t = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    const Point2 q = a + t * ab;
    const double d2 = (p - q).squaredNorm();
    if (best && d2 >= best->squared_distance) continue;
    best = Nearest{q, d2, 0};
    best_polyline = ref.polyline;
    const std::vector<double>& arc = arc_m_[ref.polyline];
    best_arc = polyline.size() > 1
                   ? arc[ref.segment] + t * (arc[ref.segment + 1] - arc[ref.segment])
                   : 0.0;
  }
  if (!best || best->squared_distance > radius_m * radius_m) return std::nullopt;
  const double length = arc_m_[best_polyline].back();
  const std::size_t n = NumSamples(length, spacing_m_);
  const auto k = static_cast<std::size_t>(std::lround(best_arc / spacing_m_));
  best->sample_index = first_sample_[best_polyline] + std::min(k, n - 1);
  return best;
}

}  // namespace shape_slam
