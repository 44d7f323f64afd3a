// shape_slam::CPolylinePointsMap: a CPolylineMap seen as a points map, so that MRPT code that
// needs a CPointsMap -- above all icp-slam (CMetricMapBuilderICP matches every scan against its
// first points map) -- uses ShapeSLAM's geometry as its reference.
//
// The polyline map inside is the truth; the point cloud (what CPointsMap's accessors, kd-tree
// and rendering see) is regenerated from it after every insertion and deserialization: points
// every CreationOptions::sample_spacing_m along the polylines, z = 0. Points added directly
// through CPointsMap's API (insertPoint, fuseWith, ...) are therefore lost at the next
// insertion. determineMatching2D, compute3DMatchingRatio, the likelihood and the saved files are
// the polyline map's (point-to-line pairing, globalIdx = index of the nearest cloud point).
//
// With CreationOptions::keep_scan_points the cloud also holds the inserted scans' own points
// (after the samples; globalIdx counts on past the samples), and determineMatching2D pairs
// every point the polylines leave unpaired (point-to-line, as without the option) with the
// nearest kept scan point within the same gate. That is the setting for icp-slam: ICP against
// the polylines alone loses what the polylines do not keep (isolated returns, short and
// simplified-away detail), and on some logs (aces) that is what holds the robot; see
// docs/mrpt-plugin.md for the measurements.
//
// Ini: `polylinePointsMap_count=1` (or `shape_slam::CPolylinePointsMap_count=1`), the same
// option sections as CPolylineMap. With icp-slam do NOT also create a pointsMap, and use
// `ICP_algorithm = icpClassic` (the Levenberg-Marquardt variant needs a plain points map).
#pragma once

#include <mrpt/maps/CSimplePointsMap.h>

#include <string>

#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {

class CPolylinePointsMap : public mrpt::maps::CSimplePointsMap {
  DEFINE_SERIALIZABLE(CPolylinePointsMap, shape_slam)

 public:
  /// Throws std::invalid_argument when an option is invalid.
  explicit CPolylinePointsMap(const PolylineMapOptions& options = {});

  /// The polyline map the points are sampled from.
  const CPolylineMap& Polylines() const { return polylines_; }
  /// Replaces the polylines and resamples the points.
  void SetMap(const PolylineMap& map);
  const PolylineMapOptions& Options() const { return polylines_.Options(); }
  /// As CPolylineMap::SetOptions, then resamples the points.
  void SetOptions(const PolylineMapOptions& options);

  // mrpt::maps::CMetricMap, answered by the polyline map
  void determineMatching2D(const mrpt::maps::CMetricMap* otherMap,
                           const mrpt::poses::CPose2D& otherMapPose,
                           mrpt::tfest::TMatchingPairList& correspondences,
                           const mrpt::maps::TMatchingParams& params,
                           mrpt::maps::TMatchingExtraResults& extraResults) const override;
  float compute3DMatchingRatio(const mrpt::maps::CMetricMap* otherMap,
                               const mrpt::poses::CPose3D& otherMapPose,
                               const mrpt::maps::TMatchingRatioParams& params) const override;
  float squareDistanceToClosestCorrespondence(float x0, float y0) const override;
  /// `prefix.polylines`, `prefix.svg` (the polyline map's) and `prefix.txt` (the points).
  void saveMetricMapRepresentationToFile(const std::string& filNamePrefix) const override;
  void getVisualizationInto(mrpt::opengl::CSetOfObjects& outObj) const override;
  std::string asString() const override;

  MAP_DEFINITION_START(CPolylinePointsMap)
  PolylineMapOptions options;
  /// `map_file` of the creation section (options.h, LoadMapFileOption): polylines to start with.
  std::string map_file;
  MAP_DEFINITION_END(CPolylinePointsMap)

 protected:
  void internal_clear() override;
  bool internal_insertObservation(
      const mrpt::obs::CObservation& obs,
      const std::optional<const mrpt::poses::CPose3D>& robotPose = std::nullopt) override;
  double internal_computeObservationLikelihood(
      const mrpt::obs::CObservation& obs, const mrpt::poses::CPose3D& takenFrom) const override;
  bool internal_canComputeObservationLikelihood(const mrpt::obs::CObservation& obs) const override;

 private:
  void ResamplePoints();
  void AddScanPointPairs(const mrpt::maps::CMetricMap* otherMap,
                         const mrpt::poses::CPose2D& otherMapPose,
                         mrpt::tfest::TMatchingPairList& correspondences,
                         const mrpt::maps::TMatchingParams& params,
                         mrpt::maps::TMatchingExtraResults& extraResults) const;

  CPolylineMap polylines_;
  /// The inserted scans' points (CreationOptions::keep_scan_points), map frame.
  mrpt::maps::CSimplePointsMap scan_points_;
};

}  // namespace shape_slam
