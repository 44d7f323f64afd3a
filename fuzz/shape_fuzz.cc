// Fuzz target of the shape toolkit (paper §3.1, §4.1): polyline extraction
// (polyline_extraction.h), discrete curve evolution (discrete_curve_evolution.h) and the shape
// similarities S and S* (shape_similarity.h).
//
// Input: two bytes choosing the parameters, then raw IEEE-754 doubles, every bit pattern
// allowed. NaN and inf are not rejected: ExtractPolylines documents how it treats non-finite
// readings, and no other function here documents that it needs finite input.
//   byte 0: bits 0-1 beam layout (180 deg, 270 deg, 360 deg, or (range, angle) pairs),
//           bits 2-3 DCE threshold, bits 4-5 S* lookahead, bits 6-7 min_points
//   byte 1: bits 0-1 max_gap_m, bits 2-3 the scan's max_range_m,
//           bits 4-7 the model polyline D has 1 + these vertices
//   then D's (x, y) pairs, then the scan's readings (or (range, angle) pairs).
// Every extracted polyline is simplified by DCE and compared with D by S and S*.
//
// Crashes, sanitizer reports and uncaught exceptions are findings, and so is a failed check of
// a documented property. Properties of values (S >= 0, SimplifyDce == SimplifyDceNaive...) are
// checked on well-scaled polylines only (finite, |coordinate| <= 1e100), where no length
// overflows and relevances are numbers: with NaN the order of eq. (1) is not defined.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "fuzz_support.h"
#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/geometry.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/shape_similarity.h"
#include "shape_slam/tangent_space.h"
#include "shape_slam/types.h"

