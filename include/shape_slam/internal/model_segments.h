// Internal (not installed): model segments prepared for the many nearest-segment queries of the
// alignment (§5.1) and its refinement, shared by alignment.cpp and alignment_refinement.cpp.
//
// A query returns the nearest point of a set of segments and whether that point lies beyond an
// open end of its polyline (the projection falls before the first vertex or after the last one).
// The alignment ignores such samples by default: when the map has seen only part of a wall that
// the scan sees further, the extra samples would otherwise pull the scan back towards the end of
// the known part (the boundary rejection of Turk & Levoy's zippering, standard in ICP).
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include "shape_slam/alignment.h"
#include "shape_slam/types.h"

namespace shape_slam::internal {

/// One segment [a, a + ab] of a model polyline, map frame. A one-vertex polyline (or one whose
/// vertices all coincide) becomes a single point: ab = 0 and inv_length2 = 0.
struct ModelSegment {
  Point2 a = Point2::Zero();   ///< start vertex, metres
  Point2 ab = Point2::Zero();  ///< end minus start, metres
  double inv_length2 = 0.0;    ///< 1 / |ab|^2, 1/m^2; 0 for a point
  bool open_start = false;     ///< `a` is the first vertex of its polyline
  bool open_end = false;       ///< `a + ab` is the last vertex of its polyline

  Point2 b() const { return a + ab; }
};

/// The segments of polylines, in order. Consecutive duplicate vertices are dropped (a
/// zero-length segment has no direction); an empty polyline contributes nothing.
std::vector<ModelSegment> MakeModelSegments(const std::vector<Polyline>& polylines);

/// Result of a nearest-segment query.
struct SegmentMatch {
  int segment = -1;  ///< index of the nearest segment, -1 when none is within the gate
  double squared_distance = std::numeric_limits<double>::infinity();  ///< m^2
  Point2 point = Point2::Zero();                                      ///< nearest point, map frame
  bool beyond_end = false;  ///< the projection falls beyond an open end of the polyline
};

/// Nearest point of p on one segment, as a match (segment index `index`).
inline SegmentMatch MatchSegment(const Point2& p, const ModelSegment& s, int index) {
  const double u = (p - s.a).dot(s.ab) * s.inv_length2;
  const double t = u < 0.0 ? 0.0 : (u > 1.0 ? 1.0 : u);
  SegmentMatch m;
  m.segment = index;
  m.point = s.a + t * s.ab;
  m.squared_distance = (p - m.point).squaredNorm();
  m.beyond_end = (s.open_start && u < 0.0) || (s.open_end && u > 1.0);
  return m;
}

/// Nearest segment of segments[begin, end) by a linear scan; segment = -1 when none lies
/// within sqrt(max_squared_distance). Allocation free.
inline SegmentMatch NearestSegment(const Point2& p, const std::vector<ModelSegment>& segments,
                                   std::size_t begin, std::size_t end,
                                   double max_squared_distance) {
  SegmentMatch best;
  for (std::size_t i = begin; i < end; ++i) {
    const SegmentMatch m = MatchSegment(p, segments[i], static_cast<int>(i));
    if (m.squared_distance < best.squared_distance) best = m;
  }
  if (best.squared_distance > max_squared_distance) return SegmentMatch{};
  return best;
}

/// A uniform grid over model segments for nearest-segment queries within a fixed radius.
/// Cells are at least `radius_m` wide (wider when the model is large, so that the grid has at
/// most kMaxCellsPerSide cells per side), so every segment within the radius of a query point
/// passes through the 3x3 cells around it. A segment is listed in every cell it may cross
/// (conservatively: the cell centre lies within half a cell diagonal of the segment). Storage
/// is compressed (one offset per cell plus one index per listed segment).
class SegmentGrid {
 public:
  static constexpr int kMaxCellsPerSide = 256;

  /// Copies the segments. Throws std::invalid_argument unless radius_m is finite and > 0.
  SegmentGrid(std::vector<ModelSegment> segments, double radius_m);

  /// Nearest segment within the radius given at construction (segment = -1 if none).
  SegmentMatch Nearest(const Point2& p) const;

  /// The i-th segment given at construction (a match's `segment`).
  const ModelSegment& Segment(int i) const { return segments_[i]; }

 private:
  void Fill();
  int CellIndex(int ix, int iy) const { return iy * nx_ + ix; }

  std::vector<ModelSegment> segments_;
  double radius_m_ = 0.0;
  Point2 origin_ = Point2::Zero();  // lower-left corner of cell (0, 0), metres
  double cell_m_ = 1.0;
  int nx_ = 0;
  int ny_ = 0;
  std::vector<int> cell_begin_;     // size nx_ * ny_ + 1, offsets into cell_segments_
  std::vector<int> cell_segments_;  // segment indices, grouped by cell
};

/// One sample of a perceived polyline with the model segments it may match (those of its own
/// pair: the restriction of §5.1).
struct RestrictedSample {
  Point2 point = Point2::Zero();  ///< scan frame, metres
  double weight = 1.0;            ///< the pair's weight
  std::size_t segments_begin = 0;
  std::size_t segments_end = 0;
};

/// The samples of every pair (SamplePolyline of the perceived polyline) and the segments of all
/// model polylines. Pairs with weight 0 or without model segments contribute no sample.
struct RestrictedProblem {
  std::vector<RestrictedSample> samples;
  std::vector<ModelSegment> segments;
};

/// Validates the pairs (finite vertices, finite weight >= 0; throws std::invalid_argument) and
/// builds the restricted problem.
RestrictedProblem MakeRestrictedProblem(const std::vector<ShapePair>& pairs, double spacing_m);

/// Throws std::invalid_argument naming `what` unless every coordinate is finite.
void CheckFinite(const Polyline& points, const char* what);
void CheckFinite(const Pose2& pose, const char* what);

}  // namespace shape_slam::internal
