#include "shape_slam/orientation_histogram.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace shape_slam {

void OrientationHistogramParams::Validate() const {
  const auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("OrientationHistogramParams::") + name +
                                  " must be > 0");
    }
  };
  positive(bin_rad, "bin_rad");
  positive(max_turn_rad, "max_turn_rad");
  if (bin_rad > M_PI / 8.0 || max_turn_rad >= M_PI / 2.0) {
    throw std::invalid_argument(
        "OrientationHistogramParams: bin_rad must be <= pi/8 and max_turn_rad < pi/2");
  }
}

OrientationHistogram ComputeOrientationHistogram(const std::vector<Polyline>& polylines,
                                                 const OrientationHistogramParams& params) {
  params.Validate();
  const int n = static_cast<int>(std::ceil(M_PI / params.bin_rad));
  std::vector<double> raw(n, 0.0);
  OrientationHistogram out;
  for (const Polyline& polyline : polylines) {
    for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
      const Point2 d = polyline[i + 1] - polyline[i];
      const double length = d.norm();
      if (!(length > 0.0) || !std::isfinite(length)) continue;
      double direction = std::atan2(d.y(), d.x());
      if (direction < 0.0) direction += M_PI;  // undirected: [0, pi)
      if (direction >= M_PI) direction -= M_PI;  // atan2 gives pi for (-x, +0)
      const int bin = std::min(n - 1, static_cast<int>(direction / M_PI * n));
      raw[bin] += length;
      out.total_m += length;
    }
  }
  out.bins.assign(n, 0.0);
  for (int k = 0; k < n; ++k) {
    out.bins[k] = 0.25 * raw[(k + n - 1) % n] + 0.5 * raw[k] + 0.25 * raw[(k + 1) % n];
  }
  return out;
}

std::optional<double> HistogramTurn(const OrientationHistogram& before,
                                    const OrientationHistogram& after,
                                    const OrientationHistogramParams& params) {
  params.Validate();
  const int n = static_cast<int>(before.bins.size());
  if (n == 0 || after.bins.size() != before.bins.size() || !(before.total_m > 0.0) ||
      !(after.total_m > 0.0)) {
    return std::nullopt;
  }
  const double bin = M_PI / n;
  const int reach = std::min(n / 2 - 1, static_cast<int>(params.max_turn_rad / bin));
  // c(s) = sum over k of before[k] * after[k - s]: after sees before's directions less the turn.
  const auto correlation = [&](int s) {
    double c = 0.0;
    for (int k = 0; k < n; ++k) c += before.bins[k] * after.bins[((k - s) % n + n) % n];
    return c;
  };
  std::vector<double> c(2 * reach + 3);
  for (int s = -reach - 1; s <= reach + 1; ++s) c[s + reach + 1] = correlation(s);
  int best = -reach;
  for (int s = -reach; s <= reach; ++s) {
    if (c[s + reach + 1] > c[best + reach + 1]) best = s;
  }
  const double y0 = c[best + reach], y1 = c[best + reach + 1], y2 = c[best + reach + 2];
  const double curvature = y0 - 2.0 * y1 + y2;
  const double offset = curvature < 0.0 ? std::clamp(0.5 * (y0 - y2) / curvature, -0.5, 0.5) : 0.0;
  return (best + offset) * bin;
}

}  // namespace shape_slam
