#include "shape_slam/polyline_correspondence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>

namespace shape_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Memoised group costs: every (scan group, model group) is evaluated at most once, whatever the
// number of model rotations tried. NaN marks "not evaluated yet", +inf a forbidden pair.
class CostCache {
 public:
  CostCache(const CorrespondenceProblem& problem, int num_scan, int num_model)
      : problem_(problem),
        num_model_(num_model),
        g_(problem.max_group_size),
        values_(static_cast<std::size_t>(num_scan) * num_model * g_ * g_,
                std::numeric_limits<double>::quiet_NaN()) {}

  double Get(int scan_first, int scan_count, int model_first, int model_count) {
    const std::size_t key =
        ((static_cast<std::size_t>(scan_first) * num_model_ + model_first) * g_ + scan_count - 1) *
            g_ +
        model_count - 1;
    double& value = values_[key];
    if (std::isnan(value)) {
      const std::optional<double> cost =
          problem_.group_cost(scan_first, scan_count, model_first, model_count);
      value = cost && std::isfinite(*cost) ? *cost : kInf;
      if (value < 0.0) negative_ = true;
    }
    return value;
  }

  /// Whether a group cost below 0 came up (then no rotation may be abandoned early).
  bool SawNegative() const { return negative_; }

 private:
  const CorrespondenceProblem& problem_;
  int num_model_;
  int g_;
  std::vector<double> values_;
  bool negative_ = false;
};

// What the optimal step into a DP cell was.
struct Step {
  int scan_count = 0;   // 0 with model_count 1: skip a model polyline
  int model_count = 0;  // 0 with scan_count 1: skip a scan polyline
  bool match = false;
};

// One DP over a fixed model rotation: dp[i][k] = least cost of the first i scan polylines and
// the first k model polylines of the rotated order.
CorrespondenceSolution SolveRotation(const CorrespondenceProblem& problem, CostCache& cache,
                                     int rotation) {
  const int a = static_cast<int>(problem.scan_skip_penalty.size());
  const int b = static_cast<int>(problem.model_skip_penalty.size());
  const int g = problem.max_group_size;
  const int w = b + 1;
  std::vector<double> dp(static_cast<std::size_t>(a + 1) * w, kInf);
  std::vector<Step> from(dp.size());
  dp[0] = 0.0;
  auto relax = [&](int i, int k, double cost, Step step) {
    double& cell = dp[static_cast<std::size_t>(i) * w + k];
    if (cost < cell) {
      cell = cost;
      from[static_cast<std::size_t>(i) * w + k] = step;
    }
  };
  for (int i = 0; i <= a; ++i) {
    for (int k = 0; k <= b; ++k) {
      const double here = dp[static_cast<std::size_t>(i) * w + k];
      if (here == kInf) continue;
      if (i < a) relax(i + 1, k, here + problem.scan_skip_penalty[i], {1, 0, false});
      if (k < b) {
        relax(i, k + 1, here + problem.model_skip_penalty[(rotation + k) % b], {0, 1, false});
      }
      for (int gs = 1; gs <= g && i + gs <= a; ++gs) {
        for (int gm = 1; gm <= g && k + gm <= b; ++gm) {
          if (gs > 1 && gm > 1) break;  // only 1-to-1, 1-to-many and many-to-1
          const double cost = cache.Get(i, gs, (rotation + k) % b, gm);
          if (cost < kInf) relax(i + gs, k + gm, here + cost, {gs, gm, true});
        }
      }
    }
  }
  CorrespondenceSolution solution;
  solution.total_cost = dp.back();
  solution.model_rotation = rotation;
  for (int i = a, k = b; i > 0 || k > 0;) {
    const Step step = from[static_cast<std::size_t>(i) * w + k];
    i -= step.scan_count;
    k -= step.model_count;
    if (step.match) {
      const double cost = cache.Get(i, step.scan_count, (rotation + k) % b, step.model_count);
      solution.matches.push_back({i, step.scan_count, (rotation + k) % b, step.model_count, cost});
    }
  }
  std::reverse(solution.matches.begin(), solution.matches.end());
  return solution;
}

