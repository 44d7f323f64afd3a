// The polyline map (paper §5): polylines in the map frame with per-vertex support (how often
// each part was seen), a spatial index so that every query costs what is near it, and the
// visible shape from a viewpoint (§3, §4).
#pragma once

#include <cstddef>
#include <unordered_map>
#include <utility>
#include <vector>

#include "shape_slam/spatial_index.h"
#include "shape_slam/types.h"
#include "shape_slam/visibility.h"

namespace shape_slam {

/// One polyline of the map with its bookkeeping.
struct MapPolyline {
  Polyline points;               ///< map frame, metres
  std::vector<double> support;   ///< per vertex: number of observations averaged into it
  int observations = 1;          ///< scans that matched or created this polyline
  int contradictions = 0;        ///< scans whose rays passed through it (see map_update.h)
  /// The keyframe (ShapeSlam's index) whose scan last added or merged into it; -1: none (a
  /// loaded map). A small pose-graph correction moves the polyline with that keyframe.
  int keyframe = -1;
};

class PolylineMap {
 public:
  explicit PolylineMap(double index_cell_size_m = 2.0);

  /// Adds a polyline; returns its id (ids are never reused). Throws std::invalid_argument when
  /// support does not match the points or a coordinate is not finite.
  PolylineId Add(MapPolyline polyline);
  /// Replaces the polyline `id` (which must exist).
  void Replace(PolylineId id, MapPolyline polyline);
  /// Removes the polyline `id` (no-op when absent).
  void Remove(PolylineId id);
  void Clear();

  bool Contains(PolylineId id) const { return polylines_.count(id) > 0; }
  /// Sets MapPolyline::keyframe of a polyline in the map (geometry and index untouched).
  void SetKeyframe(PolylineId id, int keyframe) { polylines_.at(id).keyframe = keyframe; }
  /// The polyline `id`; throws std::out_of_range when absent.
  const MapPolyline& Get(PolylineId id) const;
  /// All ids in increasing order (deterministic iteration).
  std::vector<PolylineId> Ids() const;
  /// Every polyline's points (a copy), in the order of Ids().
  std::vector<Polyline> Polylines() const;
  /// Ids of polylines with a segment that may intersect the box, increasing.
  std::vector<PolylineId> IdsNear(const Point2& min, const Point2& max) const;

  /// The visible map shape from a sensor pose (§3, §4): CCW ordered visible parts, sensor frame.
  /// With `seen`, the parts the scan saw through are left out (SeenRays, visibility.h).
  std::vector<VisiblePolyline> Visible(const Pose2& T_map_sensor, const VisibilityParams& params,
                                       const SeenRays* seen = nullptr) const;

  /// The polylines with their ids, increasing: all that Restore needs (a third of the memory of
  /// a copy of the map, which also holds the index).
  using Snapshot = std::vector<std::pair<PolylineId, MapPolyline>>;
  Snapshot TakeSnapshot() const;
  /// Replaces the content by a snapshot, ids kept (ids added later still follow every id used
  /// before). Throws std::invalid_argument like Add.
  void Restore(const Snapshot& snapshot);

  bool Empty() const { return polylines_.empty(); }
  std::size_t NumPolylines() const { return polylines_.size(); }
  std::size_t NumVertices() const { return num_vertices_; }
  /// Memory of the geometry as stored compactly (two doubles and a support value per vertex,
  /// plus a small header per polyline): the figure compared with occupancy grids.
  std::size_t GeometryBytes() const;

 private:
  std::unordered_map<PolylineId, MapPolyline> polylines_;
  std::unordered_map<PolylineId, Polyline> geometry_;  // what visibility reads
  SegmentIndex index_;
  PolylineId next_id_ = 0;
  std::size_t num_vertices_ = 0;
};

}  // namespace shape_slam
