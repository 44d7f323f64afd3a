// CMetricMapBuilderShape fed the way icp-slam feeds CMetricMapBuilderICP, against the mapper fed
// by shape_slam_io's rawlog reader (what `shape-slam run` does): same scans, same poses.
#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "shape_slam/pipeline.h"
#include "shape_slam_io/rawlog_reader.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/map_builder_shape.h"
#include "shape_slam_mrpt/plugin.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

const std::string kSenaLog =
    "/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog";
const std::string kObsOnlyLog =
    std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/logs/sena_first20_obs_only.rawlog";

bool Readable(const std::string& path) { return std::ifstream(path).good(); }

// icp-slam's loop over (the steps [first_step, max_steps) of) a rawlog, entry by entry as
// mrpt-map-builder reads it (ProcessRawlogEntry: a sensory frame without an action before it is
// used, where CRawlog drops it); returns the pose estimate after every step fed.
std::vector<mrpt::poses::CPose3D> FeedLikeIcpSlam(CMetricMapBuilderShape& builder,
                                                  const std::string& path,
                                                  std::size_t max_steps = SIZE_MAX,
                                                  std::size_t first_step = 0) {
  mrpt::io::CFileGZInputStream file(path);
  auto archive = mrpt::serialization::archiveFrom(file);
  std::vector<mrpt::poses::CPose3D> poses;
  CMetricMapBuilderShape skipped;  // takes the steps before first_step
  for (std::size_t step = 0; step < max_steps;) {
    mrpt::serialization::CSerializable::Ptr entry;
    try {
      archive >> entry;
    } catch (const mrpt::serialization::CExceptionEOF&) {
      break;
    }
    CMetricMapBuilderShape& target = step < first_step ? skipped : builder;
    if (!target.ProcessRawlogEntry(entry)) continue;
    if (step++ < first_step) continue;
    poses.push_back(builder.getCurrentPoseEstimation()->getMeanVal());
  }
  return poses;
}

// Two trajectories over the same scans (same timestamps), `a` moved onto `b` by the rigid
// motion that fits best (least squares over the positions): the scans in common and the
// position differences left.
struct Agreement {
  std::size_t common = 0;
  double rms_m = 0.0, max_m = 0.0;
};
Agreement RigidAgreement(const std::vector<StampedPose>& a, const std::vector<StampedPose>& b) {
  std::vector<std::pair<Point2, Point2>> pairs;
  for (const StampedPose& pa : a) {
    const auto it = std::find_if(b.begin(), b.end(), [&](const StampedPose& pb) {
      return pb.timestamp_s == pa.timestamp_s;
    });
    if (it != b.end()) pairs.emplace_back(pa.pose.Translation(), it->pose.Translation());
  }
  Agreement agreement;
  agreement.common = pairs.size();
  if (pairs.empty()) return agreement;
  Point2 ca = Point2::Zero(), cb = Point2::Zero();
  for (const auto& [p, q] : pairs) ca += p, cb += q;
  ca /= pairs.size();
  cb /= pairs.size();
  double dot = 0.0, cross = 0.0;
  for (const auto& [p, q] : pairs) {
    const Point2 u = p - ca, v = q - cb;
    dot += u.dot(v);
    cross += u.x() * v.y() - u.y() * v.x();
  }
  const Eigen::Rotation2Dd R(std::atan2(cross, dot));
  double sum = 0.0;
  for (const auto& [p, q] : pairs) {
    const double d = (R * (p - ca) + cb - q).norm();
    sum += d * d;
    agreement.max_m = std::max(agreement.max_m, d);
  }
  agreement.rms_m = std::sqrt(sum / pairs.size());
  return agreement;
}

// MRPT's own loop (CRawlog::getActionObservationPairOrObservation): the steps it gives.
std::size_t StepsOfMrptsReader(const std::string& path) {
  mrpt::io::CFileGZInputStream file(path);
  auto archive = mrpt::serialization::archiveFrom(file);
  mrpt::obs::CActionCollection::Ptr actions;
  mrpt::obs::CSensoryFrame::Ptr frame;
  mrpt::obs::CObservation::Ptr observation;
  std::size_t entry = 0, steps = 0;
  while (mrpt::obs::CRawlog::getActionObservationPairOrObservation(archive, actions, frame,
                                                                   observation, entry)) {
    ++steps;
  }
  return steps;
}