// The least cost of one model rotation (the same DP as SolveRotation, same order of operations,
// so the same value), without the steps. With non-negative costs a path's cost is at least that
// of its last cell in the g rows before any row, so the rotation is abandoned (+inf) as soon as
// those rows hold nothing below `bound`. `dp` and `row_min` are reused buffers.
double RotationCost(const CorrespondenceProblem& problem, CostCache& cache, int rotation,
                    double bound, std::vector<double>& dp, std::vector<double>& row_min) {
  const int a = static_cast<int>(problem.scan_skip_penalty.size());
  const int b = static_cast<int>(problem.model_skip_penalty.size());
  const int g = problem.max_group_size;
  const int w = b + 1;
  dp.assign(static_cast<std::size_t>(a + 1) * w, kInf);
  row_min.assign(a + 1, kInf);
  dp[0] = 0.0;
  for (int i = 0; i <= a; ++i) {
    if (i > 0 && bound < kInf) {
      double lower = kInf;
      for (int r = std::max(0, i - g); r < i; ++r) lower = std::min(lower, row_min[r]);
      if (lower >= bound) return kInf;
    }
    double* row = &dp[static_cast<std::size_t>(i) * w];
    for (int k = 0; k <= b; ++k) {
      const double here = row[k];
      if (here == kInf) continue;
      row_min[i] = std::min(row_min[i], here);
      if (i < a) {
        double& cell = dp[static_cast<std::size_t>(i + 1) * w + k];
        cell = std::min(cell, here + problem.scan_skip_penalty[i]);
      }
      const int model = rotation + k < b ? rotation + k : rotation + k - b;
      if (k < b) row[k + 1] = std::min(row[k + 1], here + problem.model_skip_penalty[model]);
      for (int gs = 1; gs <= g && i + gs <= a; ++gs) {
        for (int gm = 1; gm <= g && k + gm <= b; ++gm) {
          if (gs > 1 && gm > 1) break;  // only 1-to-1, 1-to-many and many-to-1
          const double cost = cache.Get(i, gs, model, gm);
          if (cost < kInf) {
            double& cell = dp[static_cast<std::size_t>(i + gs) * w + k + gm];
            cell = std::min(cell, here + cost);
          }
        }
      }
    }
  }
  return dp.back();
}

}  // namespace

CorrespondenceSolution SolveCorrespondence(const CorrespondenceProblem& problem) {
  if (!problem.group_cost) throw std::invalid_argument("SolveCorrespondence: group_cost is empty");
  if (problem.max_group_size < 1) {
    throw std::invalid_argument("SolveCorrespondence: max_group_size must be >= 1");
  }
  const int a = static_cast<int>(problem.scan_skip_penalty.size());
  const int b = static_cast<int>(problem.model_skip_penalty.size());
  if (a == 0 || b == 0) {
    CorrespondenceSolution none;
    none.total_cost = std::accumulate(problem.scan_skip_penalty.begin(),
                                      problem.scan_skip_penalty.end(), 0.0) +
                      std::accumulate(problem.model_skip_penalty.begin(),
                                      problem.model_skip_penalty.end(), 0.0);
    return none;
  }
  CostCache cache(problem, a, b);
  std::vector<int> rotations = {0};
  if (problem.model_cyclic) {
    rotations = problem.model_rotations;
    if (rotations.empty()) {
      rotations.resize(b);
      std::iota(rotations.begin(), rotations.end(), 0);
    }
  }
  for (const int r : rotations) {
    if (r < 0 || r >= b) throw std::invalid_argument("SolveCorrespondence: rotation out of range");
  }
  if (rotations.size() == 1) return SolveRotation(problem, cache, rotations.front());
  // The least cost of every rotation first (the first of equal ones wins), early abandoning
  // those that cannot beat the best so far; then the steps of the best alone.
  const auto negative = [](double v) { return v < 0.0; };
  const bool may_abandon =
      std::none_of(problem.scan_skip_penalty.begin(), problem.scan_skip_penalty.end(), negative) &&
      std::none_of(problem.model_skip_penalty.begin(), problem.model_skip_penalty.end(), negative);
  std::vector<double> dp, row_min;
  const auto best_rotation = [&](bool abandon) {
    int best = rotations.front();
    double best_cost = kInf;
    bool first = true;
    for (const int r : rotations) {
      const double cost = RotationCost(problem, cache, r, abandon ? best_cost : kInf, dp, row_min);
      if (first || cost < best_cost) best = r, best_cost = cost;
      first = false;
    }
    return best;
  };
  int best = best_rotation(may_abandon);
  if (may_abandon && cache.SawNegative()) best = best_rotation(false);  // no bound holds then
  return SolveRotation(problem, cache, best);
}

}  // namespace shape_slam
