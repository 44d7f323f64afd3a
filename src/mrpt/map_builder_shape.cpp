// CMetricMapBuilderShape: options, input (actions, sensory frames, observations), pose estimate.
#include "shape_slam_mrpt/map_builder_shape.h"

#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPosePDF.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>

#include "shape_slam/scan_insertion.h"
#include "shape_slam_io/params_ini.h"
#include "shape_slam_mrpt/conversions.h"

#include "option_fields.h"

namespace shape_slam {
namespace {

bool IsFinite(const Pose2& pose) {
  return std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta);
}


// (x, y, yaw) covariance into MRPT's 6x6 order (x, y, z, yaw, pitch, roll).
mrpt::math::CMatrixDouble66 ToCovariance6(const Eigen::Matrix3d& cov_xyt) {
  mrpt::math::CMatrixDouble66 cov;
  cov.setZero();
  constexpr int kIndex[3] = {0, 1, 3};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) cov(kIndex[r], kIndex[c]) = cov_xyt(r, c);
  }
  return cov;
}

}  // namespace

CMetricMapBuilderShape::CMetricMapBuilderShape(const Options& builder_options)
    : options_(builder_options) {
  options_.Validate();
  Restart(Pose2());
}

CMetricMapBuilderShape::~CMetricMapBuilderShape() = default;

void CMetricMapBuilderShape::SetOptions(const Options& builder_options) {
  builder_options.Validate();
  options_ = builder_options;
  Restart(T_world_map_);
}

void CMetricMapBuilderShape::LoadOptions(const mrpt::config::CConfigFileBase& source,
                                         const std::string& section) {
  Options loaded = options_;
  std::optional<bool> use_odometry;
  std::vector<std::string> keys;
  source.getAllKeys(section, keys);
  for (const std::string& key : keys) {
    const std::string where = "ini section '" + section + "', key '" + key + "'";
    const std::string value = source.read_string(section, key, "");
    if (Lower(key) == "params_file") {
      try {
        loaded.params = io::LoadParamsIni(value);
      } catch (const io::ConfigError& e) {
        throw std::invalid_argument(where + ": " + e.what());
      }
    } else if (Lower(key) == "use_odometry") {
      use_odometry = ParseBool(value, where);
    } else {
      throw std::invalid_argument(where + ": unknown key (known keys: params_file, use_odometry)");
    }
  }
  if (use_odometry) loaded.params.use_odometry = *use_odometry;
  SetOptions(loaded);
}

void CMetricMapBuilderShape::Restart(const Pose2& T_world_map) {
  slam_ = std::make_unique<ShapeSlam>(options_.params);
  localizer_.reset();
  last_localizer_report_.reset();
  localized_path_.clear();
  T_world_map_ = T_world_map;
  initial_simplemap_.clear();
  T_map_robot_start_ = Pose2();
  T_map_robot_last_known_ = Pose2();
  pending_actions_.reset();
  T_odom_robot_.reset();
  T_odom_last_scan_.reset();
  last_report_.reset();
  skipped_scans_ = 0;
  keyframes_ = 0;
  metric_map_stale_ = true;
}

void CMetricMapBuilderShape::initialize(const mrpt::maps::CSimpleMap& initialMap,
                                        const mrpt::poses::CPosePDF* x0) {
  const Pose2 T_world_x0 = x0 != nullptr ? ToPose2(x0->getMeanVal()) : Pose2();
  if (!IsFinite(T_world_x0)) {
    throw std::invalid_argument("shape_slam::CMetricMapBuilderShape::initialize: x0 not finite");
  }
  if (initialMap.empty()) {
    Restart(T_world_x0);  // the map frame at x0
    return;
  }
  const PolylineMap map = MapFromSimplemap(initialMap);  // checks every frame's pose
  const Pose2 T_world_robot =
      x0 != nullptr ? T_world_x0 : ToPose2(initialMap.rbegin()->pose->getMeanVal());
  InitializeFromMap(map, T_world_robot);
  initial_simplemap_ = initialMap;
}

