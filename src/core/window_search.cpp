#include "shape_slam/window_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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

  BuildPyramid(LikelihoodField(segments, reach_m));
}

// The likelihood field over the grid (level 0): 255 on a polyline, falling off as a Gaussian
// of hit_sigma_m within reach_m of it.
std::vector<std::uint8_t> WindowSearch::LikelihoodField(
    const std::vector<internal::ModelSegment>& segments, double reach_m) const {
  std::vector<std::uint8_t> field(static_cast<std::size_t>(nx_) * ny_, 0);
  const double inv_two_sigma2 = 1.0 / (2.0 * params_.hit_sigma_m * params_.hit_sigma_m);
  // The squared distance beyond which a segment cannot raise a cell holding c (its value would
  // round to c or less), with a margin for rounding: the exp is skipped there (same field).
  std::array<double, 256> raises_within{};
  for (int c = 0; c < 255; ++c) {
    raises_within[c] = std::log(255.0 / (c + 0.5)) / inv_two_sigma2 * (1.0 + 1e-6) + 1e-12;
  }
  raises_within[255] = -1.0;
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
        std::uint8_t& cell = field[static_cast<std::size_t>(iy) * nx_ + ix];
        const double d2 = internal::MatchSegment(centre, s, static_cast<int>(k)).squared_distance;
        if (d2 > raises_within[cell]) continue;
        const auto value = static_cast<std::uint8_t>(std::lround(255.0 * std::exp(-d2 * inv_two_sigma2)));
        cell = std::max(cell, value);
      }
    }
  }
  return field;
}

