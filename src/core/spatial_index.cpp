#include "shape_slam/spatial_index.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "shape_slam/geometry.h"

namespace shape_slam {

SegmentIndex::SegmentIndex(double cell_size_m) : cell_size_m_(cell_size_m) {
  if (!(cell_size_m > 0.0) || !std::isfinite(cell_size_m)) {
    throw std::invalid_argument("SegmentIndex: cell_size_m must be > 0");
  }
}

// Cell coordinates are clamped to the 32 bits a key holds: beyond +-2^31 cells (thousands of
// kilometres) cells merge, which only adds candidates, and the conversion stays defined.
std::int64_t SegmentIndex::Cell(double v) const {
  constexpr double kLimit = 2147483647.0;
  return static_cast<std::int64_t>(std::clamp(std::floor(v / cell_size_m_), -kLimit, kLimit));
}

SegmentIndex::CellKey SegmentIndex::Key(std::int64_t ix, std::int64_t iy) const {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(ix)) << 32) |
         static_cast<std::uint32_t>(iy);
}

// Cells crossed by the segment [a, b] (Amanatides & Woo grid traversal).
std::vector<SegmentIndex::CellKey> SegmentIndex::CellsOfSegment(const Point2& a,
                                                               const Point2& b) const {
  std::int64_t ix = Cell(a.x()), iy = Cell(a.y());
  const std::int64_t ex = Cell(b.x()), ey = Cell(b.y());
  std::vector<CellKey> cells = {Key(ix, iy)};
  const Point2 d = b - a;
  const int sx = d.x() > 0 ? 1 : -1, sy = d.y() > 0 ? 1 : -1;
  auto first_crossing = [&](double start, double delta, std::int64_t cell, int step) {
    if (delta == 0.0) return std::numeric_limits<double>::infinity();
    const double boundary = (cell + (step > 0 ? 1 : 0)) * cell_size_m_;
    return (boundary - start) / delta;
  };
  double t_max_x = first_crossing(a.x(), d.x(), ix, sx);
  double t_max_y = first_crossing(a.y(), d.y(), iy, sy);
  const double t_dx = d.x() == 0.0 ? std::numeric_limits<double>::infinity() : cell_size_m_ / std::abs(d.x());
  const double t_dy = d.y() == 0.0 ? std::numeric_limits<double>::infinity() : cell_size_m_ / std::abs(d.y());
  // Bounded by the cell distance between the end points, so rounding cannot loop forever.
  const std::int64_t steps = std::abs(ex - ix) + std::abs(ey - iy);
  for (std::int64_t k = 0; k < steps && (ix != ex || iy != ey); ++k) {
    if (t_max_x < t_max_y) {
      ix += sx;
      t_max_x += t_dx;
    } else {
      iy += sy;
      t_max_y += t_dy;
    }
    cells.push_back(Key(ix, iy));
  }
  if (ix != ex || iy != ey) cells.push_back(Key(ex, ey));
  return cells;
}

void SegmentIndex::Insert(PolylineId id, const Polyline& polyline) {
  Remove(id);
  Entry entry;
  entry.points = polyline;
  // A one-vertex polyline is entered as one degenerate segment (a point).
  const std::size_t segments = polyline.size() <= 1 ? polyline.size() : polyline.size() - 1;
  for (std::size_t i = 0; i < segments; ++i) {
    const Point2& a = polyline[i];
    const Point2& b = polyline[std::min(i + 1, polyline.size() - 1)];
    if (std::abs(Cell(b.x()) - Cell(a.x())) + std::abs(Cell(b.y()) - Cell(a.y())) >
        kMaxCellsPerSegment) {
      long_segments_.push_back({id, static_cast<std::uint32_t>(i)});
      continue;
    }
    for (const CellKey key : CellsOfSegment(a, b)) {
      std::vector<SegmentRef>& refs = cells_[key];
      const SegmentRef ref{id, static_cast<std::uint32_t>(i)};
      if (refs.empty() || !(refs.back() == ref)) refs.push_back(ref);
      entry.cells.push_back(key);
    }
  }
  std::sort(entry.cells.begin(), entry.cells.end());
  entry.cells.erase(std::unique(entry.cells.begin(), entry.cells.end()), entry.cells.end());
  polylines_[id] = std::move(entry);
}

