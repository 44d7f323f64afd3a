#include "shape_slam/internal/model_segments.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace shape_slam::internal {
namespace {

// The polyline without consecutive duplicate vertices.
Polyline WithoutDuplicates(const Polyline& polyline) {
  Polyline out;
  out.reserve(polyline.size());
  for (const Point2& p : polyline) {
    if (out.empty() || p != out.back()) out.push_back(p);
  }
  return out;
}

ModelSegment MakeSegment(const Point2& a, const Point2& b, bool open_start, bool open_end) {
  ModelSegment s;
  s.a = a;
  s.ab = b - a;
  const double length2 = s.ab.squaredNorm();
  s.inv_length2 = length2 > 0.0 ? 1.0 / length2 : 0.0;
  s.open_start = open_start;
  s.open_end = open_end;
  return s;
}

// Index of the cell containing coordinate `x` along an axis starting at `origin`, clamped to
// [0, n - 1]. `x` is finite and within the grid's padded bounds.
int ClampedCell(double x, double origin, double cell, int n) {
  const double f = std::floor((x - origin) / cell);
  return static_cast<int>(std::clamp(f, 0.0, static_cast<double>(n - 1)));
}

}  // namespace

std::vector<ModelSegment> MakeModelSegments(const std::vector<Polyline>& polylines) {
  std::vector<ModelSegment> segments;
  for (const Polyline& polyline : polylines) {
    const Polyline v = WithoutDuplicates(polyline);
    if (v.size() == 1) segments.push_back(MakeSegment(v[0], v[0], false, false));
    for (std::size_t i = 0; i + 1 < v.size(); ++i) {
      segments.push_back(MakeSegment(v[i], v[i + 1], i == 0, i + 2 == v.size()));
    }
  }
  return segments;
}

SegmentGrid::SegmentGrid(std::vector<ModelSegment> segments, double radius_m)
    : segments_(std::move(segments)), radius_m_(radius_m) {
  if (!std::isfinite(radius_m) || radius_m <= 0.0) {
    throw std::invalid_argument("SegmentGrid: radius_m must be finite and > 0");
  }
  if (segments_.empty()) return;
  Point2 lo = segments_.front().a, hi = lo;
  for (const ModelSegment& s : segments_) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b());
    hi = hi.cwiseMax(s.a).cwiseMax(s.b());
  }
  const Point2 extent = hi - lo;
  cell_m_ = std::max(radius_m, extent.maxCoeff() / (kMaxCellsPerSide - 1));
  origin_ = lo;
  nx_ = std::min(kMaxCellsPerSide, static_cast<int>(extent.x() / cell_m_) + 1);
  ny_ = std::min(kMaxCellsPerSide, static_cast<int>(extent.y() / cell_m_) + 1);
  Fill();
}

// Lists every segment in the cells it crosses, column by column: within a column the segment
// spans an interval of y, hence a run of cells. A small epsilon keeps the listing conservative
// for segments running along cell borders.
void SegmentGrid::Fill() {
  const double eps = 1e-9 * cell_m_;
  auto for_each_cell = [&](const ModelSegment& s, auto&& visit) {
    const Point2 b = s.b();
    const double x_lo = std::min(s.a.x(), b.x()), x_hi = std::max(s.a.x(), b.x());
    const double y_min = std::min(s.a.y(), b.y()), y_max = std::max(s.a.y(), b.y());
    const int ix0 = ClampedCell(x_lo - eps, origin_.x(), cell_m_, nx_);
    const int ix1 = ClampedCell(x_hi + eps, origin_.x(), cell_m_, nx_);
    for (int ix = ix0; ix <= ix1; ++ix) {
      double y0 = y_min, y1 = y_max;
      if (s.ab.x() != 0.0) {
        const double c0 = std::max(x_lo, origin_.x() + ix * cell_m_ - eps);
        const double c1 = std::min(x_hi, origin_.x() + (ix + 1) * cell_m_ + eps);
        const double slope = s.ab.y() / s.ab.x();
        const double ya = s.a.y() + (c0 - s.a.x()) * slope, yb = s.a.y() + (c1 - s.a.x()) * slope;
        y0 = std::clamp(std::min(ya, yb), y_min, y_max);
        y1 = std::clamp(std::max(ya, yb), y_min, y_max);
      }
      const int iy0 = ClampedCell(y0 - eps, origin_.y(), cell_m_, ny_);
      const int iy1 = ClampedCell(y1 + eps, origin_.y(), cell_m_, ny_);
      for (int iy = iy0; iy <= iy1; ++iy) visit(CellIndex(ix, iy));
    }
  };
  cell_begin_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  for (const ModelSegment& s : segments_) for_each_cell(s, [&](int c) { ++cell_begin_[c + 1]; });
  for (std::size_t c = 1; c < cell_begin_.size(); ++c) cell_begin_[c] += cell_begin_[c - 1];
  cell_segments_.resize(cell_begin_.back());
  std::vector<int> next(cell_begin_.begin(), cell_begin_.end() - 1);
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    for_each_cell(segments_[i], [&](int c) { cell_segments_[next[c]++] = static_cast<int>(i); });
  }
}