// Level 0 is the field; level k the maximum over the 2^k x 2^k cells from (ix, iy) up, so that
// its value bounds every translation of a node 2^k cells wide. Cells past the grid count 0; the
// maximum is taken along x, then along y (the same maximum, in loops the compiler vectorises).
void WindowSearch::BuildPyramid(std::vector<std::uint8_t> field) {
  pyramid_.push_back(std::move(field));
  const std::size_t w = static_cast<std::size_t>(nx_);
  std::vector<std::uint8_t> along_x(pyramid_.back().size());
  for (int level = 1; level < levels_; ++level) {
    const std::size_t half = std::size_t{1} << (level - 1);
    const std::vector<std::uint8_t>& below = pyramid_.back();
    const std::size_t inner = half < w ? w - half : 0;
    for (std::size_t row = 0; row < below.size(); row += w) {
      const std::uint8_t* b = below.data() + row;
      std::uint8_t* out = along_x.data() + row;
      for (std::size_t ix = 0; ix < inner; ++ix) out[ix] = std::max(b[ix], b[ix + half]);
      for (std::size_t ix = inner; ix < w; ++ix) out[ix] = b[ix];
    }
    std::vector<std::uint8_t> up(below.size());
    const std::size_t shift = half * w;
    const std::size_t rows_inner = shift < along_x.size() ? along_x.size() - shift : 0;
    for (std::size_t k = 0; k < rows_inner; ++k) up[k] = std::max(along_x[k], along_x[k + shift]);
    for (std::size_t k = rows_inner; k < along_x.size(); ++k) up[k] = along_x[k];
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
    return PosesWithin(h.T_model_scan, pose, params.distinct_m, params.distinct_rad);
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

namespace {

// Adds a hypothesis to distinct ones kept best first: dropped when a better one lies within
// distinct_m and distinct_rad of it, else it replaces the worse ones there; at most
// max_hypotheses are kept.
void AddDistinct(const WindowHypothesis& h, const WindowSearchParams& params,
                 std::vector<WindowHypothesis>& found) {
  const auto near = [&](const WindowHypothesis& f) {
    return PosesWithin(f.T_model_scan, h.T_model_scan, params.distinct_m, params.distinct_rad);
  };
  for (const WindowHypothesis& f : found) {
    if (near(f) && f.score >= h.score) return;
  }
  found.erase(std::remove_if(found.begin(), found.end(), near), found.end());
  found.insert(std::upper_bound(found.begin(), found.end(), h,
                                [](const WindowHypothesis& a, const WindowHypothesis& b) {
                                  return a.score > b.score;
                                }),
               h);
  if (static_cast<int>(found.size()) > params.max_hypotheses) found.pop_back();
}

}  // namespace

WindowSearch::Scorer::Scorer(const WindowSearch& search, const std::vector<Point2>& samples_scan,
                             const Pose2& centre, const CellRange& range, double half_window_rad)
    : search_(search), centre_(centre), range_(range),
      n_(static_cast<int>(samples_scan.size())) {
  const WindowSearchParams& params = search.params_;
  double range_m = 1.0;
  for (const Point2& p : samples_scan) range_m = std::max(range_m, p.norm());
  range_m = std::min(range_m, std::max(1.0, params.max_step_range_m));
  step_rad_ = search.resolution_m_ / range_m;
  const bool full_turn = half_window_rad >= M_PI;
  half_rotations_ = static_cast<int>(std::ceil(std::min(half_window_rad, M_PI) / step_rad_));
  rotations_ = full_turn ? 2 * half_rotations_ : 2 * half_rotations_ + 1;
  cells_ = search.RotatedCells(samples_scan, centre, rotations_, half_rotations_, step_rad_);
  offsets_.resize(cells_.size() / 2);
  boxes_.assign(rotations_, {std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                             std::numeric_limits<int>::min(), std::numeric_limits<int>::min()});
  for (int r = 0; r < rotations_; ++r) {
    std::array<int, 4>& box = boxes_[r];
    for (int i = 0; i < n_; ++i) {
      const std::size_t k = static_cast<std::size_t>(r) * n_ + i;
      const int ix = cells_[2 * k], iy = cells_[2 * k + 1];
      offsets_[k] = static_cast<long>(iy) * search.nx_ + ix;
      box = {std::min(box[0], ix), std::min(box[1], iy), std::max(box[2], ix), std::max(box[3], iy)};
    }
  }
  rotation_penalty_.resize(rotations_);
  for (int r = 0; r < rotations_; ++r) {
    const double e = (r - half_rotations_) * step_rad_ / params.prior_sigma_rad;
    rotation_penalty_[r] = params.prior_weight * e * e;
  }
  cell_penalty_ = params.prior_weight * std::pow(search.resolution_m_ / params.prior_sigma_m, 2);
  to_score_ = 1.0 / (255.0 * n_);
}

// Upper bound of the score of every pose of the node (exact at level 0).
float WindowSearch::Scorer::Bound(int r, int level, int tx, int ty) const {
  ++evaluations;
  long sum = 0;
  const std::array<int, 4>& box = boxes_[r];
  if (box[0] + tx >= 0 && box[1] + ty >= 0 && box[2] + tx < search_.nx_ && box[3] + ty < search_.ny_) {
    const std::uint8_t* grid = search_.pyramid_[level].data() + static_cast<long>(ty) * search_.nx_ + tx;
    const long* offsets = &offsets_[static_cast<std::size_t>(r) * n_];
    for (int i = 0; i < n_; ++i) sum += grid[offsets[i]];
  } else {
    const int* rc = &cells_[static_cast<std::size_t>(r) * n_ * 2];
    for (int i = 0; i < n_; ++i) sum += search_.LevelValue(level, rc[2 * i] + tx, rc[2 * i + 1] + ty);
  }
  const int w = 1 << level;
  const int gx = GapToZero(tx, std::min(tx + w - 1, range_.x1));
  const int gy = GapToZero(ty, std::min(ty + w - 1, range_.y1));
  return static_cast<float>(sum * to_score_ - rotation_penalty_[r] - cell_penalty_ * (gx * gx + gy * gy));
}

std::priority_queue<WindowSearch::Node> WindowSearch::Scorer::TopNodes() const {
  const int top = search_.levels_ - 1;
  std::priority_queue<Node> queue;
  for (int r = 0; r < rotations_; ++r) {
    for (int tx = range_.x0; tx <= range_.x1; tx += 1 << top) {
      for (int ty = range_.y0; ty <= range_.y1; ty += 1 << top) queue.push({Bound(r, top, tx, ty), r, top, tx, ty});
    }
  }
  return queue;
}

int WindowSearch::Scorer::Children(const Node& node, Node* out) const {
  int count = 0;
  const int half = 1 << (node.level - 1);
  for (const int dx : {0, half}) {
    for (const int dy : {0, half}) {
      if (node.tx + dx > range_.x1 || node.ty + dy > range_.y1) continue;
      out[count++] = {Bound(node.rotation, node.level - 1, node.tx + dx, node.ty + dy), node.rotation,
                      node.level - 1, node.tx + dx, node.ty + dy};
    }
  }
  return count;
}

WindowHypothesis WindowSearch::Scorer::Leaf(const Node& node) const {
  const double dtheta = (node.rotation - half_rotations_) * step_rad_;
  const Pose2 pose(centre_.x + node.tx * search_.resolution_m_, centre_.y + node.ty * search_.resolution_m_,
                   NormalizeAngle(centre_.theta + dtheta));
  const double penalty =
      rotation_penalty_[node.rotation] + cell_penalty_ * (node.tx * node.tx + node.ty * node.ty);
  return {pose, node.bound, node.bound + penalty};
}

std::vector<WindowHypothesis> WindowSearch::Search(const std::vector<Point2>& samples_scan,
                                                   const Pose2& T_model_scan_centre) const {
  return Search(samples_scan, T_model_scan_centre, params_.half_window_m, params_.half_window_rad);
}

std::vector<WindowHypothesis> WindowSearch::Search(const std::vector<Point2>& samples_scan,
                                                   const Pose2& T_model_scan_centre,
                                                   double half_window_m,
                                                   double half_window_rad) const {
  if (samples_scan.empty() || pyramid_.empty()) return {};
  const int c = static_cast<int>(std::ceil(half_window_m / resolution_m_));
  const Scorer scorer(*this, samples_scan, T_model_scan_centre, {-c, c, -c, c},
                      half_window_rad);
  std::vector<WindowHypothesis> found;
  std::priority_queue<Node> queue = scorer.TopNodes();
  while (!queue.empty() && scorer.evaluations < params_.max_node_evaluations) {
    const Node node = queue.top();
    queue.pop();
    if (!found.empty() && node.bound < params_.min_relative_score * found.front().score) break;
    if (node.level > 0) {
      std::array<Node, 4> children;
      const int count = scorer.Children(node, children.data());
      for (int i = 0; i < count; ++i) queue.push(children[i]);
      continue;
    }
    const WindowHypothesis leaf = scorer.Leaf(node);
    if (SameAsBetter(found, leaf.T_model_scan, params_)) continue;
    found.push_back(leaf);
    if (static_cast<int>(found.size()) >= params_.max_hypotheses) break;
  }
  return found;
}

// Every translation of the field (its lower-left corner is the centre, offsets 0 .. n - 1
// cells), all turns. Best first, but each node taken from the queue is followed down to a leaf
// along its best child (its siblings queued), so that leaves, and with them a bound to cut by,
// come early even when the top nodes of a large map all bound high; the search ends when no
// queued node can beat the max_hypotheses-th best distinct leaf, or at the work bound.
std::vector<WindowHypothesis> WindowSearch::SearchMap(const std::vector<Point2>& samples_scan) const {
  if (samples_scan.empty() || pyramid_.empty()) return {};
  const Scorer scorer(*this, samples_scan, Pose2(origin_.x(), origin_.y(), 0.0),
                      {0, nx_ - 1, 0, ny_ - 1}, M_PI);
  std::vector<WindowHypothesis> found;  // best first, distinct
  const auto kth_best = [&] {
    return static_cast<int>(found.size()) >= params_.max_hypotheses
               ? found[params_.max_hypotheses - 1].score
               : -std::numeric_limits<double>::infinity();
  };
  std::priority_queue<Node> queue = scorer.TopNodes();
  while (!queue.empty() && scorer.evaluations < params_.max_node_evaluations) {
    Node node = queue.top();
    queue.pop();
    if (node.bound <= kth_best()) break;
    while (node.level > 0) {
      std::array<Node, 4> children;
      const int count = scorer.Children(node, children.data());
      if (count == 0) break;
      const auto best = std::max_element(children.begin(), children.begin() + count);
      for (auto it = children.begin(); it != children.begin() + count; ++it) {
        if (it != best && it->bound > kth_best()) queue.push(*it);
      }
      node = *best;
    }
    if (node.level > 0 || node.bound <= kth_best()) continue;
    AddDistinct(scorer.Leaf(node), params_, found);
  }
  return found;
}

}  // namespace shape_slam
