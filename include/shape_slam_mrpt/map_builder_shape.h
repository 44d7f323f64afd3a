// shape_slam::CMetricMapBuilderShape: the ShapeSLAM mapper (pipeline.h, ShapeSlam) behind MRPT's
// mrpt::slam::CMetricMapBuilder, so that a program written for CMetricMapBuilderICP (icp-slam's
// loop: processActionObservation or processObservation per rawlog entry, then
// getCurrentPoseEstimation) runs ShapeSLAM instead.
//
//  * processActionObservation(actions, frame): the odometry increment of the best
//    CActionRobotMovement2D is composed onto the odometry pose (the origin before the first
//    action; an empty action collection adds nothing), then every CObservation2DRangeScan of
//    the frame goes to ShapeSlam::Process (conversions.h, ToLaserScan) with that odometry pose;
//    other observations are ignored. This is what `shape-slam run` does with a rawlog
//    (rawlog_reader.h), so both give the same poses for the same scans; a frame with no action
//    before it (MRPT's CRawlog drops it) is fed with an empty CActionCollection.
//  * processObservation(obs), observations-only rawlogs: a CObservationOdometry sets the
//    odometry pose (absolute), a CObservation2DRangeScan is processed; others are ignored.
//  * Scans the core rejects (no beam, bad aperture, no timestamp when others had one, ...) are
//    skipped and counted (SkippedScans()); the library never prints.
//  * getCurrentPoseEstimation: the last scan's pose composed with the odometry since that scan,
//    as a CPose3DPDFGaussian (z, pitch, roll 0 with zero variance); the covariance of (x, y, yaw)
//    is the refinement's for a matched scan, the floor of the odometry noise model
//    (OdometryNoiseParams sigma_xy_m, sigma_theta_rad) for a scan placed by prediction.
//  * getCurrentlyBuiltMap: a CSimpleMap of the keyframes at their corrected poses (as
//    `shape-slam run` writes map.simplemap), after initialize()'s initial frames if any;
//    getCurrentlyBuiltMapSize: the number of those frames.
//  * getCurrentlyBuiltMetricMap: a CMultiMetricMap holding one shape_slam::CPolylineMap with the
//    mapper's polylines (updated on demand after a change).
//  * saveCurrentEstimationToImage: a PNG of the map and the path (whatever formatEMF_BMP says).
//  * initialize(initialMap, x0) with an empty initialMap: restarts the mapper empty; the map
//    frame is placed at x0's mean (every pose reported and the polylines of the metric map are
//    x0 * the mapper's).
//  * initialize(initialMap, x0) with a non-empty CSimpleMap (as CMetricMapBuilderICP): the
//    starting map is built from its laser scans at their poses (the mean of each pose PDF) by
//    the core's scan insertion (scan_insertion.h, InsertScan, as the mapper inserts a
//    keyframe); the map frame is the simplemap's frame, and the robot starts at x0's mean, or at
//    the simplemap's last pose without x0. The mapper then goes on as `shape-slam run --map`
//    (ShapeSlam's constructor from a map); getCurrentlyBuiltMap returns the initial frames
//    followed by the new keyframes. InitializeFromMap does the same from a PolylineMap (e.g. a
//    saved map.polylines, io::LoadMapFile).
//  * CMetricMapBuilder::options (enableMapUpdating, debugForceInsertion, alwaysInsertByClass)
//    are not used: the mapper decides its keyframes itself.
//  * StartLocalization(map, [T_world_robot]): localization in a frozen map (the counterpart of
//    Cartographer's pure localization; `shape-slam localize`): the scans then go to a
//    shape_slam::Localizer (localizer.h) of the map, which never changes; without a pose the
//    global search finds the robot. getCurrentPoseEstimation gives the localized pose (or the
//    best hypothesis while ambiguous, the last known pose while searching or lost, with a
//    large covariance then), moved on by the odometry since the last scan;
//    getCurrentlyBuiltMetricMap the frozen map; getCurrentlyBuiltMap is empty (nothing is
//    built); LastLocalizerReport() the status of the last scan. initialize() and
//    InitializeFromMap() return to mapping.
//
// Not thread-safe (unlike CMetricMapBuilderICP): call it from one thread.
//
// Poses: "map" is the frame of the mapper (its first scan at the origin), "world" the frame the
// builder reports in (T_world_map = x0).
#pragma once

#include <mrpt/maps/CMultiMetricMap.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CObservation.h>
#include <mrpt/serialization/CSerializable.h>
#include <mrpt/slam/CMetricMapBuilder.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "shape_slam/localizer.h"
#include "shape_slam/pipeline.h"
#include "shape_slam/types.h"

namespace mrpt::config {
class CConfigFileBase;
}  // namespace mrpt::config

namespace shape_slam {

/// Options of CMetricMapBuilderShape.
struct CMetricMapBuilderShapeOptions {
  /// The mapper's parameters; defaults are `shape-slam run`'s.
  ShapeSlamParams params;
  /// Throws std::invalid_argument naming the offending field.
  void Validate() const { params.Validate(); }
};

class CMetricMapBuilderShape : public mrpt::slam::CMetricMapBuilder {
 public:
  using Options = CMetricMapBuilderShapeOptions;

  /// Throws std::invalid_argument when an option is invalid.
  explicit CMetricMapBuilderShape(const Options& builder_options = {});
  ~CMetricMapBuilderShape() override;

