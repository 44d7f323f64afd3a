// Issue 13: one CObservation2DRangeScan -> LaserScan conversion (shape_slam_io/mrpt_scan.h). A
// scan read from a rawlog by the rawlog reader and the same scan handed to the MRPT map classes
// (shape_slam_mrpt/conversions.h) are the same LaserScan, invalid beams included.
#include <gtest/gtest.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include "mrpt/mrpt_test_scenes.h"
#include "shape_slam_io/mrpt_scan.h"
#include "shape_slam_io/rawlog_reader.h"
#include "shape_slam_mrpt/conversions.h"

namespace shape_slam {
namespace {

// A left-to-right scan on a rotated, offset mount with every kind of invalid beam.
mrpt::obs::CObservation2DRangeScan ScanWithInvalidBeams() {
  mrpt::obs::CObservation2DRangeScan obs = testing::SimulateScan({0.5, -0.3, 0.4});
  obs.rightToLeft = false;
  obs.sensorPose = mrpt::poses::CPose3D(0.3, -0.1, 0.25, 2.9, 0.0, 0.0);
  obs.setScanRangeValidity(3, false);                                    // flagged invalid
  obs.setScanRange(10, std::numeric_limits<float>::quiet_NaN());        // valid flag, NaN
  obs.setScanRange(11, -1.0f);                                           // valid flag, negative
  obs.setScanRange(12, std::numeric_limits<float>::infinity());         // valid flag, inf
  obs.setScanRange(20, obs.maxRange + 5.0f);                             // beyond maxRange: kept
  return obs;
}

LaserScan ReadBack(const mrpt::obs::CObservation2DRangeScan& obs, std::size_t* invalid_ranges) {
  const std::string path = ::testing::TempDir() + "/scan_conversion_test.rawlog";
  {
    mrpt::io::CFileOutputStream output(path);
    auto archive = mrpt::serialization::archiveFrom(output);
    archive << obs;
  }
  io::RawlogReader reader(path);
  std::optional<LaserScan> scan = reader.Next();
  *invalid_ranges = reader.Stats().invalid_ranges;
  std::filesystem::remove(path);
  if (!scan) throw std::runtime_error("no scan read back");
  return *scan;
}

TEST(ScanConversion, RawlogReaderAndMapClassesGiveTheSameLaserScan) {
  const mrpt::obs::CObservation2DRangeScan obs = ScanWithInvalidBeams();
  std::size_t reader_invalid = 0;
  const LaserScan read = ReadBack(obs, &reader_invalid);
  const LaserScan plugin = ToLaserScan(obs);
  ASSERT_EQ(read.ranges_m.size(), plugin.ranges_m.size());
  ASSERT_EQ(read.angles_rad.size(), plugin.angles_rad.size());
  for (std::size_t i = 0; i < read.ranges_m.size(); ++i) {
    EXPECT_EQ(std::isnan(read.ranges_m[i]), std::isnan(plugin.ranges_m[i])) << i;
    if (!std::isnan(read.ranges_m[i])) {
      EXPECT_EQ(read.ranges_m[i], plugin.ranges_m[i]) << i;
    }
    EXPECT_EQ(read.angles_rad[i], plugin.angles_rad[i]) << i;
  }
  EXPECT_EQ(read.max_range_m, plugin.max_range_m);
  EXPECT_EQ(read.T_robot_sensor.x, plugin.T_robot_sensor.x);
  EXPECT_EQ(read.T_robot_sensor.y, plugin.T_robot_sensor.y);
  EXPECT_EQ(read.T_robot_sensor.theta, plugin.T_robot_sensor.theta);
  EXPECT_EQ(read.timestamp_s, plugin.timestamp_s);
  EXPECT_FALSE(plugin.T_odom_robot.has_value());
  EXPECT_EQ(reader_invalid, io::FromMrptScan(obs).invalid_ranges);
}

TEST(ScanConversion, InvalidBeamsBecomeNaNAndTheRestFollowsMrptsGeometry) {
  const mrpt::obs::CObservation2DRangeScan obs = ScanWithInvalidBeams();
  const io::ConvertedMrptScan converted = io::FromMrptScan(obs);
  const LaserScan& scan = converted.scan;
  for (const std::size_t i : {3, 10, 11, 12}) EXPECT_TRUE(std::isnan(scan.ranges_m[i])) << i;
  EXPECT_EQ(converted.invalid_ranges, 3u);  // the flagged-invalid beam is not counted
  EXPECT_FLOAT_EQ(static_cast<float>(scan.ranges_m[20]), obs.maxRange + 5.0f);
  EXPECT_EQ(scan.ranges_m[0], obs.getScanRange(0));
  // Left to right: beam 0 at +aperture/2, decreasing; as getScanAngle.
  for (const std::size_t i : {0, 100, 360}) {
    EXPECT_NEAR(scan.angles_rad[i], obs.getScanAngle(i), 1e-6) << i;
  }
  EXPECT_GT(scan.angles_rad.front(), scan.angles_rad.back());
  EXPECT_DOUBLE_EQ(scan.T_robot_sensor.x, 0.3);
  EXPECT_DOUBLE_EQ(scan.T_robot_sensor.y, -0.1);
  EXPECT_NEAR(scan.T_robot_sensor.theta, 2.9, 1e-12);
  EXPECT_EQ(scan.max_range_m, obs.maxRange);
}

TEST(ScanConversion, UnusableScansAreClearErrorsOnBothPaths) {
  mrpt::obs::CObservation2DRangeScan obs = testing::SimulateScan({0, 0, 0});
  obs.aperture = 0.0f;
  EXPECT_THROW(io::FromMrptScan(obs), std::invalid_argument);
  EXPECT_THROW(ToLaserScan(obs), std::invalid_argument);
  obs = testing::SimulateScan({0, 0, 0});
  obs.maxRange = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(ToLaserScan(obs), std::invalid_argument);
  obs = testing::SimulateScan({0, 0, 0});
  obs.resizeScan(0);
  EXPECT_THROW(ToLaserScan(obs), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
