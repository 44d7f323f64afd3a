#include "shape_slam/window_search.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <stdexcept>
#include <string>

#include "shape_slam/internal/model_segments.h"

namespace shape_slam {
namespace {

void Positive(double value, const char* name) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("WindowSearchParams::") + name + " must be > 0");
  }
}

// Smallest level K with 2^K >= the number of translation cells per side of the window.
int LevelsFor(int half_window_cells) {
  int levels = 1;
  while ((1 << (levels - 1)) < 2 * half_window_cells + 1) ++levels;
  return levels;
}

// Distance from 0 to the integer interval [a, b], in cells.
int GapToZero(int a, int b) { return a > 0 ? a : (b < 0 ? -b : 0); }

}  // namespace

void WindowSearchParams::Validate() const {
  Positive(resolution_m, "resolution_m");
  Positive(hit_sigma_m, "hit_sigma_m");
  Positive(half_window_m, "half_window_m");
  Positive(half_window_rad, "half_window_rad");
  Positive(max_step_range_m, "max_step_range_m");
  Positive(distinct_m, "distinct_m");
  Positive(distinct_rad, "distinct_rad");
  Positive(prior_sigma_m, "prior_sigma_m");
  Positive(prior_sigma_rad, "prior_sigma_rad");
  if (!(prior_weight >= 0.0) || !std::isfinite(prior_weight)) {
    throw std::invalid_argument("WindowSearchParams::prior_weight must be >= 0");
  }
  if (!(min_relative_score >= 0.0 && min_relative_score <= 1.0)) {
    throw std::invalid_argument("WindowSearchParams::min_relative_score must be in [0, 1]");
  }
  if (max_hypotheses < 1) throw std::invalid_argument("WindowSearchParams::max_hypotheses must be >= 1");
  if (max_node_evaluations < 1) {
    throw std::invalid_argument("WindowSearchParams::max_node_evaluations must be >= 1");
  }
  if (max_cells_per_side < 16) {
    throw std::invalid_argument("WindowSearchParams::max_cells_per_side must be >= 16");
  }
}

struct WindowSearch::Node {
  float bound = 0.0f;  // upper bound of the score of every pose of the node
  int rotation = 0;
  int level = 0;
  int tx = 0, ty = 0;  // lowest translation offset of the node, cells
  bool operator<(const Node& other) const { return bound < other.bound; }
};

