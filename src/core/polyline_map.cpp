#include "shape_slam/polyline_map.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace shape_slam {
namespace {

void CheckPolyline(const MapPolyline& polyline) {
  if (polyline.points.empty()) throw std::invalid_argument("PolylineMap: empty polyline");
  if (polyline.support.size() != polyline.points.size()) {
    throw std::invalid_argument("PolylineMap: support has " +
                                std::to_string(polyline.support.size()) + " values for " +
                                std::to_string(polyline.points.size()) + " vertices");
  }
  for (std::size_t i = 0; i < polyline.points.size(); ++i) {
    if (!polyline.points[i].allFinite() || !std::isfinite(polyline.support[i])) {
      throw std::invalid_argument("PolylineMap: vertex " + std::to_string(i) +
                                  " has a non-finite coordinate or support");
    }
  }
}

}  // namespace

PolylineMap::PolylineMap(double index_cell_size_m) : index_(index_cell_size_m) {}

PolylineId PolylineMap::Add(MapPolyline polyline) {
  CheckPolyline(polyline);
  const PolylineId id = next_id_++;
  num_vertices_ += polyline.points.size();
  index_.Insert(id, polyline.points);
  geometry_[id] = polyline.points;
  polylines_.emplace(id, std::move(polyline));
  return id;
}

void PolylineMap::Replace(PolylineId id, MapPolyline polyline) {
  CheckPolyline(polyline);
  MapPolyline& existing = polylines_.at(id);
  num_vertices_ = num_vertices_ - existing.points.size() + polyline.points.size();
  index_.Insert(id, polyline.points);
  geometry_[id] = polyline.points;
  existing = std::move(polyline);
}

void PolylineMap::Remove(PolylineId id) {
  const auto it = polylines_.find(id);
  if (it == polylines_.end()) return;
  num_vertices_ -= it->second.points.size();
  index_.Remove(id);
  geometry_.erase(id);
  polylines_.erase(it);
}

void PolylineMap::Clear() {
  polylines_.clear();
  geometry_.clear();
  index_.Clear();
  num_vertices_ = 0;
}

PolylineMap::Snapshot PolylineMap::TakeSnapshot() const {
  Snapshot snapshot;
  snapshot.reserve(polylines_.size());
  for (const PolylineId id : Ids()) snapshot.emplace_back(id, polylines_.at(id));
  return snapshot;
}

void PolylineMap::Restore(const Snapshot& snapshot) {
  Clear();
  for (const auto& [id, polyline] : snapshot) {
    CheckPolyline(polyline);
    num_vertices_ += polyline.points.size();
    index_.Insert(id, polyline.points);
    geometry_[id] = polyline.points;
    polylines_[id] = polyline;
    next_id_ = std::max(next_id_, id + 1);
  }
}

const MapPolyline& PolylineMap::Get(PolylineId id) const { return polylines_.at(id); }

std::vector<PolylineId> PolylineMap::Ids() const {
  std::vector<PolylineId> ids;
  ids.reserve(polylines_.size());
  for (const auto& entry : polylines_) ids.push_back(entry.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<Polyline> PolylineMap::Polylines() const {
  std::vector<Polyline> polylines;
  polylines.reserve(polylines_.size());
  for (const PolylineId id : Ids()) polylines.push_back(polylines_.at(id).points);
  return polylines;
}

std::vector<PolylineId> PolylineMap::IdsNear(const Point2& min, const Point2& max) const {
  std::vector<PolylineId> ids;
  for (const SegmentRef& ref : index_.QueryBox(min, max)) {
    if (ids.empty() || ids.back() != ref.polyline) ids.push_back(ref.polyline);
  }
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

std::vector<VisiblePolyline> PolylineMap::Visible(const Pose2& T_map_sensor,
                                                  const VisibilityParams& params,
                                                  const SeenRays* seen) const {
  return ComputeVisibleShape(geometry_, index_, T_map_sensor, params, seen);
}

std::size_t PolylineMap::GeometryBytes() const {
  // Per vertex: x, y as float32 and a uint16 support; per polyline: id, count, observations,
  // contradictions as uint32 -- the compact form a robot would keep in memory or send.
  constexpr std::size_t kPerVertex = 2 * sizeof(float) + sizeof(std::uint16_t);
  constexpr std::size_t kPerPolyline = 4 * sizeof(std::uint32_t);
  return num_vertices_ * kPerVertex + polylines_.size() * kPerPolyline;
}

}  // namespace shape_slam