// What `shape-slam run` computes: the rawlog reader's scans through the mapper.
std::vector<StampedPose> RunLikeShapeSlam(const std::string& path, ShapeSlam& slam) {
  io::RawlogReader reader(path);
  while (std::optional<LaserScan> scan = reader.Next()) slam.Process(*scan);
  return slam.Trajectory();
}

void ExpectSameTrajectory(const std::vector<StampedPose>& actual,
                          const std::vector<StampedPose>& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  double worst_m = 0.0;
  for (std::size_t i = 0; i < actual.size(); ++i) {
    EXPECT_EQ(actual[i].timestamp_s, expected[i].timestamp_s) << "scan " << i;
    const Pose2 d = expected[i].pose.Inverse() * actual[i].pose;
    worst_m = std::max(worst_m, d.Translation().norm());
    EXPECT_LT(std::abs(d.theta), 1e-9) << "scan " << i;
  }
  EXPECT_LT(worst_m, 1e-9);  // the same mapper on the same scans: the same poses
}

TEST(CMetricMapBuilderShape, SampleLogGivesTheTrajectoryOfShapeSlamRun) {
  if (!Readable(kSenaLog)) GTEST_SKIP() << kSenaLog << " missing (package mrpt-common)";
  CMetricMapBuilderShape builder;
  const std::vector<mrpt::poses::CPose3D> online = FeedLikeIcpSlam(builder, kSenaLog);
  ShapeSlam reference;
  const std::vector<StampedPose> expected = RunLikeShapeSlam(kSenaLog, reference);
  // Every scan, the first frame (before any action) too; MRPT's reader drops that one.
  ASSERT_EQ(expected.size(), 225u);
  EXPECT_EQ(StepsOfMrptsReader(kSenaLog), 224u);
  ExpectSameTrajectory(builder.Mapper().Trajectory(), expected);
  EXPECT_EQ(builder.SkippedScans(), 0);
  EXPECT_EQ(builder.Mapper().Odometry().status, OdometryStatus::kUsed);
  EXPECT_EQ(builder.Mapper().Map().NumPolylines(), reference.Map().NumPolylines());
  EXPECT_EQ(online.size(), 225u);  // one frame per scan in this log
  // The online estimate after the last entry is the last scan's pose (no odometry after it);
  // a loop closure may have moved it since, but not by more than a few centimetres here.
  const Pose2 last = expected.back().pose;
  EXPECT_NEAR(online.back().x(), last.x, 0.05);
  EXPECT_NEAR(online.back().y(), last.y, 0.05);
}

TEST(CMetricMapBuilderShape, ObservationsOnlyLogGivesTheReaderTrajectory) {
  CMetricMapBuilderShape builder;
  const std::vector<mrpt::poses::CPose3D> online = FeedLikeIcpSlam(builder, kObsOnlyLog);
  ShapeSlam reference;
  const std::vector<StampedPose> expected = RunLikeShapeSlam(kObsOnlyLog, reference);
  ASSERT_EQ(expected.size(), 20u);
  ExpectSameTrajectory(builder.Mapper().Trajectory(), expected);
  EXPECT_EQ(builder.Mapper().Odometry().status, OdometryStatus::kUsed);
  EXPECT_EQ(online.size(), 40u);  // an odometry and a scan observation per step
}