WindowSearch::WindowSearch(const std::vector<Polyline>& model, const WindowSearchParams& params)
    : params_(params), resolution_m_(params.resolution_m) {
  params_.Validate();
  for (const Polyline& p : model) internal::CheckFinite(p, "WindowSearch model polyline");
  const std::vector<internal::ModelSegment> segments = internal::MakeModelSegments(model);
  if (segments.empty()) return;
  Point2 lo = Point2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const internal::ModelSegment& s : segments) {
    lo = lo.cwiseMin(s.a).cwiseMin(s.b());
    hi = hi.cwiseMax(s.a).cwiseMax(s.b());
  }
  const double reach_m = 3.0 * params_.hit_sigma_m;
  levels_ = LevelsFor(static_cast<int>(std::ceil(params_.half_window_m / resolution_m_)));
  const int pad = 1 << (levels_ - 1);  // zero cells below the field: see LevelValue
  const double extent_m = (hi - lo).maxCoeff() + 2.0 * reach_m;
  const int usable = std::max(8, params_.max_cells_per_side - 2 * pad - 1);
  resolution_m_ = std::max(resolution_m_, extent_m / usable);
  origin_ = lo - Point2::Constant(reach_m + pad * resolution_m_);
  nx_ = static_cast<int>(std::ceil((hi.x() - origin_.x() + reach_m) / resolution_m_)) + pad;
  ny_ = static_cast<int>(std::ceil((hi.y() - origin_.y() + reach_m) / resolution_m_)) + pad;

  // Level 0: the likelihood field, 255 on a polyline.
  std::vector<std::uint8_t> field(static_cast<std::size_t>(nx_) * ny_, 0);
  const double inv_two_sigma2 = 1.0 / (2.0 * params_.hit_sigma_m * params_.hit_sigma_m);
  for (std::size_t k = 0; k < segments.size(); ++k) {
    const internal::ModelSegment& s = segments[k];
    const Point2 smin = s.a.cwiseMin(s.b()) - Point2::Constant(reach_m);
    const Point2 smax = s.a.cwiseMax(s.b()) + Point2::Constant(reach_m);
    const int x0 = std::max(0, static_cast<int>(std::floor((smin.x() - origin_.x()) / resolution_m_)));
    const int y0 = std::max(0, static_cast<int>(std::floor((smin.y() - origin_.y()) / resolution_m_)));
    const int x1 = std::min(nx_ - 1, static_cast<int>(std::floor((smax.x() - origin_.x()) / resolution_m_)));
    const int y1 = std::min(ny_ - 1, static_cast<int>(std::floor((smax.y() - origin_.y()) / resolution_m_)));
    for (int iy = y0; iy <= y1; ++iy) {
      for (int ix = x0; ix <= x1; ++ix) {
        const Point2 centre = origin_ + resolution_m_ * Point2(ix + 0.5, iy + 0.5);
        const double d2 = internal::MatchSegment(centre, s, static_cast<int>(k)).squared_distance;
        const auto value = static_cast<std::uint8_t>(std::lround(255.0 * std::exp(-d2 * inv_two_sigma2)));
        std::uint8_t& cell = field[static_cast<std::size_t>(iy) * nx_ + ix];
        cell = std::max(cell, value);
      }
    }
  }
  // Level k: the maximum over the 2^k x 2^k cells from (ix, iy) up, so that its value bounds
  // every translation of a node 2^k cells wide.
  pyramid_.push_back(std::move(field));
  for (int level = 1; level < levels_; ++level) {
    const int half = 1 << (level - 1);
    const std::vector<std::uint8_t>& below = pyramid_.back();
    std::vector<std::uint8_t> up(below.size(), 0);
    auto at = [&](int ix, int iy) -> std::uint8_t {
      return ix < nx_ && iy < ny_ ? below[static_cast<std::size_t>(iy) * nx_ + ix] : 0;
    };
    for (int iy = 0; iy < ny_; ++iy) {
      for (int ix = 0; ix < nx_; ++ix) {
        up[static_cast<std::size_t>(iy) * nx_ + ix] =
            std::max({at(ix, iy), at(ix + half, iy), at(ix, iy + half), at(ix + half, iy + half)});
      }
    }
    pyramid_.push_back(std::move(up));
  }
}

// Cells outside the grid are 0. Below the grid this is exact for every level: the field has
// 2^(levels - 1) zero cells of padding there, wider than any node.
int WindowSearch::LevelValue(int level, int ix, int iy) const {
  if (ix < 0 || iy < 0 || ix >= nx_ || iy >= ny_) return 0;
  return pyramid_[level][static_cast<std::size_t>(iy) * nx_ + ix];
}

double WindowSearch::Fit(const std::vector<Point2>& samples_scan, const Pose2& T_model_scan) const {
  if (samples_scan.empty() || pyramid_.empty()) return 0.0;
  const PointTransform transform(T_model_scan);
  long sum = 0;
  for (const Point2& p : samples_scan) {
    const Point2 c = (transform(p) - origin_) / resolution_m_;
    sum += LevelValue(0, static_cast<int>(std::floor(c.x())), static_cast<int>(std::floor(c.y())));
  }
  return static_cast<double>(sum) / (255.0 * samples_scan.size());
}

namespace {

// Whether a pose lies within distinct_m and distinct_rad of a hypothesis already found.
bool SameAsBetter(const std::vector<WindowHypothesis>& found, const Pose2& pose,
                  const WindowSearchParams& params) {
  return std::any_of(found.begin(), found.end(), [&](const WindowHypothesis& h) {
    return (h.T_model_scan.Translation() - pose.Translation()).norm() < params.distinct_m &&
           std::abs(NormalizeAngle(h.T_model_scan.theta - pose.theta)) < params.distinct_rad;
  });
}

}  // namespace

// The samples' cells (x, y interleaved, rotation-major) at every rotation step around the
// centre, the centre translation included.
std::vector<int> WindowSearch::RotatedCells(const std::vector<Point2>& samples_scan,
                                            const Pose2& centre, int rotations,
                                            int half_rotations, double step_rad) const {
  const std::size_t n = samples_scan.size();
  std::vector<int> cells(static_cast<std::size_t>(rotations) * n * 2);
  for (int r = 0; r < rotations; ++r) {
    const double dtheta = (r - half_rotations) * step_rad;
    const PointTransform transform(Pose2(centre.x, centre.y, centre.theta + dtheta));
    for (std::size_t i = 0; i < n; ++i) {
      const Point2 q = (transform(samples_scan[i]) - origin_) / resolution_m_;
      cells[(r * n + i) * 2] = static_cast<int>(std::floor(q.x()));
      cells[(r * n + i) * 2 + 1] = static_cast<int>(std::floor(q.y()));
    }
  }
  return cells;
}

