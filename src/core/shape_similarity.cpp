#include "shape_slam/shape_similarity.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/internal/prepared_shape.h"
#include "shape_slam/tangent_space.h"

namespace shape_slam {
namespace {

using internal::PreparedShape;
using internal::SegmentTable;

// A run of segments [begin, end) of a table.
struct Run {
  const SegmentTable* table;
  int begin, end;
  double Length() const { return table->cumulative[end] - table->cumulative[begin]; }
};

// Variance over s in [0,1] of T_C(s) - T_D(s): the integral of eq. (2) at the optimal Theta of
// eq. (3). A run of zero length has the constant turning function 0.
double TangentIntegral(const Run& c, const Run& d) {
  const double lc = c.Length(), ld = d.Length();
  int i = c.begin, j = d.begin;
  double position = 0.0, sum = 0.0, sum2 = 0.0;
  while (position < 1.0) {
    const bool c_flat = lc <= 0.0, d_flat = ld <= 0.0;
    const double end_c = c_flat || i + 1 >= c.end
                             ? 1.0
                             : (c.table->cumulative[i + 1] - c.table->cumulative[c.begin]) / lc;
    const double end_d = d_flat || j + 1 >= d.end
                             ? 1.0
                             : (d.table->cumulative[j + 1] - d.table->cumulative[d.begin]) / ld;
    const double end = std::min(end_c, end_d);
    const double f = (c_flat ? 0.0 : c.table->angle[i]) - (d_flat ? 0.0 : d.table->angle[j]);
    const double w = end - position;
    sum += w * f;
    sum2 += w * f * f;
    position = end;
    if (end_c <= end && !c_flat) ++i;
    if (end_d <= end && !d_flat) ++j;
  }
  return std::max(0.0, sum2 - sum * sum);
}

// S_a of eq. (2) for two runs of segments.
double RunSimilarity(const Run& c, const Run& d) {
  const double dl = c.Length() - d.Length();
  return (1.0 + dl * dl) * TangentIntegral(c, d);
}

// The runs of segments covered by a group of consecutive maximal arcs.
Run ArcRun(const SegmentTable& table, const std::vector<Arc>& arcs, int first, int last) {
  return {&table, table.first_segment[arcs[first].first_vertex],
          table.first_segment[arcs[last].last_vertex]};
}

void CheckNotEmpty(const Polyline& c, const Polyline& d) {
  if (c.empty() || d.empty()) throw std::invalid_argument("shape similarity of an empty polyline");
}

// The arc decomposition used by S: a polyline with fewer than two vertices is one empty arc.
std::vector<Arc> ArcsForSimilarity(const Polyline& p) {
  std::vector<Arc> arcs = MaximalArcs(p);
  if (arcs.empty()) arcs.push_back({0, 0});
  return arcs;
}

// The DP of S(C, D) over the maximal arcs of both prepared polylines (PolylineSimilarity); the
// correspondence into `matches` when given. `dp` is a reused buffer.
double SimilarityDp(const PreparedShape& c, const PreparedShape& d, std::vector<double>& dp,
                    std::vector<ArcGroupMatch>* matches) {
  const SegmentTable& tc = c.table;
  const SegmentTable& td = d.table;
  const std::vector<Arc>& ac = c.arcs;
  const std::vector<Arc>& ad = d.arcs;
  const int m = static_cast<int>(ac.size()), n = static_cast<int>(ad.size());
  constexpr double kInf = std::numeric_limits<double>::infinity();
  dp.assign(static_cast<std::size_t>(m + 1) * (n + 1), kInf);
  std::vector<ArcGroupMatch> step(matches != nullptr ? dp.size() : 0);
  auto cell = [n](int i, int j) { return static_cast<std::size_t>(i) * (n + 1) + j; };
  dp[0] = 0.0;
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < n; ++j) {
      const double here = dp[cell(i, j)];
      if (here == kInf) continue;
      auto relax = [&](int ci, int cl, int di, int dl) {
        const double cost = RunSimilarity(ArcRun(tc, ac, ci, cl), ArcRun(td, ad, di, dl));
        double& target = dp[cell(cl + 1, dl + 1)];
        if (here + cost < target) {
          target = here + cost;
          if (matches != nullptr) step[cell(cl + 1, dl + 1)] = {ci, cl, di, dl, cost};
        }
      };
      for (int k = j; k < n; ++k) relax(i, i, j, k);      // 1-to-1 and 1-to-many
      for (int k = i + 1; k < m; ++k) relax(i, k, j, j);  // many-to-1
    }
  }
  if (matches != nullptr) {
    for (int i = m, j = n; i > 0 && j > 0;) {
      const ArcGroupMatch s = step[cell(i, j)];
      matches->push_back(s);
      i = s.c_first_arc;
      j = s.d_first_arc;
    }
    std::reverse(matches->begin(), matches->end());
  }
  return dp[cell(m, n)];
}

}  // namespace

