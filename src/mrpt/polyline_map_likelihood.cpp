// CPolylineMap: observation likelihood, matching against points maps, distances.
#include <mrpt/maps/CPointsMap.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/poses/CPose2D.h>
#include <mrpt/poses/CPose3D.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "polyline_geometry.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

// The points of the other map of a matching, in its own frame: a points map's points, or the
// samples of a polyline map.
std::vector<Point2> OtherPoints(const mrpt::maps::CMetricMap* other, const char* caller) {
  if (other == nullptr)
    throw std::invalid_argument(std::string(caller) + ": the other map is null");
  if (const auto* points = dynamic_cast<const mrpt::maps::CPointsMap*>(other)) {
    return PointsOf(*points);
  }
  if (const auto* polylines = dynamic_cast<const CPolylineMap*>(other)) return polylines->Samples();
  throw std::invalid_argument(std::string(caller) + ": cannot match against a " +
                              other->GetRuntimeClass()->className +
                              " (needs a points map or a shape_slam::CPolylineMap)");
}

// Keeps, for every global index, only the pair with the smallest error (onlyUniqueRobust).
void KeepUniqueGlobal(mrpt::tfest::TMatchingPairList& pairs) {
  std::unordered_map<std::uint32_t, std::size_t> best;  // globalIdx -> position in pairs
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto [it, inserted] = best.emplace(pairs[i].globalIdx, i);
    if (!inserted && pairs[i].errorSquareAfterTransformation <
                         pairs[it->second].errorSquareAfterTransformation) {
      it->second = i;
    }
  }
  mrpt::tfest::TMatchingPairList unique;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (best.at(pairs[i].globalIdx) == i) unique.push_back(pairs[i]);
  }
  pairs.swap(unique);
}

}  // namespace

bool CPolylineMap::internal_canComputeObservationLikelihood(
    const mrpt::obs::CObservation& obs) const {
  return dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&obs) != nullptr;
}

// Likelihood field on the polylines (options.h, LikelihoodOptions).
double CPolylineMap::internal_computeObservationLikelihood(
    const mrpt::obs::CObservation& obs, const mrpt::poses::CPose3D& takenFrom) const {
  const auto* observation = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&obs);
  if (observation == nullptr || map_.Empty()) return 0.0;
  const LaserScan scan = ToLaserScan(*observation);
  const LikelihoodOptions& lo = options_.likelihood;
  const PointTransform T_map_sensor(ToPose2(takenFrom) * scan.T_robot_sensor);
  const double max_range_m = std::min(scan.max_range_m, lo.max_range_m);
  const double random_term = lo.z_random / lo.max_range_m;
  const double inv_two_sigma2 = 0.5 / (lo.sigma_m * lo.sigma_m);
  const PolylineGeometry& geometry = Geometry();
  double log_likelihood = 0.0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); i += static_cast<std::size_t>(lo.decimation)) {
    const double r = scan.ranges_m[i];
    if (!std::isfinite(r) || r <= options_.insertion.shapes.extraction.min_range_m || r >= max_range_m) {
      continue;
    }
    const Point2 p_map =
        T_map_sensor(Point2(r * std::cos(scan.angles_rad[i]), r * std::sin(scan.angles_rad[i])));
    const auto nearest = geometry.NearestWithin(p_map, lo.max_corr_distance_m);
    const double d2 =
        nearest ? nearest->squared_distance : lo.max_corr_distance_m * lo.max_corr_distance_m;
    log_likelihood += std::log(lo.z_hit * std::exp(-d2 * inv_two_sigma2) + random_term);
  }
  return log_likelihood;
}

// Each (decimated) point of the other map, at otherMapPose, is paired with its nearest point on
// the polylines when that lies within maxDistForCorrespondence + maxAngularDistForCorrespondence
// * (distance of the point to angularDistPivotPoint). One pair per point (onlyKeepTheClosest is
// implied); onlyUniqueRobust keeps one pair per globalIdx (the nearest sample).
void CPolylineMap::determineMatching2D(const mrpt::maps::CMetricMap* otherMap,
                                       const mrpt::poses::CPose2D& otherMapPose,
                                       mrpt::tfest::TMatchingPairList& correspondences,
                                       const mrpt::maps::TMatchingParams& params,
                                       mrpt::maps::TMatchingExtraResults& extraResults) const {
  correspondences.clear();
  extraResults = mrpt::maps::TMatchingExtraResults();
  const std::vector<Point2> local =
      OtherPoints(otherMap, "shape_slam::CPolylineMap::determineMatching2D");
  if (local.empty() || map_.Empty()) return;
  const PolylineGeometry& geometry = Geometry();
  const PointTransform T_this_other(ToPose2(otherMapPose));
  const Point2 pivot(params.angularDistPivotPoint.x, params.angularDistPivotPoint.y);
  const std::size_t step = std::max<std::size_t>(1, params.decimation_other_map_points);
  std::size_t considered = 0;
  for (std::size_t i = params.offset_other_map_points; i < local.size(); i += step) {
    ++considered;
    const Point2 p = T_this_other(local[i]);
    const double gate_m = params.maxDistForCorrespondence +
                          params.maxAngularDistForCorrespondence * (p - pivot).norm();
    const auto nearest = geometry.NearestWithin(p, gate_m);
    if (!nearest) continue;
    mrpt::tfest::TMatchingPair pair(
        static_cast<std::uint32_t>(nearest->sample_index), static_cast<std::uint32_t>(i),
        static_cast<float>(nearest->point.x()), static_cast<float>(nearest->point.y()), 0.0f,
        static_cast<float>(local[i].x()), static_cast<float>(local[i].y()), 0.0f);
    pair.errorSquareAfterTransformation = static_cast<float>(nearest->squared_distance);
    correspondences.push_back(pair);
  }
  if (params.onlyUniqueRobust) KeepUniqueGlobal(correspondences);
  float sum_sq = 0.0f;
  for (const auto& pair : correspondences) sum_sq += pair.errorSquareAfterTransformation;
  extraResults.sumSqrDist = sum_sq;
  extraResults.correspondencesRatio =
      considered == 0 ? 0.0f
                      : static_cast<float>(correspondences.size()) / static_cast<float>(considered);
}

// Fraction of the other map's points within maxDistForCorr of the polylines.
float CPolylineMap::compute3DMatchingRatio(const mrpt::maps::CMetricMap* otherMap,
                                           const mrpt::poses::CPose3D& otherMapPose,
                                           const mrpt::maps::TMatchingRatioParams& params) const {
  const std::vector<Point2> other =
      OtherPoints(otherMap, "shape_slam::CPolylineMap::compute3DMatchingRatio");
  if (other.empty() || map_.Empty()) return 0.0f;
  const PolylineGeometry& geometry = Geometry();
  const PointTransform T_this_other(ToPose2(otherMapPose));
  std::size_t matched = 0;
  for (const Point2& p : other) {
    if (geometry.NearestWithin(T_this_other(p), params.maxDistForCorr)) ++matched;
  }
  return static_cast<float>(matched) / static_cast<float>(other.size());
}

// Searched in growing discs, so that the cost follows the distance.
float CPolylineMap::squareDistanceToClosestCorrespondence(float x0, float y0) const {
  if (map_.Empty()) return std::numeric_limits<float>::infinity();
  const Point2 p(x0, y0);
  for (double radius_m = 1.0; radius_m < 1e7; radius_m *= 4.0) {
    if (const auto nearest = Geometry().NearestWithin(p, radius_m)) {
      return static_cast<float>(nearest->squared_distance);
    }
  }
  return std::numeric_limits<float>::infinity();
}

}  // namespace shape_slam
