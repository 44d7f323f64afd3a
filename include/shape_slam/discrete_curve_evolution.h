// Discrete Curve Evolution (paper §3.1, eq. 1; Latecki & Lakämper).
//
// The least relevant inner vertex is removed, and the relevances of its neighbours updated,
// until the least relevance exceeds the threshold. End points have no relevance and stay.
//
// Units. The relevance K(u, v, w) = |d(u,v) + d(v,w) - d(u,w)| is a length: by how much the
// detour through v is longer than the shortcut, in metres. The paper's thresholds 1.0 / 2.5 /
// 5.0 are not metres (its figures are consistent with centimetre-scale units); we keep metres.
// A vertex deviating by h from the chord between neighbours a and b away has
// K ~ h^2/(2a) + h^2/(2b): range noise (h ~ 1-3 cm) vanishes as its context grows while the
// evolution proceeds, whereas a corner with legs L keeps K ~ (2 - sqrt 2) L for a right angle.
// A 5 cm step in a wall, seen from 1 m on each side, has K ~ 5 cm. Measured on simulated rooms
// scanned with 1 cm range noise (tests/core/discrete_curve_evolution_test.cc, 100 scans of 181
// and 361 beams): at 0.02 m about one scan in two keeps a noise vertex on a straight wall, at
// 0.03 m two in a hundred, from 0.04 m none, and every corner survives up to 0.10 m. The
// default 0.05 m sits in that safe range; the final, pair-wise noise decision is left to S*
// (§4.1), and the alignment uses a far lighter simplification (pipeline.h).
#pragma once

#include <cstdint>
#include <limits>
#include <queue>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

struct DceParams {
  /// Stop threshold on the relevance K of eq. (1), metres: evolution continues while the least
  /// relevance is <= this.
  double threshold_m = 0.05;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// K(u, v, w) = |d(u,v) + d(v,w) - d(u,w)|, eq. (1), metres.
double Relevance(const Point2& u, const Point2& v, const Point2& w);

/// DCE: repeatedly removes the inner vertex of least relevance (ties: the lowest index) while
/// that relevance is <= threshold_m; end points stay. O(n log n). Never adds vertices.
/// Throws std::invalid_argument for a negative or non-finite threshold.
Polyline SimplifyDce(const Polyline& polyline, double threshold_m);

/// DCE as SimplifyDce, but never moving the polyline farther than max_deviation_m from any of
/// its original vertices (see CurveEvolution). Used for map polylines.
Polyline SimplifyDceBounded(const Polyline& polyline, double threshold_m, double max_deviation_m);

/// The same result as SimplifyDce by the naive O(n^2) procedure (the test oracle).
Polyline SimplifyDceNaive(const Polyline& polyline, double threshold_m);

/// Incremental DCE: removes one vertex at a time in the order of eq. (1), so that S* (§4.1) can
/// continue the evolution of a perceived polyline step by step. Copyable (S* tries lookahead
/// steps on a copy).
class CurveEvolution {
 public:
  /// `max_deviation_m` (optional, metres): a vertex may only be removed while every original
  /// vertex between its neighbours stays within this distance of the segment joining them; a
  /// blocked vertex has relevance +infinity. This bound is not in the paper: K alone lets a long
  /// wall lose a gentle bend (a 0.2 m bow over 6 m has K ~ 0.013 m), which is fine for shape
  /// matching but not for a map used for metric alignment.
  explicit CurveEvolution(const Polyline& polyline,
                          double max_deviation_m = std::numeric_limits<double>::infinity());

  int NumVertices() const { return num_alive_; }
  /// True while an inner vertex is left.
  bool CanRemove() const { return num_alive_ > 2; }
  /// Relevance of the vertex RemoveNext() would remove. Precondition: CanRemove().
  double NextRelevance() const;
  /// Removes the least relevant inner vertex. Precondition: CanRemove().
  void RemoveNext();
  /// The remaining vertices, in order.
  Polyline Current() const;
  /// Indices (into the original polyline) of the remaining vertices, in order.
  std::vector<int> CurrentIndices() const;

 private:
  struct Entry {
    double relevance;
    int index;
    std::uint32_t version;
    bool operator>(const Entry& o) const {
      return relevance > o.relevance || (relevance == o.relevance && index > o.index);
    }
  };
  void Push(int index);
  void DropStale();

  double Relevance(int index) const;

  Polyline points_;
  double max_deviation_m_;
  std::vector<int> prev_, next_;
  std::vector<std::uint32_t> version_;
  std::vector<bool> alive_;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap_;
  int num_alive_ = 0;
};

}  // namespace shape_slam