void EvolvedSimilarityParams::Validate() const {
  if (lookahead < 1) throw std::invalid_argument("EvolvedSimilarityParams::lookahead must be >= 1");
}

double ArcSimilarity(const Polyline& c, const Polyline& d) {
  CheckNotEmpty(c, d);
  const SegmentTable tc(c), td(d);
  return RunSimilarity({&tc, 0, static_cast<int>(tc.angle.size())},
                       {&td, 0, static_cast<int>(td.angle.size())});
}

SimilarityResult PolylineSimilarity(const Polyline& c, const Polyline& d) {
  CheckNotEmpty(c, d);
  SimilarityResult result;
  std::vector<double> dp;
  result.value = SimilarityDp(PreparedShape(c), PreparedShape(d), dp, &result.matches);
  return result;
}

EvolvedSimilarity ComputeEvolvedSimilarity(const Polyline& perceived, const Polyline& model,
                                           const EvolvedSimilarityParams& params) {
  params.Validate();
  CheckNotEmpty(perceived, model);
  internal::EvolutionStages stages(perceived);
  std::vector<double> dp;
  EvolvedSimilarity best;
  best.removed_vertices =
      internal::BestEvolutionStage(stages, PreparedShape(model), params, dp, best.value);
  CurveEvolution evolution(perceived);  // the stages' evolution, replayed to the best one
  for (int k = 0; k < best.removed_vertices; ++k) evolution.RemoveNext();
  best.evolved_c = evolution.Current();
  best.best = PolylineSimilarity(best.evolved_c, model);  // its value is best.value
  return best;
}

double ShapeComplexity(const Polyline& polyline) {
  if (polyline.size() < 2) return 0.0;
  if (polyline.size() == 2) return 0.5 * (polyline.back() - polyline.front()).norm();
  double complexity = 0.0;
  for (std::size_t i = 1; i + 1 < polyline.size(); ++i) {
    complexity += Relevance(polyline[i - 1], polyline[i], polyline[i + 1]);
  }
  return complexity;
}

double Reliability(const Polyline& p, const Polyline& q, double evolved_similarity) {
  return ShapeComplexity(p) + ShapeComplexity(q) - evolved_similarity;  // Eq. (5)
}

namespace internal {

SegmentTable::SegmentTable(const Polyline& p) : first_segment(p.size(), 0) {
  cumulative.push_back(0.0);
  for (std::size_t i = 0; i + 1 < p.size(); ++i) {
    first_segment[i] = static_cast<int>(angle.size());
    const Point2 d = p[i + 1] - p[i];
    const double length = d.norm();
    if (length <= 0.0) continue;
    const double direction = std::atan2(d.y(), d.x());
    angle.push_back(angle.empty() ? direction : angle.back() + NormalizeAngle(direction - angle.back()));
    cumulative.push_back(cumulative.back() + length);
  }
  if (!p.empty()) first_segment.back() = static_cast<int>(angle.size());
}

PreparedShape::PreparedShape(const Polyline& polyline)
    : table(polyline), arcs(ArcsForSimilarity(polyline)) {}

double SimilarityValue(const PreparedShape& c, const PreparedShape& d, std::vector<double>& dp) {
  return SimilarityDp(c, d, dp, nullptr);
}

EvolutionStages::EvolutionStages(const Polyline& perceived) : evolution_(perceived) {
  CheckNotEmpty(perceived, perceived);
  stages_.push_back(std::make_unique<PreparedShape>(perceived));
}

const PreparedShape* EvolutionStages::Stage(int k) {
  while (static_cast<int>(stages_.size()) <= k) {
    if (!evolution_.CanRemove()) return nullptr;
    evolution_.RemoveNext();
    stages_.push_back(std::make_unique<PreparedShape>(evolution_.Current()));
  }
  return stages_[static_cast<std::size_t>(k)].get();
}

// S*'s walk over the stages (§4.1): from the best stage so far, the next `lookahead` stages in
// turn; the first that lowers S becomes the best, and the walk goes on from there.
int BestEvolutionStage(EvolutionStages& perceived, const PreparedShape& model,
                       const EvolvedSimilarityParams& params, std::vector<double>& dp,
                       double& value) {
  params.Validate();
  value = SimilarityValue(*perceived.Stage(0), model, dp);
  int at = 0;
  for (bool improved = true; improved;) {
    improved = false;
    for (int k = 1; k <= params.lookahead; ++k) {
      const PreparedShape* stage = perceived.Stage(at + k);
      if (stage == nullptr) break;
      const double v = SimilarityValue(*stage, model, dp);
      if (v < value) {
        value = v;
        at += k;
        improved = true;
        break;
      }
    }
  }
  return at;
}

double EvolvedSimilarityValue(EvolutionStages& perceived, const PreparedShape& model,
                              const EvolvedSimilarityParams& params, std::vector<double>& dp) {
  double value = 0.0;
  BestEvolutionStage(perceived, model, params, dp, value);
  return value;
}

}  // namespace internal

}  // namespace shape_slam