// The laser scans of every frame inserted at the frame's pose (the mean of its PDF), trusted, in
// the simplemap's order.
PolylineMap CMetricMapBuilderShape::MapFromSimplemap(
    const mrpt::maps::CSimpleMap& simplemap) const {
  PolylineMap map(options_.params.index_cell_size_m);
  const ScanInsertionParams insertion = ToScanInsertionParams(options_.params);
  std::size_t frame = 0;
  for (const mrpt::maps::CSimpleMap::Pair& pair : simplemap) {
    const std::string where = "shape_slam::CMetricMapBuilderShape::initialize: initialMap frame " +
                              std::to_string(frame++);
    if (!pair.pose || !pair.sf) throw std::invalid_argument(where + " has no pose or no frame");
    const Pose2 T_world_robot = ToPose2(pair.pose->getMeanVal());
    if (!IsFinite(T_world_robot)) throw std::invalid_argument(where + ": pose not finite");
    for (const mrpt::obs::CObservation::Ptr& observation : *pair.sf) {
      const auto* range_scan =
          dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(observation.get());
      if (range_scan == nullptr) continue;
      try {
        InsertScan(map, ToLaserScan(*range_scan), T_world_robot, /*pose_trusted=*/true, insertion);
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(where + ": " + e.what());
      }
    }
  }
  if (map.Empty()) {
    throw std::invalid_argument(
        "shape_slam::CMetricMapBuilderShape::initialize: initialMap gives no polylines (no "
        "usable CObservation2DRangeScan)");
  }
  return map;
}

void CMetricMapBuilderShape::InitializeFromMap(const PolylineMap& map,
                                               const Pose2& T_world_robot) {
  if (!IsFinite(T_world_robot)) {
    throw std::invalid_argument("shape_slam::CMetricMapBuilderShape: the robot pose is not finite");
  }
  auto slam = std::make_unique<ShapeSlam>(options_.params, map, T_world_robot);
  Restart(Pose2());
  slam_ = std::move(slam);
  T_map_robot_start_ = T_world_robot;
}

void CMetricMapBuilderShape::StartLocalization(const PolylineMap& map,
                                               const std::optional<Pose2>& T_world_robot,
                                               const std::optional<LocalizerParams>& params) {
  if (T_world_robot && !IsFinite(*T_world_robot)) {
    throw std::invalid_argument("shape_slam::CMetricMapBuilderShape: the robot pose is not finite");
  }
  LocalizerParams localizer_params;
  localizer_params.stages = options_.params;
  auto localizer = std::make_unique<Localizer>(map, params.value_or(localizer_params));
  if (T_world_robot) localizer->SetInitialPose(*T_world_robot);
  Restart(Pose2());  // the map frame is the world frame
  localizer_ = std::move(localizer);
  T_map_robot_last_known_ = T_world_robot.value_or(Pose2());
  localized_ = T_world_robot.has_value();
}

void CMetricMapBuilderShape::processActionObservation(mrpt::obs::CActionCollection& action,
                                                      mrpt::obs::CSensoryFrame& observations) {
  // Actions and frames: the odometry starts at the origin (a frame before any action has it).
  Pose2 T_odom_robot = T_odom_robot_.value_or(Pose2());
  const mrpt::obs::CActionRobotMovement2D::Ptr movement = action.getBestMovementEstimation();
  if (movement && movement->poseChange) {
    const Pose2 increment = ToPose2(movement->poseChange->getMeanVal());
    if (IsFinite(increment)) T_odom_robot = T_odom_robot * increment;
  }
  T_odom_robot_ = T_odom_robot;
  for (const mrpt::obs::CObservation::Ptr& observation : observations) {
    if (observation) ProcessObservation(*observation);
  }
}

void CMetricMapBuilderShape::processObservation(const mrpt::obs::CObservation::Ptr& obs) {
  if (obs) ProcessObservation(*obs);
}

bool CMetricMapBuilderShape::ProcessRawlogEntry(
    const mrpt::serialization::CSerializable::Ptr& entry) {
  if (auto actions = std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(entry)) {
    pending_actions_ = std::move(actions);
    return false;
  }
  if (auto frame = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(entry)) {
    mrpt::obs::CActionCollection::Ptr actions = std::move(pending_actions_);
    if (!actions) actions = std::make_shared<mrpt::obs::CActionCollection>();
    pending_actions_.reset();
    processActionObservation(*actions, *frame);
    return true;
  }
  if (auto observation = std::dynamic_pointer_cast<mrpt::obs::CObservation>(entry)) {
    processObservation(observation);
    return true;
  }
  return false;
}