TEST(CMetricMapBuilderShape, MapsAndPoseEstimateDescribeWhatWasBuilt) {
  if (!Readable(kSenaLog)) GTEST_SKIP() << kSenaLog << " missing (package mrpt-common)";
  CMetricMapBuilderShape builder;
  FeedLikeIcpSlam(builder, kSenaLog, 60);  // the first 20 s: some keyframes
  const ShapeSlam& slam = builder.Mapper();
  const std::size_t keyframes = slam.Keyframes().size();
  ASSERT_GT(keyframes, 1u);
  EXPECT_EQ(builder.getCurrentlyBuiltMapSize(), keyframes);
  mrpt::maps::CSimpleMap simplemap;
  builder.getCurrentlyBuiltMap(simplemap);
  ASSERT_EQ(simplemap.size(), keyframes);
  const auto [pose_pdf, frame] = simplemap.get(keyframes - 1);
  const Pose2 T_last = slam.Keyframes().back().T_map_robot;
  EXPECT_NEAR(pose_pdf->getMeanVal().x(), T_last.x, 1e-9);
  EXPECT_NEAR(pose_pdf->getMeanVal().y(), T_last.y, 1e-9);
  EXPECT_EQ(frame->size(), 1u);

  const auto polylines = builder.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>();
  ASSERT_TRUE(polylines);
  EXPECT_EQ(polylines->Map().NumPolylines(), slam.Map().NumPolylines());
  EXPECT_EQ(polylines->Map().NumVertices(), slam.Map().NumVertices());

  const auto estimate = std::dynamic_pointer_cast<mrpt::poses::CPose3DPDFGaussian>(
      builder.getCurrentPoseEstimation());
  ASSERT_TRUE(estimate);
  ASSERT_TRUE(builder.LastReport());
  const ScanReport& report = *builder.LastReport();
  EXPECT_NEAR(estimate->mean.x(), report.T_map_robot.x, 1e-12);
  EXPECT_NEAR(estimate->mean.yaw(), report.T_map_robot.theta, 1e-12);
  if (report.matched) {
    EXPECT_DOUBLE_EQ(estimate->cov(0, 0), report.covariance(0, 0));
    EXPECT_DOUBLE_EQ(estimate->cov(3, 3), report.covariance(2, 2));
    EXPECT_DOUBLE_EQ(estimate->cov(0, 3), report.covariance(0, 2));
  }
  EXPECT_EQ(estimate->cov(2, 2), 0.0);  // z
}

TEST(CMetricMapBuilderShape, InitializeAtX0MovesEveryPoseAndThePolylines) {
  CMetricMapBuilderShape at_origin;
  FeedLikeIcpSlam(at_origin, kObsOnlyLog);
  CMetricMapBuilderShape moved;
  const Pose2 T_world_map(1.0, -2.0, M_PI / 2);
  const mrpt::poses::CPosePDFGaussian x0(ToCPose2D(T_world_map));
  moved.initialize(mrpt::maps::CSimpleMap(), &x0);
  FeedLikeIcpSlam(moved, kObsOnlyLog);
  const Pose2 expected = T_world_map * at_origin.LastReport()->T_map_robot;
  const mrpt::poses::CPose3D actual = moved.getCurrentPoseEstimation()->getMeanVal();
  EXPECT_NEAR(actual.x(), expected.x, 1e-9);
  EXPECT_NEAR(actual.y(), expected.y, 1e-9);
  EXPECT_NEAR(NormalizeAngle(actual.yaw() - expected.theta), 0.0, 1e-9);
  const auto a = at_origin.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>()->Map();
  const auto b = moved.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>()->Map();
  ASSERT_EQ(a.NumPolylines(), b.NumPolylines());
  const Point2 p = a.Get(a.Ids().front()).points.front();
  const Point2 q = b.Get(b.Ids().front()).points.front();
  EXPECT_LT((T_world_map * p - q).norm(), 1e-9);
}