std::vector<WindowHypothesis> WindowSearch::Search(const std::vector<Point2>& samples_scan,
                                                   const Pose2& T_model_scan_centre) const {
  std::vector<WindowHypothesis> found;
  if (samples_scan.empty() || pyramid_.empty()) return found;
  const int n = static_cast<int>(samples_scan.size());
  double range_m = 1.0;
  for (const Point2& p : samples_scan) range_m = std::max(range_m, p.norm());
  range_m = std::min(range_m, std::max(1.0, params_.max_step_range_m));
  const double step_rad = resolution_m_ / range_m;
  const bool full_turn = params_.half_window_rad >= M_PI;
  const int half_rotations =
      static_cast<int>(std::ceil(std::min(params_.half_window_rad, M_PI) / step_rad));
  const int rotations = full_turn ? 2 * half_rotations : 2 * half_rotations + 1;
  const int c = static_cast<int>(std::ceil(params_.half_window_m / resolution_m_));
  const int top = levels_ - 1;

  const std::vector<int> cells =
      RotatedCells(samples_scan, T_model_scan_centre, rotations, half_rotations, step_rad);
  std::vector<double> rotation_penalty(rotations);
  for (int r = 0; r < rotations; ++r) {
    const double e = (r - half_rotations) * step_rad / params_.prior_sigma_rad;
    rotation_penalty[r] = params_.prior_weight * e * e;
  }
  const double cell_penalty = params_.prior_weight * std::pow(resolution_m_ / params_.prior_sigma_m, 2);
  const double to_score = 1.0 / (255.0 * n);
  int evaluations = 0;
  auto bound = [&](int r, int level, int tx, int ty) {
    ++evaluations;
    const int* rc = &cells[static_cast<std::size_t>(r) * n * 2];
    long sum = 0;
    for (int i = 0; i < n; ++i) sum += LevelValue(level, rc[2 * i] + tx, rc[2 * i + 1] + ty);
    const int w = 1 << level;
    const int gx = GapToZero(tx, std::min(tx + w - 1, c)), gy = GapToZero(ty, std::min(ty + w - 1, c));
    return static_cast<float>(sum * to_score - rotation_penalty[r] - cell_penalty * (gx * gx + gy * gy));
  };

  std::priority_queue<Node> queue;
  for (int r = 0; r < rotations; ++r) {
    for (int tx = -c; tx <= c; tx += 1 << top) {
      for (int ty = -c; ty <= c; ty += 1 << top) queue.push({bound(r, top, tx, ty), r, top, tx, ty});
    }
  }
  while (!queue.empty() && evaluations < params_.max_node_evaluations) {
    const Node node = queue.top();
    queue.pop();
    if (!found.empty() && node.bound < params_.min_relative_score * found.front().score) break;
    if (node.level > 0) {
      const int half = 1 << (node.level - 1);
      for (const int dx : {0, half}) {
        for (const int dy : {0, half}) {
          if (node.tx + dx > c || node.ty + dy > c) continue;
          queue.push({bound(node.rotation, node.level - 1, node.tx + dx, node.ty + dy),
                      node.rotation, node.level - 1, node.tx + dx, node.ty + dy});
        }
      }
      continue;
    }
    const double dtheta = (node.rotation - half_rotations) * step_rad;
    const Pose2 pose(T_model_scan_centre.x + node.tx * resolution_m_,
                     T_model_scan_centre.y + node.ty * resolution_m_,
                     NormalizeAngle(T_model_scan_centre.theta + dtheta));
    if (SameAsBetter(found, pose, params_)) continue;
    const double penalty =
        rotation_penalty[node.rotation] + cell_penalty * (node.tx * node.tx + node.ty * node.ty);
    found.push_back({pose, node.bound, node.bound + penalty});
    if (static_cast<int>(found.size()) >= params_.max_hypotheses) break;
  }
  return found;
}

}  // namespace shape_slam