// The query's own cell first, then the neighbours that could still hold a segment at least as
// near as the best so far (their rectangle within that distance and within the radius): near a
// wall the own cell usually settles it. A segment is listed in every cell it crosses, so its
// nearest point lies in a cell no farther than itself: the result is that of scanning all nine.
SegmentMatch SegmentGrid::Nearest(const Point2& p) const {
  if (segments_.empty()) return SegmentMatch{};
  const double fx = std::floor((p.x() - origin_.x()) / cell_m_);
  const double fy = std::floor((p.y() - origin_.y()) / cell_m_);
  // Outside the grid by more than a cell: no segment can be within the radius.
  if (!(fx >= -1.0 && fx <= nx_ && fy >= -1.0 && fy <= ny_)) return SegmentMatch{};
  const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
  const double radius2 = radius_m_ * radius_m_;
  SegmentMatch best;
  const auto scan_cell = [&](int ix, int iy) {
    const int c = CellIndex(ix, iy);
    for (int k = cell_begin_[c]; k < cell_begin_[c + 1]; ++k) {
      const int i = cell_segments_[k];
      const SegmentMatch m = MatchSegment(p, segments_[i], i);
      if (m.squared_distance < best.squared_distance ||
          (m.squared_distance == best.squared_distance && i < best.segment)) {
        best = m;
      }
    }
  };
  const bool inside = cx >= 0 && cx < nx_ && cy >= 0 && cy < ny_;
  if (inside) scan_cell(cx, cy);
  for (int iy = std::max(cy - 1, 0); iy <= std::min(cy + 1, ny_ - 1); ++iy) {
    for (int ix = std::max(cx - 1, 0); ix <= std::min(cx + 1, nx_ - 1); ++ix) {
      if (inside && ix == cx && iy == cy) continue;
      const double x0 = origin_.x() + ix * cell_m_, y0 = origin_.y() + iy * cell_m_;
      const double dx = std::max({0.0, x0 - p.x(), p.x() - (x0 + cell_m_)});
      const double dy = std::max({0.0, y0 - p.y(), p.y() - (y0 + cell_m_)});
      const double d2 = dx * dx + dy * dy;
      if (d2 > best.squared_distance || d2 > radius2) continue;
      scan_cell(ix, iy);
    }
  }
  if (best.squared_distance > radius2) return SegmentMatch{};
  return best;
}

void CheckFinite(const Polyline& points, const char* what) {
  for (const Point2& p : points) {
    if (!p.allFinite()) throw std::invalid_argument(std::string(what) + ": non-finite coordinate");
  }
}

void CheckFinite(const Pose2& pose, const char* what) {
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.theta)) {
    throw std::invalid_argument(std::string(what) + ": non-finite pose");
  }
}

RestrictedProblem MakeRestrictedProblem(const std::vector<ShapePair>& pairs, double spacing_m) {
  RestrictedProblem problem;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const ShapePair& pair = pairs[i];
    if (!std::isfinite(pair.weight) || pair.weight < 0.0) {
      throw std::invalid_argument("ShapePair::weight must be finite and >= 0 (pair " +
                                  std::to_string(i) + ")");
    }
    CheckFinite(pair.perceived, "ShapePair::perceived");
    for (const Polyline& model : pair.model) CheckFinite(model, "ShapePair::model");
    if (pair.weight == 0.0) continue;
    const std::size_t begin = problem.segments.size();
    const std::vector<ModelSegment> segments = MakeModelSegments(pair.model);
    if (segments.empty()) continue;
    problem.segments.insert(problem.segments.end(), segments.begin(), segments.end());
    for (const Point2& p : SamplePolyline(pair.perceived, spacing_m)) {
      problem.samples.push_back({p, pair.weight, begin, problem.segments.size()});
    }
  }
  return problem;
}

}  // namespace shape_slam::internal
