#include "shape_slam/discrete_curve_evolution.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

void CheckThreshold(double threshold_m) {
  if (!(threshold_m >= 0.0) || !std::isfinite(threshold_m)) {
    throw std::invalid_argument("DCE threshold must be a finite value >= 0 (metres)");
  }
}

}  // namespace

void DceParams::Validate() const {
  if (!(threshold_m >= 0.0) || !std::isfinite(threshold_m)) {
    throw std::invalid_argument("DceParams::threshold_m must be >= 0");
  }
}

double Relevance(const Point2& u, const Point2& v, const Point2& w) {
  return std::abs((v - u).norm() + (w - v).norm() - (w - u).norm());  // Eq. (1)
}

CurveEvolution::CurveEvolution(const Polyline& polyline, double max_deviation_m)
    : points_(polyline),
      max_deviation_m_(max_deviation_m),
      prev_(polyline.size()),
      next_(polyline.size()),
      version_(polyline.size(), 0),
      alive_(polyline.size(), true),
      num_alive_(static_cast<int>(polyline.size())) {
  const int n = num_alive_;
  for (int i = 0; i < n; ++i) {
    prev_[i] = i - 1;
    next_[i] = i + 1;
  }
  for (int i = 1; i + 1 < n; ++i) Push(i);
}

double CurveEvolution::Relevance(int index) const {
  const Point2& u = points_[prev_[index]];
  const Point2& w = points_[next_[index]];
  if (std::isfinite(max_deviation_m_)) {
    const double bound2 = max_deviation_m_ * max_deviation_m_;
    for (int k = prev_[index] + 1; k < next_[index]; ++k) {
      if (SquaredDistanceToSegment(points_[k], u, w) > bound2) {
        return std::numeric_limits<double>::infinity();
      }
    }
  }
  return shape_slam::Relevance(u, points_[index], w);
}

void CurveEvolution::Push(int index) { heap_.push({Relevance(index), index, version_[index]}); }

// Pops heap entries of removed vertices or outdated relevances, so that top() is current.
void CurveEvolution::DropStale() {
  while (!heap_.empty()) {
    const Entry& top = heap_.top();
    if (alive_[top.index] && top.version == version_[top.index]) return;
    heap_.pop();
  }
}

double CurveEvolution::NextRelevance() const {
  if (!CanRemove()) throw std::logic_error("CurveEvolution: no inner vertex left");
  return heap_.top().relevance;
}

void CurveEvolution::RemoveNext() {
  if (!CanRemove()) throw std::logic_error("CurveEvolution: no inner vertex left");
  const int v = heap_.top().index;
  heap_.pop();
  alive_[v] = false;
  --num_alive_;
  const int u = prev_[v], w = next_[v];
  next_[u] = w;
  prev_[w] = u;
  // The neighbours' contexts changed (footnote 4): refresh their relevances.
  for (const int neighbour : {u, w}) {
    if (prev_[neighbour] >= 0 && next_[neighbour] < static_cast<int>(points_.size())) {
      ++version_[neighbour];
      Push(neighbour);
    }
  }
  DropStale();
}

Polyline CurveEvolution::Current() const {
  Polyline out;
  out.reserve(num_alive_);
  for (int i = points_.empty() ? -1 : 0; i >= 0 && i < static_cast<int>(points_.size()); i = next_[i]) {
    out.push_back(points_[i]);
  }
  return out;
}

std::vector<int> CurveEvolution::CurrentIndices() const {
  std::vector<int> out;
  out.reserve(num_alive_);
  for (int i = points_.empty() ? -1 : 0; i >= 0 && i < static_cast<int>(points_.size()); i = next_[i]) {
    out.push_back(i);
  }
  return out;
}

Polyline SimplifyDce(const Polyline& polyline, double threshold_m) {
  CheckThreshold(threshold_m);
  CurveEvolution evolution(polyline);
  while (evolution.CanRemove() && evolution.NextRelevance() <= threshold_m) evolution.RemoveNext();
  return evolution.Current();
}

Polyline SimplifyDceBounded(const Polyline& polyline, double threshold_m, double max_deviation_m) {
  CheckThreshold(threshold_m);
  if (!(max_deviation_m >= 0.0)) {
    throw std::invalid_argument("SimplifyDceBounded: max_deviation_m must be >= 0");
  }
  CurveEvolution evolution(polyline, max_deviation_m);
  while (evolution.CanRemove() && evolution.NextRelevance() <= threshold_m) evolution.RemoveNext();
  return evolution.Current();
}

Polyline SimplifyDceNaive(const Polyline& polyline, double threshold_m) {
  CheckThreshold(threshold_m);
  std::vector<int> kept(polyline.size());
  for (std::size_t i = 0; i < kept.size(); ++i) kept[i] = static_cast<int>(i);
  while (kept.size() > 2) {
    double least = std::numeric_limits<double>::infinity();
    std::size_t at = 0;
    for (std::size_t k = 1; k + 1 < kept.size(); ++k) {
      const double r = Relevance(polyline[kept[k - 1]], polyline[kept[k]], polyline[kept[k + 1]]);
      if (r < least) least = r, at = k;  // strict: ties keep the lowest index
    }
    if (least > threshold_m) break;
    kept.erase(kept.begin() + static_cast<std::ptrdiff_t>(at));
  }
  Polyline out;
  for (const int i : kept) out.push_back(polyline[i]);
  return out;
}

}  // namespace shape_slam
