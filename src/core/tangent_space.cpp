#include "shape_slam/tangent_space.h"

#include <algorithm>
#include <cmath>

namespace shape_slam {
namespace {

// Sign of the turn at vertex i (between segments (i-1, i) and (i, i+1)); 0 when collinear or a
// segment has zero length.
int TurnSign(const Polyline& p, std::size_t i) {
  const Point2 a = p[i] - p[i - 1], b = p[i + 1] - p[i];
  const double cross = a.x() * b.y() - a.y() * b.x();
  const double scale = a.norm() * b.norm();
  if (scale <= 0.0 || std::abs(cross) <= 1e-12 * scale) return 0;
  return cross > 0.0 ? 1 : -1;
}

}  // namespace

double TurningFunction::operator()(double s) const {
  if (angles.empty()) return 0.0;
  const double clamped = std::clamp(s, 0.0, 1.0);
  const auto it = std::upper_bound(breaks.begin(), breaks.end(), clamped);
  const std::size_t i = it == breaks.begin() ? 0 : static_cast<std::size_t>(it - breaks.begin()) - 1;
  return angles[std::min(i, angles.size() - 1)];
}

TurningFunction ComputeTurningFunction(const Polyline& polyline) {
  TurningFunction f;
  std::vector<double> lengths;
  for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
    const Point2 d = polyline[i + 1] - polyline[i];
    const double length = d.norm();
    if (length <= 0.0) continue;
    const double direction = std::atan2(d.y(), d.x());
    f.angles.push_back(f.angles.empty() ? direction
                                        : f.angles.back() + NormalizeAngle(direction - f.angles.back()));
    lengths.push_back(length);
    f.length_m += length;
  }
  if (f.angles.empty()) {
    f.breaks = {0.0, 1.0};
    f.angles = {0.0};
    return f;
  }
  f.breaks.push_back(0.0);
  double walked = 0.0;
  for (std::size_t i = 0; i + 1 < lengths.size(); ++i) {
    walked += lengths[i];
    f.breaks.push_back(walked / f.length_m);
  }
  f.breaks.push_back(1.0);
  return f;
}

std::vector<Arc> MaximalArcs(const Polyline& polyline) {
  std::vector<Arc> arcs;
  const int n = static_cast<int>(polyline.size());
  if (n < 2) return arcs;
  Arc current{0, n - 1};
  int sign = 0;
  for (int i = 1; i + 1 < n; ++i) {
    const int s = TurnSign(polyline, static_cast<std::size_t>(i));
    if (s == 0) continue;
    if (sign != 0 && s != sign) {
      arcs.push_back({current.first_vertex, i});
      current.first_vertex = i - 1;
    }
    sign = s;
  }
  arcs.push_back(current);
  return arcs;
}

}  // namespace shape_slam
