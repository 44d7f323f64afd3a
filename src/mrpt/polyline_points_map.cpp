#include "shape_slam_mrpt/polyline_points_map.h"

#include <mrpt/opengl/CSetOfObjects.h>
#include <mrpt/serialization/CArchive.h>

#include <memory>
#include <sstream>

#include "shape_slam_io/map_file.h"

IMPLEMENTS_SERIALIZABLE(CPolylinePointsMap, mrpt::maps::CSimplePointsMap, shape_slam)

MAP_DEFINITION_REGISTER("shape_slam::CPolylinePointsMap,polylinePointsMap",
                        shape_slam::CPolylinePointsMap)

namespace shape_slam {

CPolylinePointsMap::CPolylinePointsMap(const PolylineMapOptions& options) : polylines_(options) {}

void CPolylinePointsMap::SetMap(const PolylineMap& map) {
  polylines_.SetMap(map);
  ResamplePoints();
}

void CPolylinePointsMap::SetOptions(const PolylineMapOptions& options) {
  polylines_.SetOptions(options);
  ResamplePoints();
}

// The point cloud is the polylines' samples (z = 0); the kd-tree is rebuilt on demand.
void CPolylinePointsMap::ResamplePoints() {
  const std::vector<Point2>& samples = polylines_.Samples();
  setSize(0);
  reserve(samples.size());
  for (const Point2& p : samples) {
    insertPointFast(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
  }
  mark_as_modified();
}

void CPolylinePointsMap::internal_clear() {
  polylines_.clear();
  CSimplePointsMap::internal_clear();
}

bool CPolylinePointsMap::internal_insertObservation(
    const mrpt::obs::CObservation& obs,
    const std::optional<const mrpt::poses::CPose3D>& robotPose) {
  if (!polylines_.insertObservation(obs, robotPose)) return false;
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
std::uint8_t CPolylinePointsMap::serializeGetVersion() const { return 0; }

void CPolylinePointsMap::serializeTo(mrpt::serialization::CArchive& out) const {
  out << genericMapParams << polylines_;
}

void CPolylinePointsMap::serializeFrom(mrpt::serialization::CArchive& in, std::uint8_t version) {
  switch (version) {
    case 0:
      in >> genericMapParams >> polylines_;
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
