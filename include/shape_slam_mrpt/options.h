// Options of the MRPT map classes (CPolylineMap, CPolylinePointsMap) and their ini mapping.
//
// The options are the core's parameters (pipeline.h, map_update.h, ...), grouped the way MRPT
// groups map options, one ini section each (<prefix> is e.g. "MappingApplication_polylineMap_00"):
//   [<prefix>_creationOpts]    CreationOptions   (+ MRPT's enableSaveAs3DObject,
//                                                   enableObservationLikelihood,
//                                                   enableObservationInsertion, and map_file:
//                                                   a map.polylines the map starts with)
//   [<prefix>_insertOpts]      InsertionOptions  (extraction, simplification, map update)
//   [<prefix>_likelihoodOpts]  LikelihoodOptions (observation likelihood for particle filters)
// Keys are the field names below and those of the core structs they hold: ExtractionParams and
// MapUpdateParams fields unprefixed (max_gap_m, dce_threshold_m, ...), VisibilityParams fields
// prefixed with "visibility_" (visibility_max_range_m, ...). The loader is strict: an unknown
// key in one of these sections, a value that does not parse, or one that fails validation throws
// std::invalid_argument naming the section and the key; a typo is never silently ignored.
// Missing keys keep their defaults, which are the pipeline's (ShapeSlamParams{}).
#pragma once

#include <iosfwd>
#include <string>

#include "shape_slam/scan_insertion.h"

namespace mrpt::config {
class CConfigFileBase;
}  // namespace mrpt::config

namespace shape_slam {

/// [..._creationOpts]
struct CreationOptions {
  /// Cell size of the map's spatial index (ShapeSlamParams::index_cell_size_m), metres.
  double index_cell_size_m = 2.0;
  /// Spacing of the points sampled along the polylines: the point cloud of CPolylinePointsMap
  /// and the indices (globalIdx) of matchings, metres.
  double sample_spacing_m = 0.05;
  /// CPolylinePointsMap only (e.g. as icp-slam's ICP reference): its point cloud also keeps the
  /// points of every inserted scan at the insertion pose (as CSimplePointsMap inserts them, at
  /// least scan_points_spacing_m apart), and determineMatching2D pairs the points the polylines
  /// leave unpaired with the nearest kept point (same gate). The polylines are built and saved
  /// as without it. Off, the cloud is the polyline samples only (see polyline_points_map.h).
  bool keep_scan_points = false;
  double scan_points_spacing_m = 0.05;  ///< minDistBetweenLaserPoints of the kept points, metres
  void Validate() const;
};

/// [..._insertOpts]: how a CObservation2DRangeScan becomes polylines and updates the map: the
/// core's scan insertion (scan_insertion.h), the step the mapper takes for a keyframe, so a map
/// built here from scans at given poses is the one the mapper builds from them at those poses.
/// Keys: ExtractionParams fields, alignment_dce_threshold_m and alignment_max_deviation_m
/// (ScanShapesParams), visibility_* (VisibilityParams) and MapUpdateParams fields.
using InsertionOptions = ScanInsertionParams;

/// [..._likelihoodOpts]: a likelihood field on the polylines (as MRPT's LF model for grids):
/// every `decimation`-th valid reading, at distance d to the nearest polyline (d capped at
/// max_corr_distance_m), contributes log(z_hit exp(-d^2 / (2 sigma_m^2)) + z_random / max_range_m).
/// The defaults are those of COccupancyGridMap2D's LF_* options, decimation aside.
struct LikelihoodOptions {
  double sigma_m = 0.35;              ///< standard deviation of the distance (LF_stdHit), metres
  double max_corr_distance_m = 0.30;  ///< distances are capped at this, metres
  double z_hit = 0.95;                ///< weight of the Gaussian, [0, 1]
  double z_random = 0.05;             ///< weight of random readings, [0, 1]
  double max_range_m = 81.0;          ///< readings at or beyond this are ignored, metres
  int decimation = 10;                ///< use every n-th beam, >= 1
  void Validate() const;
};

struct PolylineMapOptions {
  CreationOptions creation;
  InsertionOptions insertion;
  LikelihoodOptions likelihood;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const;
};

/// Reads the three sections <prefix>_creationOpts, _insertOpts, _likelihoodOpts over `defaults`
/// (see the file comment). Throws std::invalid_argument naming the section and key.
PolylineMapOptions LoadPolylineMapOptions(const mrpt::config::CConfigFileBase& source,
                                          const std::string& prefix,
                                          const PolylineMapOptions& defaults = {});

/// The `map_file` key of <prefix>_creationOpts (comments stripped), or "" when absent: the path
/// of a map file (shape_slam_io/map_file.h, `shape-slam run`'s map.polylines) whose polylines a
/// map created from this definition starts with. Relative paths are relative to the current
/// directory of the process.
std::string LoadMapFileOption(const mrpt::config::CConfigFileBase& source,
                              const std::string& prefix);

/// Writes every option as `key = value` lines under "[<prefix>_...Opts]" headers.
void DumpPolylineMapOptions(const PolylineMapOptions& options, const std::string& prefix,
                            std::ostream& out);

/// True when every field is equal.
bool operator==(const PolylineMapOptions& a, const PolylineMapOptions& b);
inline bool operator!=(const PolylineMapOptions& a, const PolylineMapOptions& b) {
  return !(a == b);
}

}  // namespace shape_slam
