// A spatial index of polyline segments: a uniform grid hash, so that a query costs what is
// near it, not the size of the map. Polylines are inserted, replaced and removed whole.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

using PolylineId = std::uint32_t;

/// Segment `segment` (joining vertices segment and segment + 1) of polyline `polyline`.
struct SegmentRef {
  PolylineId polyline = 0;
  std::uint32_t segment = 0;
  bool operator==(const SegmentRef& o) const { return polyline == o.polyline && segment == o.segment; }
  bool operator<(const SegmentRef& o) const {
    return polyline < o.polyline || (polyline == o.polyline && segment < o.segment);
  }
};

class SegmentIndex {
 public:
  /// Throws std::invalid_argument unless cell_size_m > 0.
  explicit SegmentIndex(double cell_size_m = 2.0);

  /// Inserts a polyline's segments (a one-vertex polyline as a point), replacing `id` if present.
  /// Each segment is entered in exactly the cells it crosses (grid traversal).
  void Insert(PolylineId id, const Polyline& polyline);
  /// Removes a polyline (no-op when absent).
  void Remove(PolylineId id);
  void Clear();

  /// Segments at distance <= radius_m from `centre`, sorted, without duplicates.
  std::vector<SegmentRef> QueryDisc(const Point2& centre, double radius_m) const;
  /// Segments whose cells overlap the box [min, max], sorted, without duplicates (a superset
  /// of the segments intersecting the box, exact up to the cell size).
  std::vector<SegmentRef> QueryBox(const Point2& min, const Point2& max) const;

  std::size_t NumPolylines() const { return polylines_.size(); }

 private:
  using CellKey = std::uint64_t;
  CellKey Key(std::int64_t ix, std::int64_t iy) const;
  std::int64_t Cell(double v) const;
  std::vector<CellKey> CellsOfSegment(const Point2& a, const Point2& b) const;
  std::vector<SegmentRef> Collect(const Point2& min, const Point2& max) const;

  struct Entry {
    Polyline points;
    std::vector<CellKey> cells;  // cells holding at least one of its segments
  };
  /// Segments crossing more cells than this are kept in long_segments_ instead of the cells
  /// (a corrupt or far-flung input must not cost time and memory in proportion to its length).
  static constexpr std::int64_t kMaxCellsPerSegment = 1024;
  bool BoxMeetsSegment(const SegmentRef& ref, const Point2& min, const Point2& max) const;

  double cell_size_m_;
  std::unordered_map<CellKey, std::vector<SegmentRef>> cells_;
  std::vector<SegmentRef> long_segments_;
  std::unordered_map<PolylineId, Entry> polylines_;
};

}  // namespace shape_slam
