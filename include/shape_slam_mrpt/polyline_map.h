// shape_slam::CPolylineMap: ShapeSLAM's polyline map (paper §5) as an MRPT metric map, so that
// MRPT applications (icp-slam, pf-localization, observations2map, RawLogViewer, ...; see
// docs/mrpt-plugin.md) and CMultiMetricMap can build, match against, save and draw it.
//
//  * insertObservation(CObservation2DRangeScan, robot pose): the scan is converted to a
//    LaserScan (shape_slam_io/mrpt_scan.h, as the rawlog reader converts it) and inserted by the
//    core's InsertScan (scan_insertion.h: ExtractScanShapes, the visible map shape at that pose,
//    UpdateMap, §3.1 and §5.2) with the pose trusted (the caller vouches for it): the map the
//    mapper's insertion makes from the same scans at the same poses. Scans without polylines and
//    other observation types are not inserted (returns false).
//  * computeObservationLikelihood(CObservation2DRangeScan, pose): a likelihood field on the
//    polylines (LikelihoodOptions), for particle filters.
//  * determineMatching2D / compute3DMatchingRatio against a points map: each point of the other
//    map is paired with its nearest point ON the polylines (not with a sample), so ICP against
//    this map is point-to-line ICP. globalIdx is the index of the nearest sample (Samples()).
//  * Serialization (versioned), getVisualizationInto (a CSetOfLines), and
//    saveMetricMapRepresentationToFile(prefix): `prefix.polylines` (shape_slam_io's map file,
//    loadable by `shape-slam`) and `prefix.svg`.
//  * Created from ini files with `polylineMap_count=1` (or `shape_slam::CPolylineMap_count=1`),
//    options in `<section>_polylineMap_00_creationOpts` / `_insertOpts` / `_likelihoodOpts`
//    (options.h).
//
// The library registers the class with MRPT's RTTI and map registry when it is loaded (also by
// LD_PRELOAD or an app's plugin option), see plugin.h.
#pragma once

#include <mrpt/maps/CMetricMap.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "shape_slam/map_update.h"
#include "shape_slam/polyline_map.h"
#include "shape_slam/types.h"
#include "shape_slam_mrpt/options.h"

namespace shape_slam {

class PolylineGeometry;  // nearest-point queries and samples (src/mrpt, not installed)

class CPolylineMap : public mrpt::maps::CMetricMap {
  DEFINE_SERIALIZABLE(CPolylineMap, shape_slam)

 public:
  /// Throws std::invalid_argument when an option is invalid.
  explicit CPolylineMap(const PolylineMapOptions& options = {});

  const PolylineMap& Map() const { return map_; }
  /// Replaces the polylines (e.g. with a map file loaded by shape_slam_io).
  void SetMap(const PolylineMap& map);
  const PolylineMapOptions& Options() const { return options_; }
  /// Validates (throws std::invalid_argument), then applies: a new index cell size rebuilds the
  /// map's index; the polylines stay.
  void SetOptions(const PolylineMapOptions& options);
  /// What the last successful scan insertion did to the map.
  const MapUpdateStats& LastUpdate() const { return last_update_; }

  /// Points every CreationOptions::sample_spacing_m along each polyline (both ends included),
  /// polylines in increasing id order: the indices of determineMatching2D's globalIdx. The
  /// reference stays valid until the map changes.
  const std::vector<Point2>& Samples() const;
  /// Distance from a point (map frame) to the nearest polyline, metres; +inf when none lies
  /// within max_distance_m.
  double DistanceToPolylines(const Point2& p_map, double max_distance_m) const;

  // mrpt::maps::CMetricMap
  bool isEmpty() const override;
  void determineMatching2D(const mrpt::maps::CMetricMap* otherMap,
                           const mrpt::poses::CPose2D& otherMapPose,
                           mrpt::tfest::TMatchingPairList& correspondences,
                           const mrpt::maps::TMatchingParams& params,
                           mrpt::maps::TMatchingExtraResults& extraResults) const override;
  float compute3DMatchingRatio(const mrpt::maps::CMetricMap* otherMap,
                               const mrpt::poses::CPose3D& otherMapPose,
                               const mrpt::maps::TMatchingRatioParams& params) const override;
  float squareDistanceToClosestCorrespondence(float x0, float y0) const override;
  void saveMetricMapRepresentationToFile(const std::string& filNamePrefix) const override;
  void getVisualizationInto(mrpt::opengl::CSetOfObjects& outObj) const override;
  std::string asString() const override;

  MAP_DEFINITION_START(CPolylineMap)
  PolylineMapOptions options;
  /// `map_file` of the creation section (options.h, LoadMapFileOption): polylines to start with.
  std::string map_file;
  MAP_DEFINITION_END(CPolylineMap)

 protected:
  void internal_clear() override;
  bool internal_insertObservation(
      const mrpt::obs::CObservation& obs,
      const std::optional<const mrpt::poses::CPose3D>& robotPose = std::nullopt) override;
  double internal_computeObservationLikelihood(
      const mrpt::obs::CObservation& obs, const mrpt::poses::CPose3D& takenFrom) const override;
  bool internal_canComputeObservationLikelihood(const mrpt::obs::CObservation& obs) const override;

 private:
  const PolylineGeometry& Geometry() const;
  void InvalidateGeometry();

  PolylineMapOptions options_;
  PolylineMap map_;
  MapUpdateStats last_update_;
  // Built on first use after a change; immutable once built, so copies may share it.
  mutable std::shared_ptr<const PolylineGeometry> geometry_;
};

}  // namespace shape_slam
