// CARMEN -> observations-only rawlog (rawlog_writer.h): reading the rawlog back gives the same
// scans (timestamps, beam directions in the robot frame, ranges, odometry); an existing output
// is left untouched when the conversion fails. CARMEN -> action-observation pairs, read back by
// MRPT itself: one pair per scan, the log's timestamps on action and scan, the increments
// composing to the log's odometry, zero increments for a log without motion.
#include "shape_slam_io/rawlog_writer.h"

#include <gtest/gtest.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>

#include <cmath>

#include "shape_slam_io/atomic_file.h"
#include "shape_slam_io/carmen_reader.h"
#include "shape_slam_io/rawlog_reader.h"
#include "io/test_files.h"

namespace shape_slam::io {
namespace {

void ExpectSameScans(const std::string& carmen_path) {
  testing::TempDir dir;
  const std::vector<LaserScan> original = ReadAllScans(carmen_path);
  CarmenReader reader(carmen_path);
  const RawlogWriteStats stats = WriteObservationsRawlog(reader, dir.Path("out.rawlog"));
  ASSERT_EQ(stats.scans, original.size());
  RawlogReader back(dir.Path("out.rawlog"));
  std::size_t k = 0;
  while (const std::optional<LaserScan> scan = back.Next()) {
    ASSERT_LT(k, original.size());
    const LaserScan& a = original[k++];
    SCOPED_TRACE("scan " + std::to_string(k - 1) + " of " + carmen_path);
    EXPECT_NEAR(scan->timestamp_s, a.timestamp_s, 1e-6);  // MRPT's clock: 100 ns ticks
    ASSERT_EQ(scan->ranges_m.size(), a.ranges_m.size());
    EXPECT_NEAR(scan->max_range_m, a.max_range_m, 1e-5 * a.max_range_m);
    for (std::size_t i = 0; i < a.ranges_m.size(); ++i) {
      const bool valid = std::isfinite(a.ranges_m[i]) && a.ranges_m[i] > 0.0 &&
                         a.ranges_m[i] < a.max_range_m;
      if (valid) {
        EXPECT_NEAR(scan->ranges_m[i], a.ranges_m[i], 1e-6 * a.ranges_m[i]) << "beam " << i;
      } else {
        EXPECT_TRUE(std::isnan(scan->ranges_m[i])) << "beam " << i;
      }
      // Beam direction and origin in the robot frame.
      const Pose2 beam_a = a.T_robot_sensor * Pose2(0, 0, a.angles_rad[i]);
      const Pose2 beam_b = scan->T_robot_sensor * Pose2(0, 0, scan->angles_rad[i]);
      EXPECT_NEAR(NormalizeAngle(beam_b.theta - beam_a.theta), 0.0, 1e-5) << "beam " << i;
      EXPECT_NEAR(beam_b.x, beam_a.x, 1e-9);
      EXPECT_NEAR(beam_b.y, beam_a.y, 1e-9);
    }
    ASSERT_EQ(scan->T_odom_robot.has_value(), a.T_odom_robot.has_value());
    if (a.T_odom_robot) {
      EXPECT_NEAR(scan->T_odom_robot->x, a.T_odom_robot->x, 1e-9);
      EXPECT_NEAR(scan->T_odom_robot->y, a.T_odom_robot->y, 1e-9);
      EXPECT_NEAR(NormalizeAngle(scan->T_odom_robot->theta - a.T_odom_robot->theta), 0.0, 1e-9);
    }
  }
  EXPECT_EQ(k, original.size());
}

TEST(RawlogWriterTest, FlaserLogRoundTrips) {
  ExpectSameScans(SHAPE_SLAM_TEST_DATA_DIR "/logs/intel_head.log");
}

TEST(RawlogWriterTest, OddBeamCountsAndRobotLaserRoundTrip) {
  ExpectSameScans(SHAPE_SLAM_TEST_DATA_DIR "/logs/flaser_181_361.log");
  ExpectSameScans(SHAPE_SLAM_TEST_DATA_DIR "/logs/robotlaser1.log");
}

TEST(RawlogWriterTest, FailedConversionLeavesTheExistingOutputAlone) {
  testing::TempDir dir;
  const std::string out = dir.Write("out.rawlog", "precious");
  // A log whose second FLASER record is malformed: strict reading fails mid-way.
  const std::string log = dir.Write(
      "bad.log",
      "FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 1.0 host 1.0\n"
      "FLASER 3 1.0 oops 1.0 0 0 0 0 0 0 2.0 host 2.0\n");
  EXPECT_THROW(
      {
        CarmenReader reader(log, LogReaderOptions{true});
        WriteObservationsRawlog(reader, out);
      },
      LogError);
  EXPECT_EQ(testing::ReadFile(out), "precious");
}

// One action-observation pair of a rawlog, as MRPT's CRawlog loads it.
struct MrptPair {
  mrpt::obs::CActionRobotMovement2D::Ptr movement;
  std::vector<mrpt::obs::CObservation2DRangeScan::Ptr> scans;
};

// The pairs of an actions / sensory-frames rawlog; fails the test on any other layout.
std::vector<MrptPair> ReadPairsWithMrpt(const std::string& path) {
  mrpt::obs::CRawlog rawlog;
  EXPECT_TRUE(rawlog.loadFromRawLogFile(path));
  EXPECT_EQ(rawlog.size() % 2, 0u);
  std::vector<MrptPair> pairs;
  for (std::size_t i = 0; i + 1 < rawlog.size(); i += 2) {
    EXPECT_EQ(rawlog.getType(i), mrpt::obs::CRawlog::etActionCollection) << "entry " << i;
    EXPECT_EQ(rawlog.getType(i + 1), mrpt::obs::CRawlog::etSensoryFrame) << "entry " << i + 1;
    if (rawlog.getType(i) != mrpt::obs::CRawlog::etActionCollection ||
        rawlog.getType(i + 1) != mrpt::obs::CRawlog::etSensoryFrame) {
      break;
    }
    const mrpt::obs::CSensoryFrame::Ptr frame = rawlog.getAsObservations(i + 1);
    MrptPair pair{rawlog.getAsAction(i)->getBestMovementEstimation(), {}};
    for (std::size_t k = 0; k < frame->size(); ++k) {
      pair.scans.push_back(frame->getObservationByClass<mrpt::obs::CObservation2DRangeScan>(k));
      if (!pair.scans.back()) pair.scans.pop_back();
    }
    pairs.push_back(pair);
  }
  return pairs;
}

TEST(RawlogWriterTest, PairsHoldOneActionAndScanPerScanWithTheLogsTimestampsAndIncrements) {
  testing::TempDir dir;
  const std::string log = SHAPE_SLAM_TEST_DATA_DIR "/logs/intel_head.log";
  const std::vector<LaserScan> original = ReadAllScans(log);
  ASSERT_GE(original.size(), 3u);
  CarmenReader reader(log);
  const RawlogWriteStats stats = WritePairsRawlog(reader, dir.Path("pairs.rawlog"));
  EXPECT_EQ(stats.scans, original.size());
  EXPECT_EQ(stats.odometry, original.size());
  const std::vector<MrptPair> pairs = ReadPairsWithMrpt(dir.Path("pairs.rawlog"));
  ASSERT_EQ(pairs.size(), original.size());
  mrpt::poses::CPose2D T_first_robot;  // the increments composed
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    SCOPED_TRACE("pair " + std::to_string(k));
    ASSERT_TRUE(pairs[k].movement);
    ASSERT_EQ(pairs[k].scans.size(), 1u);
    EXPECT_NEAR(mrpt::Clock::toDouble(pairs[k].movement->timestamp), original[k].timestamp_s,
                1e-6);
    EXPECT_NEAR(mrpt::Clock::toDouble(pairs[k].scans[0]->timestamp), original[k].timestamp_s,
                1e-6);
    T_first_robot = T_first_robot + pairs[k].movement->poseChange->getMeanVal();
    const Pose2 expected = original[0].T_odom_robot->Inverse() * *original[k].T_odom_robot;
    EXPECT_NEAR(T_first_robot.x(), expected.x, 1e-9);
    EXPECT_NEAR(T_first_robot.y(), expected.y, 1e-9);
    EXPECT_NEAR(NormalizeAngle(T_first_robot.phi() - expected.theta), 0.0, 1e-9);
  }
  // Some increment is not zero: the log's robot moves.
  EXPECT_GT(std::abs(T_first_robot.x()) + std::abs(T_first_robot.phi()), 0.01);
}

TEST(RawlogWriterTest, PairsOfALogWithoutMotionHaveZeroIncrements) {
  testing::TempDir dir;
  const std::string log = dir.Write(
      "still.log",
      "FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 1.0 host 1.0\n"
      "FLASER 3 1.0 1.5 1.0 0 0 0 0 0 0 2.0 host 2.0\n");
  CarmenReader reader(log);
  const RawlogWriteStats stats = WritePairsRawlog(reader, dir.Path("pairs.rawlog"));
  EXPECT_EQ(stats.scans, 2u);
  const std::vector<MrptPair> pairs = ReadPairsWithMrpt(dir.Path("pairs.rawlog"));
  ASSERT_EQ(pairs.size(), 2u);
  for (const MrptPair& pair : pairs) {
    ASSERT_TRUE(pair.movement);
    const mrpt::poses::CPose2D increment = pair.movement->poseChange->getMeanVal();
    EXPECT_EQ(increment.x(), 0.0);
    EXPECT_EQ(increment.y(), 0.0);
    EXPECT_EQ(increment.phi(), 0.0);
  }
  EXPECT_NEAR(mrpt::Clock::toDouble(pairs[1].scans.at(0)->timestamp), 2.0, 1e-6);
}

}  // namespace
}  // namespace shape_slam::io
