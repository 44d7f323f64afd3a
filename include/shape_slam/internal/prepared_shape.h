// Internal (not installed): polylines prepared once for the many shape-similarity queries of the
// correspondence DP (§4.2, eq. 4). Without a pose estimate every scan group is compared with
// every model group, and S* (§4.1) walks each scan group through the same DCE stages whatever
// the model group: the tangent table and the maximal arcs of a polyline, and the DCE stages of a
// perceived one, are made once here instead of once per pair. The values are those of
// PolylineSimilarity and ComputeEvolvedSimilarity (shape_similarity.h) to the bit: the same
// arithmetic in the same order, only done once.
#pragma once

#include <memory>
#include <vector>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/shape_similarity.h"
#include "shape_slam/tangent_space.h"
#include "shape_slam/types.h"

namespace shape_slam::internal {

/// The tangent space of a polyline in a form that compares any run of its segments without
/// allocating: cumulative lengths and unwrapped directions of the non-degenerate segments.
struct SegmentTable {
  std::vector<double> cumulative;  ///< size k + 1
  std::vector<double> angle;       ///< size k
  std::vector<int> first_segment;  ///< per vertex: index of the first segment after it

  explicit SegmentTable(const Polyline& p);
};

/// A non-empty polyline's segment table and the maximal arcs S compares (a polyline with fewer
/// than two vertices is one empty arc).
struct PreparedShape {
  explicit PreparedShape(const Polyline& polyline);

  SegmentTable table;
  std::vector<Arc> arcs;
};

/// S(C, D) of PolylineSimilarity for prepared polylines, the value alone. `dp` is a buffer
/// reused between calls.
double SimilarityValue(const PreparedShape& c, const PreparedShape& d, std::vector<double>& dp);

/// The DCE stages of a perceived polyline (stage 0 the polyline itself, stage k after k
/// removals, to two vertices), each prepared when first asked for.
class EvolutionStages {
 public:
  /// Throws std::invalid_argument when the polyline is empty.
  explicit EvolutionStages(const Polyline& perceived);

  /// Stage k, or nullptr when the evolution ends before it.
  const PreparedShape* Stage(int k);

 private:
  CurveEvolution evolution_;  // at the last prepared stage
  std::vector<std::unique_ptr<PreparedShape>> stages_;
};

/// S*'s walk (§4.1, ComputeEvolvedSimilarity walks the same): the stage (= vertices removed) at
/// which S(C, D) is lowest, and that S in `value`.
int BestEvolutionStage(EvolutionStages& perceived, const PreparedShape& model,
                       const EvolvedSimilarityParams& params, std::vector<double>& dp,
                       double& value);

/// S*(C, D).value of ComputeEvolvedSimilarity, walking `perceived`'s stages.
double EvolvedSimilarityValue(EvolutionStages& perceived, const PreparedShape& model,
                              const EvolvedSimilarityParams& params, std::vector<double>& dp);

}  // namespace shape_slam::internal