void SegmentIndex::Remove(PolylineId id) {
  const auto it = polylines_.find(id);
  if (it == polylines_.end()) return;
  long_segments_.erase(std::remove_if(long_segments_.begin(), long_segments_.end(),
                                      [id](const SegmentRef& r) { return r.polyline == id; }),
                       long_segments_.end());
  for (const CellKey key : it->second.cells) {
    const auto cell = cells_.find(key);
    if (cell == cells_.end()) continue;
    std::vector<SegmentRef>& refs = cell->second;
    refs.erase(std::remove_if(refs.begin(), refs.end(),
                              [id](const SegmentRef& r) { return r.polyline == id; }),
               refs.end());
    if (refs.empty()) cells_.erase(cell);
  }
  polylines_.erase(it);
}

void SegmentIndex::Clear() {
  cells_.clear();
  long_segments_.clear();
  polylines_.clear();
}

std::vector<SegmentRef> SegmentIndex::Collect(const Point2& min, const Point2& max) const {
  std::vector<SegmentRef> out;
  if (!(min.x() <= max.x() && min.y() <= max.y())) return out;
  const std::int64_t x0 = Cell(min.x()), x1 = Cell(max.x()), y0 = Cell(min.y()), y1 = Cell(max.y());
  if (static_cast<double>(x1 - x0 + 1) * static_cast<double>(y1 - y0 + 1) >
      static_cast<double>(4 * cells_.size() + 16)) {
    // A query larger than the map: scanning the occupied cells is cheaper.
    for (const auto& [key, refs] : cells_) {
      const auto ix = static_cast<std::int32_t>(key >> 32), iy = static_cast<std::int32_t>(key);
      if (ix >= x0 && ix <= x1 && iy >= y0 && iy <= y1) out.insert(out.end(), refs.begin(), refs.end());
    }
  } else {
    for (std::int64_t ix = x0; ix <= x1; ++ix) {
      for (std::int64_t iy = y0; iy <= y1; ++iy) {
        const auto cell = cells_.find(Key(ix, iy));
        if (cell != cells_.end()) out.insert(out.end(), cell->second.begin(), cell->second.end());
      }
    }
  }
  for (const SegmentRef& ref : long_segments_) {
    if (BoxMeetsSegment(ref, min, max)) out.push_back(ref);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

// Whether the segment's bounding box meets the box (conservative, like the cells).
bool SegmentIndex::BoxMeetsSegment(const SegmentRef& ref, const Point2& min,
                                   const Point2& max) const {
  const Polyline& p = polylines_.at(ref.polyline).points;
  const Point2& a = p[ref.segment];
  const Point2& b = ref.segment + 1 < p.size() ? p[ref.segment + 1] : a;
  return std::min(a.x(), b.x()) <= max.x() && std::max(a.x(), b.x()) >= min.x() &&
         std::min(a.y(), b.y()) <= max.y() && std::max(a.y(), b.y()) >= min.y();
}

std::vector<SegmentRef> SegmentIndex::QueryBox(const Point2& min, const Point2& max) const {
  return Collect(min, max);
}

std::vector<SegmentRef> SegmentIndex::QueryDisc(const Point2& centre, double radius_m) const {
  const Point2 r = Point2::Constant(radius_m);
  std::vector<SegmentRef> refs = Collect(centre - r, centre + r);
  const double r2 = radius_m * radius_m;
  refs.erase(std::remove_if(refs.begin(), refs.end(),
                            [&](const SegmentRef& ref) {
                              const Polyline& p = polylines_.at(ref.polyline).points;
                              const Point2& a = p[ref.segment];
                              const Point2& b = ref.segment + 1 < p.size() ? p[ref.segment + 1] : a;
                              return SquaredDistanceToSegment(centre, a, b) > r2;
                            }),
             refs.end());
  return refs;
}

}  // namespace shape_slam
