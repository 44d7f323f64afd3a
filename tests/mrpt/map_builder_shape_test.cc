// CMetricMapBuilderShape fed the way icp-slam feeds CMetricMapBuilderICP, against the mapper fed
// by shape_slam_io's rawlog reader (what `shape-slam run` does): same scans, same poses.
#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/maps/CSimpleMap.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPosePDFGaussian.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
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

// icp-slam's loop over (the first max_entries entries of) a rawlog; returns the pose estimate
// after every entry.
std::vector<mrpt::poses::CPose3D> FeedLikeIcpSlam(CMetricMapBuilderShape& builder,
                                                  const std::string& path,
                                                  std::size_t max_entries = SIZE_MAX) {
  mrpt::io::CFileGZInputStream file(path);
  auto archive = mrpt::serialization::archiveFrom(file);
  std::vector<mrpt::poses::CPose3D> poses;
  std::size_t entry = 0;
  while (poses.size() < max_entries) {
    mrpt::obs::CActionCollection::Ptr actions;
    mrpt::obs::CSensoryFrame::Ptr frame;
    mrpt::obs::CObservation::Ptr observation;
    if (!mrpt::obs::CRawlog::getActionObservationPairOrObservation(archive, actions, frame,
                                                                   observation, entry)) {
      break;
    }
    if (observation) {
      builder.processObservation(observation);
    } else {
      builder.processActionObservation(*actions, *frame);
    }
    poses.push_back(builder.getCurrentPoseEstimation()->getMeanVal());
  }
  return poses;
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
  ASSERT_EQ(expected.size(), 224u);
  ExpectSameTrajectory(builder.Mapper().Trajectory(), expected);
  EXPECT_EQ(builder.SkippedScans(), 0);
  EXPECT_EQ(builder.Mapper().Odometry().status, OdometryStatus::kUsed);
  EXPECT_EQ(builder.Mapper().Map().NumPolylines(), reference.Map().NumPolylines());
  EXPECT_EQ(online.size(), 224u);  // one pair per scan in this log
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

TEST(CMetricMapBuilderShape, InitializeFromANonEmptyMapIsRefused) {
  CMetricMapBuilderShape builder;
  FeedLikeIcpSlam(builder, kObsOnlyLog);
  mrpt::maps::CSimpleMap simplemap;
  builder.getCurrentlyBuiltMap(simplemap);
  EXPECT_THROW(builder.initialize(simplemap), std::invalid_argument);
  builder.initialize();  // restarts empty
  EXPECT_EQ(builder.getCurrentlyBuiltMapSize(), 0u);
  EXPECT_TRUE(builder.Mapper().Trajectory().empty());
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