// initialize(simplemap): the starting map is the simplemap's scans inserted at their poses
// (the same polylines as CPolylineMap::loadFromSimpleMap, the same core insertion), the robot
// starts at the last frame's pose, and the rest of the log continues that map.
TEST(CMetricMapBuilderShape, InitializeFromASimplemapContinuesItsMap) {
  if (!Readable(kSenaLog)) GTEST_SKIP() << kSenaLog << " missing (package mrpt-common)";
  constexpr std::size_t kSteps = 100;
  CMetricMapBuilderShape first;
  FeedLikeIcpSlam(first, kSenaLog, kSteps);
  mrpt::maps::CSimpleMap simplemap;
  first.getCurrentlyBuiltMap(simplemap);
  ASSERT_GT(simplemap.size(), 10u);

  CMetricMapBuilderShape continued;
  continued.initialize(simplemap);
  CPolylineMap oracle;
  oracle.loadFromSimpleMap(simplemap);
  const PolylineMap& start =
      continued.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>()->Map();
  ASSERT_EQ(start.NumPolylines(), oracle.Map().NumPolylines());
  EXPECT_EQ(start.NumVertices(), oracle.Map().NumVertices());
  const mrpt::poses::CPose3D at_start = continued.getCurrentPoseEstimation()->getMeanVal();
  const mrpt::poses::CPose3D last_frame = simplemap.rbegin()->pose->getMeanVal();
  EXPECT_EQ(at_start.x(), last_frame.x());
  EXPECT_EQ(at_start.y(), last_frame.y());
  EXPECT_EQ(continued.getCurrentlyBuiltMapSize(), simplemap.size());

  // The rest of the log from the last keyframe on, against the whole log mapped at once. The
  // continued builder holds the loaded map fixed (a frozen submap it anchors its keyframes to),
  // while the whole run's pose graph moves its early part when it closes the loop (by up to
  // 0.5 m): the two trajectories agree up to one rigid motion and that bend (measured: 126
  // scans, RMS 0.155 m, max 0.316 m; the global design, continuing in one map: 0.112, 0.260).
  const std::size_t last_keyframe_step = kSteps - 1;  // a keyframe every few steps: close by
  FeedLikeIcpSlam(continued, kSenaLog, SIZE_MAX, last_keyframe_step);
  CMetricMapBuilderShape whole;
  FeedLikeIcpSlam(whole, kSenaLog);
  EXPECT_GT(continued.Mapper().NumKeyframesInLoadedMap(), 10);
  const Agreement agreement =
      RigidAgreement(continued.Mapper().Trajectory(), whole.Mapper().Trajectory());
  EXPECT_GE(agreement.common, 100u);
  EXPECT_LT(agreement.rms_m, 0.2);
  EXPECT_LT(agreement.max_m, 0.4);
  mrpt::maps::CSimpleMap out;
  continued.getCurrentlyBuiltMap(out);
  EXPECT_EQ(out.size(), simplemap.size() + continued.Mapper().Keyframes().size());
}

TEST(CMetricMapBuilderShape, InitializeFromAMapStartsThereAndRefusesNothingToStartFrom) {
  CMetricMapBuilderShape first;
  FeedLikeIcpSlam(first, kObsOnlyLog);
  const PolylineMap map = first.Mapper().Map();
  CMetricMapBuilderShape seeded;
  const Pose2 T_world_robot(0.3, -0.1, 0.2);
  seeded.InitializeFromMap(map, T_world_robot);
  EXPECT_EQ(seeded.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>()->Map().NumPolylines(),
            map.NumPolylines());
  EXPECT_EQ(seeded.getCurrentPoseEstimation()->getMeanVal().x(), T_world_robot.x);
  EXPECT_THROW(seeded.InitializeFromMap(PolylineMap(), Pose2()), std::invalid_argument);
  EXPECT_THROW(seeded.InitializeFromMap(map, Pose2(NAN, 0.0, 0.0)), std::invalid_argument);
  // A simplemap whose frames hold no laser scan gives no map.
  mrpt::maps::CSimpleMap no_scans;
  no_scans.insert(mrpt::poses::CPose3DPDFGaussian::Create(mrpt::poses::CPose3D()),
                  mrpt::obs::CSensoryFrame::Create());
  EXPECT_THROW(seeded.initialize(no_scans), std::invalid_argument);
  seeded.initialize();  // restarts empty
  EXPECT_EQ(seeded.getCurrentlyBuiltMapSize(), 0u);
  EXPECT_TRUE(seeded.Mapper().Map().Empty());
}

// Every polyline's vertices, sorted: two maps with the same polylines (whatever their ids).
std::vector<std::vector<std::pair<double, double>>> AllPolylines(const PolylineMap& map) {
  std::vector<std::vector<std::pair<double, double>>> all;
  for (const PolylineId id : map.Ids()) {
    all.emplace_back();
    for (const Point2& p : map.Get(id).points) all.back().emplace_back(p.x(), p.y());
  }
  std::sort(all.begin(), all.end());
  return all;
}