namespace shape_slam {
namespace {

using fuzz::Check;

// S costs O(m n (m + n)) arc comparisons and S* repeats it: polylines compared by S and S* are
// cut to this many vertices, so that an input runs in milliseconds.
constexpr std::size_t kMaxSimilarityVertices = 12;
// Extracted polylines compared with the model per input.
constexpr std::size_t kMaxComparedPolylines = 2;
constexpr double kMaxWellScaled = 1e100;

struct FuzzInput {
  LaserScan scan;
  Polyline model;
  ExtractionParams extraction;
  double dce_threshold_m = 0.0;
  EvolvedSimilarityParams similarity;
};

/// Reads raw doubles from the input, front to back.
class DoubleReader {
 public:
  DoubleReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::size_t Remaining() const { return (size_ - offset_) / sizeof(double); }
  double Next() {
    double value = 0.0;
    std::memcpy(&value, data_ + offset_, sizeof(double));
    offset_ += sizeof(double);
    return value;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t offset_ = 0;
};

// Beam directions as the readers produce them: 180 deg (CARMEN FLASER, odd count), 270 deg,
// or a full 360 deg turn whose last beam precedes the first (cyclic order, seam join).
std::vector<double> BeamAngles(std::size_t n, int layout) {
  std::vector<double> angles_rad(n, 0.0);
  const double fov_rad = layout == 0 ? M_PI : layout == 1 ? 1.5 * M_PI : 2.0 * M_PI;
  const double step_rad = layout == 2
                              ? fov_rad / static_cast<double>(std::max<std::size_t>(n, 1))
                              : fov_rad / static_cast<double>(std::max<std::size_t>(n, 2) - 1);
  for (std::size_t i = 0; i < n; ++i) {
    angles_rad[i] = -0.5 * fov_rad + static_cast<double>(i) * step_rad;
  }
  return angles_rad;
}

bool Decode(const std::uint8_t* data, std::size_t size, FuzzInput& in) {
  if (size < 2) return false;
  const std::uint8_t a = data[0], b = data[1];
  constexpr std::array<double, 4> kThresholds_m = {0.0, 0.01, 0.05, 0.5};
  constexpr std::array<double, 4> kGaps_m = {0.05, 0.2, 1.0, 5.0};
  constexpr std::array<double, 4> kMaxRanges_m = {0.0, 8.0, 30.0, 81.83};
  const int layout = a & 3;
  in.dce_threshold_m = kThresholds_m[(a >> 2) & 3];
  in.similarity.lookahead = 1 + ((a >> 4) & 3);
  in.extraction.min_points = 1 + ((a >> 6) & 3);
  in.extraction.max_gap_m = kGaps_m[b & 3];
  in.scan.max_range_m = kMaxRanges_m[(b >> 2) & 3];
  DoubleReader doubles(data + 2, size - 2);
  const std::size_t model_vertices = 1 + (b >> 4);
  if (doubles.Remaining() < 2 * model_vertices) return false;
  for (std::size_t i = 0; i < model_vertices; ++i) {
    const double x = doubles.Next();
    in.model.emplace_back(x, doubles.Next());
  }
  while (doubles.Remaining() >= (layout == 3 ? 2 : 1)) {
    in.scan.ranges_m.push_back(doubles.Next());
    if (layout == 3) in.scan.angles_rad.push_back(doubles.Next());
  }
  if (layout != 3) in.scan.angles_rad = BeamAngles(in.scan.ranges_m.size(), layout);
  return true;
}

bool IsWellScaled(const Polyline& polyline) {
  return std::all_of(polyline.begin(), polyline.end(), [](const Point2& p) {
    return std::isfinite(p.x()) && std::isfinite(p.y()) && std::abs(p.x()) <= kMaxWellScaled &&
           std::abs(p.y()) <= kMaxWellScaled;
  });
}

bool SamePoint(const Point2& p, const Point2& q) {
  return std::memcmp(p.data(), q.data(), 2 * sizeof(double)) == 0;
}

bool SamePolyline(const Polyline& p, const Polyline& q) {
  return p.size() == q.size() && std::equal(p.begin(), p.end(), q.begin(), SamePoint);
}

/// True when `part` is `whole` with some inner vertices removed (ends kept, order kept).
bool IsSimplificationOf(const Polyline& part, const Polyline& whole) {
  if (whole.size() <= 2) return SamePolyline(part, whole);
  if (part.size() < 2 || part.size() > whole.size()) return false;
  if (!SamePoint(part.front(), whole.front()) || !SamePoint(part.back(), whole.back())) {
    return false;
  }
  std::size_t j = 0;
  for (const Point2& p : part) {
    while (j < whole.size() && !SamePoint(whole[j], p)) ++j;
    if (j == whole.size()) return false;
    ++j;
  }
  return true;
}

Polyline Truncated(const Polyline& polyline, std::size_t max_vertices) {
  const auto n = static_cast<std::ptrdiff_t>(std::min(polyline.size(), max_vertices));
  return Polyline(polyline.begin(), polyline.begin() + n);
}

// polyline_extraction.h: groups of consecutive valid beams, split where points are farther
// apart than max_gap_m, dropped below min_points.
void CheckExtraction(const LaserScan& scan, const ExtractionParams& params,
                     const std::vector<Polyline>& polylines) {
  std::size_t points = 0;
  for (const Polyline& polyline : polylines) {
    Check(static_cast<int>(polyline.size()) >= params.min_points, "polylines have min_points");
    points += polyline.size();
    for (std::size_t i = 0; i < polyline.size(); ++i) {
      const Point2& p = polyline[i];
      Check(std::isfinite(p.x()) && std::isfinite(p.y()), "extracted points are finite");
      Check(i == 0 || (p - polyline[i - 1]).norm() <= params.max_gap_m * (1.0 + 1e-12),
            "consecutive points of a polyline are at most max_gap_m apart");
    }
  }
  Check(points <= scan.ranges_m.size(), "at most one point per beam");
}

// discrete_curve_evolution.h: SimplifyDce never adds vertices and keeps the end points; on
// well-scaled input it equals the O(n^2) oracle and stops only when every inner vertex is more
// relevant than the threshold.
void CheckDce(const Polyline& polyline, double threshold_m, const Polyline& simplified) {
  Check(IsSimplificationOf(simplified, polyline), "DCE only removes inner vertices");
  if (!IsWellScaled(polyline)) return;
  Check(SamePolyline(simplified, SimplifyDceNaive(polyline, threshold_m)),
        "SimplifyDce equals SimplifyDceNaive");
  for (std::size_t i = 1; i + 1 < simplified.size(); ++i) {
    Check(Relevance(simplified[i - 1], simplified[i], simplified[i + 1]) > threshold_m,
          "DCE stops only when every inner relevance exceeds the threshold");
  }
}

// SimplifyDceBounded is CurveEvolution with a deviation bound run to the threshold: every
// original vertex stays within max_deviation_m of the segment that replaced it.
void CheckBoundedDce(const Polyline& polyline, double threshold_m, double max_deviation_m) {
  const Polyline bounded = SimplifyDceBounded(polyline, threshold_m, max_deviation_m);
  Check(IsSimplificationOf(bounded, polyline), "bounded DCE only removes inner vertices");
  CurveEvolution evolution(polyline, max_deviation_m);
  while (evolution.CanRemove() && evolution.NextRelevance() <= threshold_m) evolution.RemoveNext();
  Check(SamePolyline(evolution.Current(), bounded), "SimplifyDceBounded is CurveEvolution's");
  if (!IsWellScaled(polyline)) return;
  const std::vector<int> kept = evolution.CurrentIndices();
  const double bound2 = max_deviation_m * max_deviation_m;
  for (std::size_t k = 0; k + 1 < kept.size(); ++k) {
    const Point2 &a = polyline[kept[k]], &b = polyline[kept[k + 1]];
    for (int j = kept[k] + 1; j < kept[k + 1]; ++j) {
      Check(SquaredDistanceToSegment(polyline[j], a, b) <= bound2,
            "bounded DCE keeps removed vertices within max_deviation_m");
    }
  }
}

// CurveEvolution: one vertex per step, the indices increasing with both ends kept.
void CheckCurveEvolution(const Polyline& polyline) {
  CurveEvolution evolution(polyline);
  while (evolution.CanRemove()) {
    const int before = evolution.NumVertices();
    evolution.NextRelevance();
    evolution.RemoveNext();
    Check(evolution.NumVertices() == before - 1, "RemoveNext removes one vertex");
  }
  const std::vector<int> indices = evolution.CurrentIndices();
  Check(static_cast<int>(indices.size()) == evolution.NumVertices() &&
            evolution.Current().size() == indices.size(),
        "Current, CurrentIndices and NumVertices agree");
  Check(polyline.size() > 2 ? indices.size() == 2 : indices.size() == polyline.size(),
        "evolution ends with the two end points");
  Check(indices.empty() ||
            (indices.front() == 0 && indices.back() == static_cast<int>(polyline.size()) - 1),
        "evolution keeps both end points");
}

// The arc count S works with: a polyline without arcs is one empty arc.
int NumArcs(const Polyline& polyline) {
  return std::max<int>(1, static_cast<int>(MaximalArcs(polyline).size()));
}

// shape_similarity.h: the correspondence covers both curves in order, each step pairs one arc
// with one or more consecutive arcs, and the value is the sum of the steps' S_a.
void CheckSimilarity(const Polyline& c, const Polyline& d, const SimilarityResult& s) {
  if (!IsWellScaled(c) || !IsWellScaled(d)) return;
  Check(std::isfinite(s.value) && s.value >= 0.0, "S is finite and >= 0");
  Check(!s.matches.empty(), "S has a correspondence");
  int next_c = 0, next_d = 0;
  double sum = 0.0;
  for (const ArcGroupMatch& m : s.matches) {
    Check(m.c_first_arc == next_c && m.d_first_arc == next_d, "steps follow each other");
    Check(m.c_last_arc >= m.c_first_arc && m.d_last_arc >= m.d_first_arc, "steps are not empty");
    Check(m.c_first_arc == m.c_last_arc || m.d_first_arc == m.d_last_arc,
          "one side of a step is a single arc");
    Check(m.cost >= 0.0, "S_a >= 0");
    sum += m.cost;
    next_c = m.c_last_arc + 1;
    next_d = m.d_last_arc + 1;
  }
  Check(next_c == NumArcs(c) && next_d == NumArcs(d), "the correspondence covers both curves");
  Check(std::abs(sum - s.value) <= 1e-9 * std::max(1.0, s.value), "S is the sum of its steps");
  Check(PolylineSimilarity(c, c).value == 0.0, "S(C, C) = 0");
}

// S*: the lowest S over the evolution of C, starting at S itself.
void CheckEvolvedSimilarity(const Polyline& c, const Polyline& d, const SimilarityResult& s,
                            const EvolvedSimilarity& e) {
  Check(IsSimplificationOf(e.evolved_c, c), "S* evolves C by removing inner vertices");
  Check(e.removed_vertices == static_cast<int>(c.size() - e.evolved_c.size()),
        "removed_vertices counts the removed vertices");
  if (!IsWellScaled(c) || !IsWellScaled(d)) return;
  Check(e.value <= s.value, "S* <= S");
  Check(e.value == e.best.value, "S* is the value of its best stage");
  Check(PolylineSimilarity(e.evolved_c, d).value == e.value, "S* is S of the evolved C");
}

void RunDce(const Polyline& polyline, double threshold_m) {
  CheckDce(polyline, threshold_m, SimplifyDce(polyline, threshold_m));
  CheckBoundedDce(polyline, threshold_m, 0.05);
  CheckCurveEvolution(polyline);
  const double complexity = ShapeComplexity(polyline);
  if (IsWellScaled(polyline)) Check(complexity >= 0.0, "the shape complexity is >= 0");
}

void RunSimilarities(const Polyline& c, const Polyline& d, const EvolvedSimilarityParams& params) {
  const SimilarityResult s = PolylineSimilarity(c, d);
  CheckSimilarity(c, d, s);
  const EvolvedSimilarity e = ComputeEvolvedSimilarity(c, d, params);
  CheckEvolvedSimilarity(c, d, s, e);
  const double arc = ArcSimilarity(c, d);
  if (IsWellScaled(c) && IsWellScaled(d)) Check(arc >= 0.0, "S_a >= 0");
  Reliability(c, d, e.value);
}

}  // namespace
}  // namespace shape_slam

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace shape_slam;
  FuzzInput in;
  if (!Decode(data, size, in)) return 0;
  const std::vector<Polyline> polylines = ExtractPolylines(in.scan, in.extraction);
  CheckExtraction(in.scan, in.extraction, polylines);
  RunDce(in.model, in.dce_threshold_m);
  for (std::size_t i = 0; i < polylines.size(); ++i) {
    RunDce(polylines[i], in.dce_threshold_m);
    if (i >= kMaxComparedPolylines) continue;
    const Polyline perceived =
        Truncated(SimplifyDce(polylines[i], in.dce_threshold_m), kMaxSimilarityVertices);
    RunSimilarities(perceived, in.model, in.similarity);
  }
  RunSimilarities(in.model, in.model, in.similarity);
  return 0;
}