  const Options& GetOptions() const { return options_; }
  /// Sets the options and restarts the mapper (as initialize()). Throws std::invalid_argument.
  void SetOptions(const Options& builder_options);
  /// Reads `params_file` (a ShapeSLAM parameter ini as `shape-slam run --config` reads,
  /// config/default.ini) and `use_odometry` (true/false, applied after params_file) from
  /// `section`, then restarts the mapper. Unknown keys throw std::invalid_argument naming them.
  void LoadOptions(const mrpt::config::CConfigFileBase& source, const std::string& section);

  /// The mapper itself: Trajectory() (every scan, corrected by the last loop closure),
  /// Keyframes(), Map(), Odometry(). Poses there are in the map frame (see the file comment).
  const ShapeSlam& Mapper() const { return *slam_; }
  /// T_world_map: x0 of the last initialize(), identity by default.
  const Pose2& WorldFromMap() const { return T_world_map_; }
  /// The report of the last scan processed, if any.
  const std::optional<ScanReport>& LastReport() const { return last_report_; }
  /// Scans skipped because the core rejected them.
  int SkippedScans() const { return skipped_scans_; }

  /// Restarts the mapper from `map` (world frame; e.g. io::LoadMapFile of a map.polylines), the
  /// robot at `T_world_robot`: the map is kept and extended by the new scans. The map frame is
  /// the world frame. Throws std::invalid_argument for an empty map or a non-finite pose.
  void InitializeFromMap(const PolylineMap& map, const Pose2& T_world_robot);

  /// Localization in `map` (world frame), which stays frozen: see the file comment. With
  /// T_world_robot the robot starts there; without it the global search finds it. `params`
  /// default to the localizer's with the builder's mapper parameters as its stages. Throws
  /// std::invalid_argument for an empty map, a non-finite pose or invalid params.
  void StartLocalization(const PolylineMap& map,
                         const std::optional<Pose2>& T_world_robot = std::nullopt,
                         const std::optional<LocalizerParams>& params = std::nullopt);
  /// Whether the builder localizes in a frozen map (StartLocalization) rather than maps.
  bool Localizing() const { return localizer_ != nullptr; }
  /// The localizer's report of the last scan, in localization mode.
  const std::optional<LocalizerReport>& LastLocalizerReport() const { return last_localizer_report_; }

  /// At the end of the log: the mapper's final loop searches and pose-graph optimisation
  /// (ShapeSlam::Finish). Call it before saving the map; processing may go on afterwards.
  void Finish();

  /// See the file comment (observations-only rawlogs).
  void processObservation(const mrpt::obs::CObservation::Ptr& obs);

  /// One top-level rawlog entry, in file order, for a loop that reads entries itself (`archive
  /// >> entry`): an action collection is kept for the sensory frame after it; a sensory frame
  /// goes to processActionObservation with that collection, or with an empty one when there is
  /// none (MRPT's CRawlog drops such a frame; `shape-slam run` uses it); an observation goes to
  /// processObservation. Returns whether the entry was processed (a frame or an observation).
  bool ProcessRawlogEntry(const mrpt::serialization::CSerializable::Ptr& entry);

  // mrpt::slam::CMetricMapBuilder
  void initialize(const mrpt::maps::CSimpleMap& initialMap = mrpt::maps::CSimpleMap(),
                  const mrpt::poses::CPosePDF* x0 = nullptr) override;
  mrpt::poses::CPose3DPDF::Ptr getCurrentPoseEstimation() const override;
  void processActionObservation(mrpt::obs::CActionCollection& action,
                                mrpt::obs::CSensoryFrame& observations) override;
  void getCurrentlyBuiltMap(mrpt::maps::CSimpleMap& out_map) const override;
  unsigned int getCurrentlyBuiltMapSize() override;
  const mrpt::maps::CMultiMetricMap* getCurrentlyBuiltMetricMap() const override;
  void saveCurrentEstimationToImage(const std::string& file, bool formatEMF_BMP = true) override;

 private:
  void Restart(const Pose2& T_world_map);
  PolylineMap MapFromSimplemap(const mrpt::maps::CSimpleMap& simplemap) const;
  void ProcessObservation(const mrpt::obs::CObservation& observation);
  Pose2 CurrentPoseInMap() const;

  Options options_;
  std::unique_ptr<ShapeSlam> slam_;
  std::unique_ptr<Localizer> localizer_;  // localization mode (StartLocalization)
  std::optional<LocalizerReport> last_localizer_report_;
  std::vector<StampedPose> localized_path_;  // localization mode: the localized scans
  bool localized_ = false;                    // localization mode: the pose is known
  Pose2 T_world_map_;
  mrpt::maps::CSimpleMap initial_simplemap_;  // initialize()'s initialMap, if any
  Pose2 T_map_robot_start_;                   // mapping: the pose before the first scan
  Pose2 T_map_robot_last_known_;  // localization mode: localized or best hypothesis, last scan
  mrpt::obs::CActionCollection::Ptr pending_actions_;  // read, waiting for its sensory frame
  std::optional<Pose2> T_odom_robot_;       // odometry so far (increments or absolute)
  std::optional<Pose2> T_odom_last_scan_;   // odometry at the last processed scan
  std::optional<ScanReport> last_report_;
  int skipped_scans_ = 0;
  int keyframes_ = 0;
  // The CPolylineMap view of the mapper's map, rebuilt when stale.
  mutable mrpt::maps::CMultiMetricMap metric_map_;
  mutable bool metric_map_stale_ = true;
};

}  // namespace shape_slam
