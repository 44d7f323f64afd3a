// CARMEN -> observations-only rawlog (rawlog_writer.h): reading the rawlog back gives the same
// scans (timestamps, beam directions in the robot frame, ranges, odometry); an existing output
// is left untouched when the conversion fails.
#include "shape_slam_io/rawlog_writer.h"

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace shape_slam::io
