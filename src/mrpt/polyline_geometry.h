// Private: a snapshot of a polyline map prepared for the MRPT queries -- nearest point on the
// polylines within a radius (matching, likelihood) and samples along them (the point cloud of
// CPolylinePointsMap, the globalIdx of matchings).
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "shape_slam/polyline_map.h"
#include "shape_slam/spatial_index.h"
#include "shape_slam/types.h"

namespace shape_slam {

class PolylineGeometry {
 public:
  /// Copies the polylines of `map` (increasing id order). Throws std::invalid_argument unless
  /// sample_spacing_m and cell_size_m are > 0.
  PolylineGeometry(const PolylineMap& map, double sample_spacing_m, double cell_size_m);

  struct Nearest {
    Point2 point = Point2::Zero();  ///< nearest point on a polyline, map frame
    double squared_distance = 0.0;  ///< m^2
    std::size_t sample_index = 0;   ///< index in Samples() of the sample nearest to `point`
  };
  /// The nearest point of the polylines within radius_m of p, or nullopt (also when p or
  /// radius_m is not finite, or the disc reaches beyond 1e9 m).
  std::optional<Nearest> NearestWithin(const Point2& p, double radius_m) const;

  /// Points every sample spacing along each polyline, both ends included.
  const std::vector<Point2>& Samples() const { return samples_; }
  const std::vector<Polyline>& Polylines() const { return polylines_; }

 private:
  std::vector<Polyline> polylines_;
  std::vector<std::vector<double>> arc_m_;  // per polyline: arc length at each vertex
  std::vector<std::size_t> first_sample_;   // per polyline: index of its first sample
  std::vector<Point2> samples_;
  SegmentIndex index_;  // keyed by the position in polylines_
  double spacing_m_;
};

}  // namespace shape_slam
