#include "shape_slam_mrpt/polyline_points_map.h"

#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <memory>
#include <sstream>

#include "shape_slam_io/map_file.h"
#include "shape_slam_mrpt/conversions.h"

IMPLEMENTS_SERIALIZABLE(CPolylinePointsMap, mrpt::maps::CSimplePointsMap, shape_slam)

MAP_DEFINITION_REGISTER("shape_slam::CPolylinePointsMap,polylinePointsMap",
                        shape_slam::CPolylinePointsMap)

namespace shape_slam {

CPolylinePointsMap::CPolylinePointsMap(const PolylineMapOptions& options) : polylines_(options) {
  scan_points_.insertionOptions.isPlanarMap = true;
}

void CPolylinePointsMap::SetMap(const PolylineMap& map) {
  polylines_.SetMap(map);
  scan_points_.clear();
  ResamplePoints();
}

void CPolylinePointsMap::SetOptions(const PolylineMapOptions& options) {
  polylines_.SetOptions(options);
  ResamplePoints();
}

// The point cloud is the polylines' samples (z = 0), then the kept scan points; the kd-tree is
// rebuilt on demand.
void CPolylinePointsMap::ResamplePoints() {
  const std::vector<Point2>& samples = polylines_.Samples();
  const auto& xs = scan_points_.getPointsBufferRef_x();
  const auto& ys = scan_points_.getPointsBufferRef_y();
  setSize(0);
  reserve(samples.size() + xs.size());
  for (const Point2& p : samples) {
    insertPointFast(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  }
  for (std::size_t i = 0; i < xs.size(); ++i) insertPointFast(xs[i], ys[i], 0.0f);
  mark_as_modified();
}

void CPolylinePointsMap::internal_clear() {
  polylines_.clear();
  scan_points_.clear();
  CSimplePointsMap::internal_clear();
}

bool CPolylinePointsMap::internal_insertObservation(
    const mrpt::obs::CObservation& obs,
    const std::optional<const mrpt::poses::CPose3D>& robotPose) {
  const bool inserted = polylines_.insertObservation(obs, robotPose);
  bool kept = false;
  if (Options().creation.keep_scan_points) {
    scan_points_.insertionOptions.minDistBetweenLaserPoints =
        static_cast<float>(Options().creation.scan_points_spacing_m);
    kept = scan_points_.insertObservation(obs, robotPose);
  }
  if (!inserted && !kept) return false;
  ResamplePoints();
  return true;
}

double CPolylinePointsMap::internal_computeObservationLikelihood(
    const mrpt::obs::CObservation& obs, const mrpt::poses::CPose3D& takenFrom) const {
  return polylines_.computeObservationLikelihood(obs, takenFrom);
}

bool CPolylinePointsMap::internal_canComputeObservationLikelihood(
    const mrpt::obs::CObservation& obs) const {
  return polylines_.canComputeObservationLikelihood(obs);
}

void CPolylinePointsMap::determineMatching2D(
    const mrpt::maps::CMetricMap* otherMap, const mrpt::poses::CPose2D& otherMapPose,
    mrpt::tfest::TMatchingPairList& correspondences, const mrpt::maps::TMatchingParams& params,
    mrpt::maps::TMatchingExtraResults& extraResults) const {
  polylines_.determineMatching2D(otherMap, otherMapPose, correspondences, params, extraResults);
  if (Options().creation.keep_scan_points) {
    AddScanPointPairs(otherMap, otherMapPose, correspondences, params, extraResults);
  }
}

// The other map's points the polylines left unpaired, paired with the nearest kept scan point
// within the same gate (globalIdx after the samples').
void CPolylinePointsMap::AddScanPointPairs(const mrpt::maps::CMetricMap* otherMap,
                                           const mrpt::poses::CPose2D& otherMapPose,
                                           mrpt::tfest::TMatchingPairList& correspondences,
                                           const mrpt::maps::TMatchingParams& params,
                                           mrpt::maps::TMatchingExtraResults& extraResults) const {
  const auto* other = dynamic_cast<const mrpt::maps::CPointsMap*>(otherMap);
  if (other == nullptr || scan_points_.empty()) return;
  const std::vector<Point2> local = PointsOf(*other);
  std::vector<bool> paired(local.size(), false);
  for (const auto& pair : correspondences) paired[pair.localIdx] = true;
  const PointTransform T_this_other(ToPose2(otherMapPose));
  const Point2 pivot(params.angularDistPivotPoint.x, params.angularDistPivotPoint.y);
  const std::size_t step = std::max<std::size_t>(1, params.decimation_other_map_points);
  const std::size_t offset = polylines_.Samples().size();
  std::size_t considered = 0;
  for (std::size_t i = params.offset_other_map_points; i < local.size(); i += step) {
    ++considered;
    if (paired[i]) continue;
    const Point2 p = T_this_other(local[i]);
    const double gate_m = params.maxDistForCorrespondence +
                          params.maxAngularDistForCorrespondence * (p - pivot).norm();
    float x = 0, y = 0, d2 = 0;
    const std::size_t j = scan_points_.kdTreeClosestPoint2D(static_cast<float>(p.x()),
                                                            static_cast<float>(p.y()), x, y, d2);
    if (!(d2 <= gate_m * gate_m)) continue;
    mrpt::tfest::TMatchingPair pair(static_cast<std::uint32_t>(offset + j),
                                    static_cast<std::uint32_t>(i), x, y, 0.0f,
                                    static_cast<float>(local[i].x()),
                                    static_cast<float>(local[i].y()), 0.0f);
    pair.errorSquareAfterTransformation = d2;
    correspondences.push_back(pair);
    extraResults.sumSqrDist += d2;
  }
  extraResults.correspondencesRatio =
      considered == 0 ? 0.0f
                      : static_cast<float>(correspondences.size()) / static_cast<float>(considered);
}

float CPolylinePointsMap::compute3DMatchingRatio(
    const mrpt::maps::CMetricMap* otherMap, const mrpt::poses::CPose3D& otherMapPose,
    const mrpt::maps::TMatchingRatioParams& params) const {
  return polylines_.compute3DMatchingRatio(otherMap, otherMapPose, params);
}

float CPolylinePointsMap::squareDistanceToClosestCorrespondence(float x0, float y0) const {
  return polylines_.squareDistanceToClosestCorrespondence(x0, y0);
}

void CPolylinePointsMap::saveMetricMapRepresentationToFile(const std::string& filNamePrefix) const {
  polylines_.saveMetricMapRepresentationToFile(filNamePrefix);
  CSimplePointsMap::saveMetricMapRepresentationToFile(filNamePrefix);
}

// The polylines, over the points as CPointsMap draws them.
void CPolylinePointsMap::getVisualizationInto(mrpt::opengl::CSetOfObjects& outObj) const {
  if (!genericMapParams.enableSaveAs3DObject) return;
  CSimplePointsMap::getVisualizationInto(outObj);
  polylines_.getVisualizationInto(outObj);
}

std::string CPolylinePointsMap::asString() const {
  std::ostringstream s;
  s << "shape_slam::CPolylinePointsMap: " << size() << " points sampled from "
    << polylines_.asString();
  return s.str();
}

// Version 0: generic map params, then the polyline map (an object); the points are resampled.
// Version 1: then the kept scan points (a CSimplePointsMap object).
std::uint8_t CPolylinePointsMap::serializeGetVersion() const { return 1; }

void CPolylinePointsMap::serializeTo(mrpt::serialization::CArchive& out) const {
  out << genericMapParams << polylines_ << scan_points_;
}

void CPolylinePointsMap::serializeFrom(mrpt::serialization::CArchive& in, std::uint8_t version) {
  switch (version) {
    case 0:
    case 1:
      in >> genericMapParams >> polylines_;
      scan_points_.clear();
      if (version >= 1) in >> scan_points_;
      ResamplePoints();
      break;
    default:
      MRPT_THROW_UNKNOWN_SERIALIZATION_VERSION(version);
  }
}

// ---- ini definition ----

CPolylinePointsMap::TMapDefinition::TMapDefinition() = default;

void CPolylinePointsMap::TMapDefinition::loadFromConfigFile_map_specific(
    const mrpt::config::CConfigFileBase& source, const std::string& sectionNamePrefix) {
  options = LoadPolylineMapOptions(source, sectionNamePrefix, options);
  map_file = LoadMapFileOption(source, sectionNamePrefix);
}

void CPolylinePointsMap::TMapDefinition::dumpToTextStream_map_specific(std::ostream& out) const {
  DumpPolylineMapOptions(options, "<prefix>", out);
  if (!map_file.empty()) out << "map_file (creation section) = " << map_file << "\n";
}

mrpt::maps::CMetricMap* CPolylinePointsMap::internal_CreateFromMapDefinition(
    const mrpt::maps::TMetricMapInitializer& def) {
  const auto& definition = dynamic_cast<const CPolylinePointsMap::TMapDefinition&>(def);
  auto map = std::make_unique<CPolylinePointsMap>(definition.options);
  if (!definition.map_file.empty()) map->SetMap(io::LoadMapFile(definition.map_file));
  return map.release();
}

}  // namespace shape_slam
