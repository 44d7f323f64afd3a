// Correspondence of two ordered vectors of polylines (paper §4.2, eq. 4).
//
// The scan's polylines A_1..A_a and the map's visible polylines B_1..B_b are both ordered
// counter-clockwise around the viewpoint. A correspondence pairs groups of neighbouring
// polylines (1-to-1, 1-to-many, many-to-1), preserves the order, and may leave polylines
// unmatched. Eq. (4) asks for the correspondence minimising
//   sum over pairs (S* + D)  +  sum over unmatched polylines P,
// which this file solves by dynamic programming for any pair cost and skip penalties (the shape
// matcher supplies S* + D and P; see shape_matcher.h). Separating the combinatorial part from
// the costs keeps it testable against brute-force enumeration.
#pragma once

#include <functional>
#include <optional>
#include <vector>

namespace shape_slam {

/// One group of consecutive scan polylines matched with one group of consecutive model
/// polylines; one of the two groups has a single member (§4.2 and footnote 6).
struct GroupMatch {
  int scan_first = 0;   ///< index of the first scan polyline of the group
  int scan_count = 1;   ///< number of scan polylines in the group
  int model_first = 0;  ///< index of the first model polyline (groups may wrap when cyclic)
  int model_count = 1;  ///< number of model polylines in the group
  double cost = 0.0;    ///< the pair cost (S* + D) of this group match

  /// Index of the k-th model polyline of the group, taking a cyclic wrap into account.
  int ModelIndex(int k, int num_model) const { return (model_first + k) % num_model; }
};

/// Cost of matching scan[scan_first, +scan_count) with model[model_first, +model_count)
/// (model indices taken modulo the model size when cyclic); std::nullopt forbids the pair.
using GroupCostFunction =
    std::function<std::optional<double>(int scan_first, int scan_count, int model_first,
                                        int model_count)>;

struct CorrespondenceProblem {
  std::vector<double> scan_skip_penalty;   ///< P(A_i) for every scan polyline
  std::vector<double> model_skip_penalty;  ///< P(B_j) for every model polyline
  GroupCostFunction group_cost;            ///< S* + D of a group pair
  /// When true the model order is cyclic (its start is unknown, e.g. a 360 deg view or no pose
  /// estimate): every rotation of the model sequence is tried and groups may wrap around.
  bool model_cyclic = false;
  /// With a cyclic model: the rotations (index of the model polyline the order starts at) to
  /// try; empty tries all of them. A pose estimate tells where the order starts, so a caller
  /// with one can restrict the search to a few rotations.
  std::vector<int> model_rotations;
  /// Largest group on either side (1 disables groupings).
  int max_group_size = 3;
};

struct CorrespondenceSolution {
  std::vector<GroupMatch> matches;  ///< in scan order
  double total_cost = 0.0;          ///< the minimum of eq. (4)
  int model_rotation = 0;           ///< index of the model polyline the order started at
};

/// Minimises eq. (4) by dynamic programming. Linear orders: O(a * b * g^2) cost evaluations and
/// O(a * b * g) steps for a scan of a polylines, a model of b and groups up to g; a cyclic model
/// multiplies the steps (not the cost evaluations, which are cached) by b, i.e. O(n^3) as in
/// §4.2; with non-negative costs (eq. 4's are) a rotation is abandoned once it cannot beat the
/// best so far, which leaves the result unchanged. Ties are broken deterministically (the first
/// rotation of least cost). Throws std::invalid_argument on a missing cost
/// function or a group size < 1.
CorrespondenceSolution SolveCorrespondence(const CorrespondenceProblem& problem);

}  // namespace shape_slam