// As the rawlog reader (rawlog_reader.cpp): odometry updates the odometry pose, a laser scan is
// processed with it.
void CMetricMapBuilderShape::ProcessObservation(const mrpt::obs::CObservation& observation) {
  if (const auto* odometry = dynamic_cast<const mrpt::obs::CObservationOdometry*>(&observation)) {
    const Pose2 T_odom_robot = ToPose2(odometry->odometry);
    if (IsFinite(T_odom_robot)) T_odom_robot_ = T_odom_robot;
    return;
  }
  const auto* range_scan = dynamic_cast<const mrpt::obs::CObservation2DRangeScan*>(&observation);
  if (range_scan == nullptr) return;
  try {
    LaserScan scan = ToLaserScan(*range_scan);
    scan.T_odom_robot = T_odom_robot_;
    if (localizer_) {
      last_localizer_report_ = localizer_->Process(scan);
    } else {
      last_report_ = slam_->Process(scan);
    }
  } catch (const std::invalid_argument&) {
    ++skipped_scans_;  // a scan the core cannot use: the mapper state is unchanged
    return;
  }
  T_odom_last_scan_ = T_odom_robot_;
  if (localizer_) {
    const LocalizerReport& r = *last_localizer_report_;
    if (r.localized || r.hypotheses > 0) T_map_robot_last_known_ = r.T_map_robot;
    if (r.localized) localized_path_.push_back({r.timestamp_s, r.T_map_robot});
    localized_ = r.localized;
    return;
  }
  if (last_report_->keyframe) ++keyframes_;
  // A loop closure may move the map without a keyframe flag; cheap to rebuild on demand.
  metric_map_stale_ = true;
}

// The last scan's pose, moved on by the odometry since then when the mapper uses odometry.
// In localization mode: the last known pose, moved on the same way.
Pose2 CMetricMapBuilderShape::CurrentPoseInMap() const {
  if (localizer_) {
    Pose2 T_map_robot = T_map_robot_last_known_;
    if (options_.params.use_odometry && T_odom_last_scan_ && T_odom_robot_) {
      T_map_robot = T_map_robot * (T_odom_last_scan_->Inverse() * *T_odom_robot_);
    }
    return T_map_robot;
  }
  if (!last_report_) return T_map_robot_start_;
  Pose2 T_map_robot = last_report_->T_map_robot;
  if (slam_->Odometry().status == OdometryStatus::kUsed && T_odom_last_scan_ && T_odom_robot_) {
    T_map_robot = T_map_robot * (T_odom_last_scan_->Inverse() * *T_odom_robot_);
  }
  return T_map_robot;
}

mrpt::poses::CPose3DPDF::Ptr CMetricMapBuilderShape::getCurrentPoseEstimation() const {
  const Pose2 T = T_world_map_ * CurrentPoseInMap();
  Eigen::Matrix3d cov_map = Eigen::Matrix3d::Zero();
  if (localizer_ && !localized_) {
    // Searching, ambiguous or lost: the pose is a guess.
    constexpr double kUnknownSigmaM = 100.0;
    cov_map.diagonal() << kUnknownSigmaM * kUnknownSigmaM, kUnknownSigmaM * kUnknownSigmaM,
        M_PI * M_PI;
  } else if (!localizer_ && last_report_ && last_report_->matched) {
    cov_map = last_report_->covariance;
  } else {
    const OdometryNoiseParams& noise = options_.params.odometry_noise;
    cov_map.diagonal() << noise.sigma_xy_m * noise.sigma_xy_m, noise.sigma_xy_m * noise.sigma_xy_m,
        noise.sigma_theta_rad * noise.sigma_theta_rad;
  }
  // Rotate the (x, y) block from the map frame into the world frame.
  const Eigen::Matrix3d cov_world = CovarianceInFrame(cov_map, T_world_map_);
  return mrpt::poses::CPose3DPDFGaussian::Create(
      mrpt::poses::CPose3D(T.x, T.y, 0.0, T.theta, 0.0, 0.0), ToCovariance6(cov_world));
}

void CMetricMapBuilderShape::Finish() {
  slam_->Finish();
  metric_map_stale_ = true;
}

unsigned int CMetricMapBuilderShape::getCurrentlyBuiltMapSize() {
  return static_cast<unsigned int>(initial_simplemap_.size() + keyframes_);
}

}  // namespace shape_slam
