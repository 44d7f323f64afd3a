// CMetricMapBuilderShape: what it has built, as MRPT maps and as a picture.
#include <mrpt/maps/CSimpleMap.h>

#include <string>
#include <vector>

#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/drawing.h"
#include "shape_slam_io/mrpt_maps.h"
#include "shape_slam_mrpt/map_builder_shape.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

bool IsIdentity(const Pose2& pose) { return pose.x == 0.0 && pose.y == 0.0 && pose.theta == 0.0; }

// The mapper's polylines moved into the world frame (support and bookkeeping kept).
PolylineMap InWorldFrame(const PolylineMap& map_map, const Pose2& T_world_map,
                         double cell_size_m) {
  PolylineMap map_world(cell_size_m);
  for (const PolylineId id : map_map.Ids()) {
    MapPolyline polyline = map_map.Get(id);
    for (Point2& p : polyline.points) p = T_world_map * p;
    map_world.Add(std::move(polyline));
  }
  return map_world;
}

}  // namespace

void CMetricMapBuilderShape::getCurrentlyBuiltMap(mrpt::maps::CSimpleMap& out_map) const {
  out_map = initial_simplemap_;
  for (const mrpt::maps::CSimpleMap::Pair& pair :
       io::MakeMrptSimplemap(slam_->Keyframes(), T_world_map_)) {
    out_map.insert(pair);
  }
}

const mrpt::maps::CMultiMetricMap* CMetricMapBuilderShape::getCurrentlyBuiltMetricMap() const {
  if (!metric_map_stale_) return &metric_map_;
  PolylineMapOptions map_options;
  map_options.creation.index_cell_size_m = options_.params.index_cell_size_m;
  if (metric_map_.maps.empty()) metric_map_.maps.push_back(CPolylineMap::Create(map_options));
  auto polylines = metric_map_.mapByClass<CPolylineMap>();
  if (localizer_) {
    polylines->SetMap(localizer_->Map());  // frozen, in the world frame
  } else if (IsIdentity(T_world_map_)) {
    polylines->SetMap(slam_->Map());
  } else {
    polylines->SetMap(InWorldFrame(slam_->Map(), T_world_map_, map_options.creation.index_cell_size_m));
  }
  metric_map_stale_ = false;
  return &metric_map_;
}

void CMetricMapBuilderShape::saveCurrentEstimationToImage(const std::string& file,
                                                          bool /*formatEMF_BMP*/) {
  std::vector<Point2> path_world;
  for (const StampedPose& pose : localizer_ ? localized_path_ : slam_->Trajectory()) {
    path_world.push_back((T_world_map_ * pose.pose).Translation());
  }
  const double cell_size_m = options_.params.index_cell_size_m;
  const PolylineMap map_world =
      InWorldFrame(localizer_ ? localizer_->Map() : slam_->Map(), T_world_map_, cell_size_m);
  io::WriteFileAtomically(file, io::RenderPng(io::MakeMapDrawing(
                                    map_world, path_world, "CMetricMapBuilderShape")));
}

}  // namespace shape_slam
