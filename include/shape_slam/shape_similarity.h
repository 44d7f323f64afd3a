// Shape similarity of polylines (paper §4.1, eq. 2 and 3) and the reliability of a pair of
// corresponding polylines (§4.3, eq. 5).
//
// All measures are dissimilarities: 0 for identical shapes, larger for less similar ones. They
// use shape only: neither the position nor the orientation of the polylines matters.
#pragma once

#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

/// S_a of eq. (2): (1 + (l_C - l_D)^2) * integral over [0,1] of (T_C(s) - T_D(s) + Theta)^2,
/// with the optimal Theta of eq. (3). The minimiser of the integral is
/// Theta = integral (T_D - T_C) ds (the paper's eq. (3) drops the sign), which makes the
/// integral the variance of T_C - T_D. Computed exactly over the merged breakpoints of the two
/// step functions. l is the arc length in metres (the absolute length term of §4.1). A
/// polyline of zero length has the constant turning function 0.
double ArcSimilarity(const Polyline& c, const Polyline& d);

/// One step of the optimal arc correspondence: arcs c_first..c_last of C correspond to arcs
/// d_first..d_last of D (inclusive; one of the two ranges has a single arc).
struct ArcGroupMatch {
  int c_first_arc = 0, c_last_arc = 0;
  int d_first_arc = 0, d_last_arc = 0;
  double cost = 0.0;  ///< S_a of the two groups
};

struct SimilarityResult {
  double value = 0.0;                  ///< S(C, D): lower = more similar, 0 = identical
  std::vector<ArcGroupMatch> matches;  ///< the optimal correspondence, in order
};

/// S(C, D) (§4.1): dynamic programming over the maximal arcs of both curves; every step pairs
/// one arc with one or more consecutive arcs of the other (1-to-1, 1-to-many, many-to-1),
/// covering both curves in order; the value is the sum of S_a over the steps.
/// O(m n (m + n)) arc comparisons for m and n arcs. Throws std::invalid_argument when a
/// polyline is empty.
SimilarityResult PolylineSimilarity(const Polyline& c, const Polyline& d);

struct EvolvedSimilarityParams {
  /// §4.1: evolution continues as long as one of the next `lookahead` removals improves S.
  int lookahead = 3;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

struct EvolvedSimilarity {
  double value = 0.0;      ///< S*(C, D)
  Polyline evolved_c;      ///< the perceived polyline at the best evolution stage
  int removed_vertices = 0;
  SimilarityResult best;   ///< S at that stage, with its correspondence
};

/// S*(C, D) (§4.1): the perceived polyline C is evolved further by DCE while S(C, D) improves;
/// the lowest S reached is S*. Robust to local minima by a lookahead: evolution continues as
/// long as one of the next `lookahead` removals gives a lower S than the best so far.
/// Throws std::invalid_argument when a polyline is empty or the params are invalid.
EvolvedSimilarity ComputeEvolvedSimilarity(const Polyline& perceived, const Polyline& model,
                                           const EvolvedSimilarityParams& params = {});

/// Shape complexity C (§4.3): the sum of the relevances (eq. 1) of the inner vertices; with no
/// inner vertex, half the distance between the end points. Metres; 0 for fewer than 2 vertices.
double ShapeComplexity(const Polyline& polyline);

/// Reliability Q(P, Q) = C(P) + C(Q) - S*(P, Q), eq. (5): high similarity of complex shapes.
double Reliability(const Polyline& p, const Polyline& q, double evolved_similarity);

}  // namespace shape_slam