// Localization mode (StartLocalization): the map of a first pass is frozen; the same log fed
// again is localized in it by the global search (no pose given) and then tracked, the poses
// those of the mapping pass; the map never changes and nothing is built. With the first pose
// given the first scan is localized. initialize() returns to mapping.
TEST(CMetricMapBuilderShape, LocalizationModeTracksInAFrozenMap) {
  if (!Readable(kSenaLog)) GTEST_SKIP() << kSenaLog << " missing (package mrpt-common)";
  CMetricMapBuilderShape mapping;
  FeedLikeIcpSlam(mapping, kSenaLog);
  mapping.Finish();
  const PolylineMap map = mapping.Mapper().Map();
  const std::vector<StampedPose> mapped = mapping.Mapper().Trajectory();
  ASSERT_GT(mapped.size(), 200u);

  for (const bool with_pose : {false, true}) {
    SCOPED_TRACE(with_pose ? "first pose given" : "global search");
    CMetricMapBuilderShape localizing;
    if (with_pose) {
      localizing.StartLocalization(map, mapped.front().pose);
    } else {
      localizing.StartLocalization(map);
    }
    ASSERT_TRUE(localizing.Localizing());
    EXPECT_EQ(localizing.getCurrentPoseEstimation()->getMeanVal().x(),
              with_pose ? mapped.front().pose.x : 0.0);
    std::size_t scans = 0, localized = 0, agree = 0;
    mrpt::io::CFileGZInputStream file(kSenaLog);
    auto archive = mrpt::serialization::archiveFrom(file);
    for (;;) {
      mrpt::serialization::CSerializable::Ptr entry;
      try {
        archive >> entry;
      } catch (const mrpt::serialization::CExceptionEOF&) {
        break;
      }
      if (!localizing.ProcessRawlogEntry(entry)) continue;
      const LocalizerReport& report = *localizing.LastLocalizerReport();
      if (scans == 0 && with_pose) {
        EXPECT_TRUE(report.localized);
      }
      const Pose2& truth = mapped.at(scans++).pose;
      if (!report.localized) continue;
      ++localized;
      agree += (report.T_map_robot.Translation() - truth.Translation()).norm() <= 0.10 ? 1 : 0;
      const mrpt::poses::CPose3D estimate = localizing.getCurrentPoseEstimation()->getMeanVal();
      EXPECT_NEAR(estimate.x(), report.T_map_robot.x, 1e-9);  // no odometry after the scan yet
    }
    EXPECT_EQ(scans, mapped.size());
    EXPECT_GE(localized, scans * 95 / 100);
    EXPECT_GE(agree, localized * 95 / 100);
    EXPECT_EQ(localizing.getCurrentlyBuiltMapSize(), 0u);
    mrpt::maps::CSimpleMap built;
    localizing.getCurrentlyBuiltMap(built);
    EXPECT_TRUE(built.empty());
    const PolylineMap& frozen =
        localizing.getCurrentlyBuiltMetricMap()->mapByClass<CPolylineMap>()->Map();
    EXPECT_EQ(AllPolylines(frozen), AllPolylines(map));
  }

  CMetricMapBuilderShape localizing;
  EXPECT_THROW(localizing.StartLocalization(PolylineMap()), std::invalid_argument);
  EXPECT_THROW(localizing.StartLocalization(map, Pose2(NAN, 0.0, 0.0)), std::invalid_argument);
  EXPECT_FALSE(localizing.Localizing());
  localizing.StartLocalization(map);
  localizing.initialize();
  EXPECT_FALSE(localizing.Localizing());
}

TEST(CMetricMapBuilderShape, LoadsOptionsFromAnIniSection) {
  CMetricMapBuilderShape builder;
  builder.LoadOptions(mrpt::config::CConfigFileMemory("[slam]\nuse_odometry=false\n"), "slam");
  EXPECT_FALSE(builder.GetOptions().params.use_odometry);
  const std::string params = std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/../../config/default.ini";
  builder.LoadOptions(mrpt::config::CConfigFileMemory("[slam]\nparams_file=" + params + "\n"),
                      "slam");
  EXPECT_TRUE(builder.GetOptions().params.use_odometry);
  EXPECT_THROW(
      builder.LoadOptions(mrpt::config::CConfigFileMemory("[slam]\nuse_odometri=1\n"), "slam"),
      std::invalid_argument);
  EXPECT_THROW(builder.LoadOptions(
                   mrpt::config::CConfigFileMemory("[slam]\nparams_file=/nonexistent.ini\n"),
                   "slam"),
               std::invalid_argument);
}

TEST(CMetricMapBuilderShape, SavesAPicture) {
  CMetricMapBuilderShape builder;
  FeedLikeIcpSlam(builder, kObsOnlyLog);
  const std::string png = ::testing::TempDir() + "/map_builder_shape_test.png";
  builder.saveCurrentEstimationToImage(png);
  std::ifstream in(png, std::ios::binary);
  std::string head(8, '\0');
  in.read(head.data(), 8);
  EXPECT_EQ(head.substr(1, 3), "PNG");
}

}  // namespace
}  // namespace shape_slam
