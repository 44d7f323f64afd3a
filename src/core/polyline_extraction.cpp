#include "shape_slam/polyline_extraction.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace shape_slam {
namespace {

bool IsValidReading(double range_m, double angle_rad, const LaserScan& scan,
                    const ExtractionParams& params) {
  return std::isfinite(range_m) && std::isfinite(angle_rad) && range_m > params.min_range_m &&
         (scan.max_range_m <= 0.0 || range_m < scan.max_range_m);
}

bool CoversFullCircle(const LaserScan& scan) {
  const std::size_t n = scan.angles_rad.size();
  if (n < 2) return false;
  const double span = std::abs(scan.angles_rad.back() - scan.angles_rad.front());
  return span + span / (n - 1) >= 2.0 * M_PI - 1e-6;
}

// A group of consecutive valid beams [first, last] and their points.
struct Group {
  std::size_t first_beam = 0, last_beam = 0;
  Polyline points;
};

std::vector<Group> GroupPoints(const LaserScan& scan, const ExtractionParams& params) {
  std::vector<Group> groups;
  bool open = false;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    const double r = scan.ranges_m[i];
    if (!IsValidReading(r, scan.angles_rad[i], scan, params)) {
      open = false;
      continue;
    }
    const Point2 p(r * std::cos(scan.angles_rad[i]), r * std::sin(scan.angles_rad[i]));
    double max_gap = params.max_gap_m;
    if (open) {  // the previous beam was valid and is the last point
      const double spacing = std::min(r, scan.ranges_m[i - 1]) *
                             std::abs(scan.angles_rad[i] - scan.angles_rad[i - 1]);
      max_gap = std::max(max_gap, params.gap_beam_spacing_factor * spacing);
    }
    if (!open || (p - groups.back().points.back()).squaredNorm() > max_gap * max_gap) {
      groups.push_back({i, i, {}});
      open = true;
    }
    groups.back().points.push_back(p);
    groups.back().last_beam = i;
  }
  return groups;
}

// 360 deg scans: the last group continues into the first when they meet at the seam.
void JoinAcrossSeam(const LaserScan& scan, const ExtractionParams& params,
                    std::vector<Group>& groups) {
  if (groups.size() < 2 || !CoversFullCircle(scan)) return;
  Group& first = groups.front();
  Group& last = groups.back();
  const bool at_seam = first.first_beam == 0 && last.last_beam + 1 == scan.ranges_m.size();
  if (!at_seam || (last.points.back() - first.points.front()).norm() > params.max_gap_m) return;
  last.points.insert(last.points.end(), first.points.begin(), first.points.end());
  groups.erase(groups.begin());
}

}  // namespace

void ExtractionParams::Validate() const {
  if (!(max_gap_m > 0.0) || !std::isfinite(max_gap_m)) {
    throw std::invalid_argument("ExtractionParams::max_gap_m must be > 0");
  }
  if (!(min_range_m >= 0.0) || !std::isfinite(min_range_m)) {
    throw std::invalid_argument("ExtractionParams::min_range_m must be >= 0");
  }
  if (min_points < 1) throw std::invalid_argument("ExtractionParams::min_points must be >= 1");
  if (!(gap_beam_spacing_factor >= 0.0) || !std::isfinite(gap_beam_spacing_factor)) {
    throw std::invalid_argument("ExtractionParams::gap_beam_spacing_factor must be >= 0");
  }
}

std::vector<Polyline> ExtractPolylines(const LaserScan& scan, const ExtractionParams& params) {
  params.Validate();
  if (scan.ranges_m.size() != scan.angles_rad.size()) {
    throw std::invalid_argument("ExtractPolylines: " + std::to_string(scan.ranges_m.size()) +
                                " ranges but " + std::to_string(scan.angles_rad.size()) +
                                " angles");
  }
  std::vector<Group> groups = GroupPoints(scan, params);
  JoinAcrossSeam(scan, params, groups);
  std::vector<Polyline> polylines;
  for (Group& g : groups) {
    if (static_cast<int>(g.points.size()) >= params.min_points) {
      polylines.push_back(std::move(g.points));
    }
  }
  return polylines;
}

LaserScan CounterClockwiseScan(const LaserScan& scan) {
  if (scan.angles_rad.size() < 2 || scan.angles_rad.front() <= scan.angles_rad.back()) return scan;
  LaserScan ccw = scan;
  std::reverse(ccw.ranges_m.begin(), ccw.ranges_m.end());
  std::reverse(ccw.angles_rad.begin(), ccw.angles_rad.end());
  return ccw;
}

}  // namespace shape_slam
