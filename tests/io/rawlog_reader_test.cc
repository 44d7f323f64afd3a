#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "io/test_files.h"
#include "shape_slam_io/log_reader.h"

#ifdef SHAPE_SLAM_HAVE_MRPT
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileInputStream.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservation2DRangeScan.h>
#include <mrpt/obs/CObservationComment.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <vector>

#include "shape_slam_io/rawlog_reader.h"
#endif

namespace shape_slam::io {
namespace {

using ::testing::HasSubstr;
using testing::ReadFile;
using testing::TempDir;
using ::testing::ThrowsMessage;

const std::string kLogs = std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/logs";
const std::string kFixtureGz = kLogs + "/sena_first20_obs_only.rawlog";
const std::string kFixturePlain = kLogs + "/sena_first20_obs_only_plain.rawlog";

#ifndef SHAPE_SLAM_HAVE_MRPT

TEST(RawlogReaderTest, RawlogsNeedMrpt) {
  for (const std::string& path : {kFixtureGz, kFixturePlain}) {
    EXPECT_THAT([&] { OpenLog(path); }, ThrowsMessage<LogError>(HasSubstr("built without MRPT")));
  }
}

#else

using mrpt::obs::CObservation2DRangeScan;
using mrpt::serialization::CSerializable;

// MRPT's sample log (mrpt-common): actions/sensory-frames layout, 225 frames, 224 actions.
const std::string kSena =
    "/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog";

std::vector<LaserScan> ReadAll(LogReader& reader) {
  std::vector<LaserScan> scans;
  while (std::optional<LaserScan> scan = reader.Next()) scans.push_back(std::move(*scan));
  return scans;
}

// The oracle: a log read with MRPT's own CRawlog::getActionObservationPairOrObservation, with
// the odometry increments composed by MRPT's CPose2D.
struct MrptScan {
  CObservation2DRangeScan::Ptr scan;
  mrpt::poses::CPose2D odometry;
};

std::vector<MrptScan> ReadWithMrpt(const std::string& path) {
  mrpt::io::CFileGZInputStream input(path);
  auto archive = mrpt::serialization::archiveFrom(input);
  mrpt::obs::CActionCollection::Ptr actions;
  mrpt::obs::CSensoryFrame::Ptr frame;
  mrpt::obs::CObservation::Ptr observation;
  std::size_t entry = 0;
  mrpt::poses::CPose2D odometry;
  std::vector<MrptScan> scans;
  while (mrpt::obs::CRawlog::getActionObservationPairOrObservation(archive, actions, frame,
                                                                   observation, entry)) {
    if (!actions || !frame) continue;
    if (const auto movement = actions->getBestMovementEstimation()) {
      odometry = odometry + movement->poseChange->getMeanVal();
    }
    for (const auto& obs : *frame) {
      if (auto scan = std::dynamic_pointer_cast<CObservation2DRangeScan>(obs)) {
        scans.push_back({scan, odometry});
      }
    }
  }
  return scans;
}

void ExpectSameRanges(const LaserScan& scan, const CObservation2DRangeScan& obs) {
  ASSERT_EQ(scan.ranges_m.size(), obs.getScanSize());
  for (std::size_t i = 0; i < obs.getScanSize(); ++i) {
    if (obs.getScanRangeValidity(i)) {
      EXPECT_EQ(scan.ranges_m[i], static_cast<double>(obs.getScanRange(i))) << i;
    } else {
      EXPECT_TRUE(std::isnan(scan.ranges_m[i])) << i;
    }
  }
}

void ExpectPose(const Pose2& pose, double x, double y, double theta, double tolerance) {
  EXPECT_NEAR(pose.x, x, tolerance);
  EXPECT_NEAR(pose.y, y, tolerance);
  EXPECT_NEAR(NormalizeAngle(pose.theta - theta), 0.0, tolerance);
}

// Beam angles equal getScanAngle, and the scan's points in the robot frame equal the points
// MRPT's own points map makes of the observation (sensorPose applied, invalid beams left out).
void ExpectSameGeometryAsMrpt(const LaserScan& scan, const CObservation2DRangeScan& obs) {
  ASSERT_EQ(scan.angles_rad.size(), obs.getScanSize());
  for (std::size_t i = 0; i < obs.getScanSize(); ++i) {
    EXPECT_NEAR(scan.angles_rad[i], obs.getScanAngle(i), 1e-6) << i;
  }
  mrpt::maps::CSimplePointsMap map;
  map.insertionOptions.minDistBetweenLaserPoints = 0.0f;
  map.loadFromRangeScan(obs);
  std::vector<Point2> ours;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    const double r = scan.ranges_m[i];
    if (!std::isfinite(r)) continue;
    ours.push_back(scan.T_robot_sensor *
                   Point2(r * std::cos(scan.angles_rad[i]), r * std::sin(scan.angles_rad[i])));
  }
  ASSERT_EQ(ours.size(), map.size());
  for (std::size_t k = 0; k < ours.size(); ++k) {
    float x = 0, y = 0;
    map.getPoint(k, x, y);
    EXPECT_NEAR(ours[k].x(), x, 2e-4) << k;
    EXPECT_NEAR(ours[k].y(), y, 2e-4) << k;
  }
}

void WriteRawlog(const std::string& path, const std::vector<CSerializable::Ptr>& entries) {
  mrpt::io::CFileOutputStream output(path);
  auto archive = mrpt::serialization::archiveFrom(output);
  for (const CSerializable::Ptr& entry : entries) archive << *entry;
}

CObservation2DRangeScan::Ptr CopyOfFirstSenaScan() {
  return std::make_shared<CObservation2DRangeScan>(*ReadWithMrpt(kSena).front().scan);
}

// ----------------------------------------------------------------------------------------------
// The real sample log.

TEST(RawlogReaderTest, SampleLogScansBeamsMountingAndOdometry) {
  const std::unique_ptr<LogReader> reader = OpenLog(kSena);
  EXPECT_EQ(reader->Format(), "rawlog");
  const std::vector<LaserScan> scans = ReadAll(*reader);
  ASSERT_EQ(scans.size(), 225u);
  for (const LaserScan& scan : scans) {
    ASSERT_EQ(scan.ranges_m.size(), 361u);
    EXPECT_EQ(scan.max_range_m, 80.0);
    ExpectPose(scan.T_robot_sensor, 0.78, 0.0, 0.0, 1e-6);
    ASSERT_TRUE(scan.T_odom_robot.has_value());
  }
  EXPECT_NEAR(scans.front().angles_rad.front(), -M_PI_2, 1e-6);
  EXPECT_NEAR(scans.front().angles_rad.back(), M_PI_2, 1e-6);
  EXPECT_GT(scans.front().timestamp_s, 1.1e9);  // January 2006, seconds since 1970
  EXPECT_LT(scans.front().timestamp_s, 1.2e9);
  // The first entry is a sensory frame before any action (MRPT's CRawlog drops it): used, at
  // the odometry origin, and nothing to warn about.
  ExpectPose(*scans.front().T_odom_robot, 0.0, 0.0, 0.0, 0.0);
  const LogReaderStats& stats = reader->Stats();
  EXPECT_EQ(stats.scans, 225u);
  EXPECT_EQ(stats.skipped_records, 0u);
  EXPECT_EQ(stats.non_monotonic_timestamps, 0u);
  EXPECT_TRUE(stats.issues.empty());
}

// MRPT's CRawlog drops the first frame (no action before it); every later scan is the same.
TEST(RawlogReaderTest, SampleLogMatchesMrptsOwnReadingScanByScan) {
  const std::vector<MrptScan> expected = ReadWithMrpt(kSena);
  RawlogReader reader(kSena);
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), expected.size() + 1);
  EXPECT_LT(scans[0].timestamp_s, mrpt::Clock::toDouble(expected[0].scan->timestamp));
  for (std::size_t k = 0; k < expected.size(); ++k) {
    SCOPED_TRACE(k);
    const CObservation2DRangeScan& obs = *expected[k].scan;
    EXPECT_EQ(scans[k + 1].timestamp_s, mrpt::Clock::toDouble(obs.timestamp));
    ExpectSameRanges(scans[k + 1], obs);
    const mrpt::poses::CPose2D& odometry = expected[k].odometry;
    ExpectPose(*scans[k + 1].T_odom_robot, odometry.x(), odometry.y(), odometry.phi(), 1e-9);
  }
  // The robot drives a loop of tens of metres: the odometry is really accumulated.
  EXPECT_GT(std::hypot(expected[112].odometry.x(), expected[112].odometry.y()), 5.0);
  for (std::size_t k = 0; k < expected.size(); k += 37) {
    SCOPED_TRACE(k);
    ExpectSameGeometryAsMrpt(scans[k + 1], *expected[k].scan);
  }
}

TEST(RawlogReaderTest, LeftToRightScanWithRotatedMountingMatchesMrptGeometry) {
  TempDir dir;
  auto obs = CopyOfFirstSenaScan();
  obs->rightToLeft = false;
  obs->sensorPose = mrpt::poses::CPose3D(0.1, -0.2, 0.3, 0.4, 0.0, 0.0);
  obs->setScanRange(5, -2.0f);  // valid flag, impossible value: NaN and counted
  obs->setScanRangeValidity(5, true);
  const std::string path = dir.Path("left_to_right.rawlog");
  WriteRawlog(path, {obs});
  RawlogReader reader(path);
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_NEAR(scans[0].angles_rad.front(), M_PI_2, 1e-6);
  ExpectPose(scans[0].T_robot_sensor, 0.1, -0.2, 0.4, 1e-6);
  EXPECT_FALSE(scans[0].T_odom_robot.has_value());  // no odometry in this log
  EXPECT_TRUE(std::isnan(scans[0].ranges_m[5]));
  EXPECT_EQ(reader.Stats().invalid_ranges, 1u);
  obs->setScanRangeValidity(5, false);  // MRPT's points map would insert -2 m
  ExpectSameGeometryAsMrpt(scans[0], *obs);
}

// ----------------------------------------------------------------------------------------------
// The observations-only fixtures (scripts/rawlog_fixtures).

TEST(RawlogReaderTest, ObservationsOnlyFixturesGzipAndPlainMatchTheSourceLog) {
  const std::vector<MrptScan> source = ReadWithMrpt(kSena);
  for (const std::string& path : {kFixtureGz, kFixturePlain}) {
    SCOPED_TRACE(path);
    const std::unique_ptr<LogReader> reader = OpenLog(path);
    EXPECT_EQ(reader->Format(), "rawlog");
    const std::vector<LaserScan> scans = ReadAll(*reader);
    ASSERT_EQ(scans.size(), 20u);
    EXPECT_FALSE(scans[0].T_odom_robot.has_value());  // before the first odometry entry
    for (std::size_t k = 0; k < scans.size(); ++k) {
      SCOPED_TRACE(k);
      ExpectSameRanges(scans[k], *source[k].scan);
      EXPECT_EQ(scans[k].timestamp_s, mrpt::Clock::toDouble(source[k].scan->timestamp));
      if (k == 0) continue;
      ASSERT_TRUE(scans[k].T_odom_robot.has_value());
      const mrpt::poses::CPose2D& odometry = source[k].odometry;
      ExpectPose(*scans[k].T_odom_robot, odometry.x(), odometry.y(), odometry.phi(), 1e-9);
    }
    EXPECT_TRUE(reader->Stats().issues.empty());  // the comment entry is skipped silently
  }
}

TEST(RawlogReaderTest, DetectedFromTheContentWhateverTheExtension) {
  TempDir dir;
  for (const std::string& source : {kFixtureGz, kFixturePlain}) {
    const std::string path = dir.Write("misnamed.log", ReadFile(source));
    const std::unique_ptr<LogReader> reader = OpenLog(path);
    EXPECT_EQ(reader->Format(), "rawlog");
    EXPECT_EQ(ReadAll(*reader).size(), 20u);
  }
}

// ----------------------------------------------------------------------------------------------
// Truncated, corrupt and unusable rawlogs.

// Where each entry of an uncompressed rawlog ends, and which entries are laser scans.
struct EntryLayout {
  std::vector<uint64_t> ends;
  std::vector<bool> is_scan;
};

EntryLayout LayoutOf(const std::string& plain_path) {
  mrpt::io::CFileInputStream input(plain_path);
  auto archive = mrpt::serialization::archiveFrom(input);
  EntryLayout layout;
  while (input.getPosition() < input.getTotalBytesCount()) {
    const CSerializable::Ptr object = archive.ReadObject();
    layout.ends.push_back(input.getPosition());
    layout.is_scan.push_back(std::dynamic_pointer_cast<CObservation2DRangeScan>(object) != nullptr);
  }
  return layout;
}

TEST(RawlogReaderTest, TruncatedRawlogNamesTheEntryWhenStrictAndEndsWithAnIssueOtherwise) {
  TempDir dir;
  const std::string bytes = ReadFile(kFixturePlain);
  const EntryLayout layout = LayoutOf(kFixturePlain);
  ASSERT_EQ(layout.ends.size(), 40u);
  ASSERT_EQ(layout.ends.back(), bytes.size());
  const std::size_t cut = bytes.size() / 2;
  std::size_t broken = 0, complete_scans = 0;
  while (layout.ends[broken] <= cut) complete_scans += layout.is_scan[broken++] ? 1 : 0;
  const std::string path = dir.Write("half.rawlog", bytes.substr(0, cut));
  const std::string where = path + ": entry " + std::to_string(broken);

  EXPECT_THAT([&] { ReadAllScans(path, LogReaderOptions{true}); },
              ThrowsMessage<LogError>(HasSubstr(where + ": truncated or corrupt rawlog")));
  RawlogReader reader(path);
  EXPECT_EQ(ReadAll(reader).size(), complete_scans);
  EXPECT_FALSE(reader.Next().has_value());
  EXPECT_EQ(reader.Stats().skipped_records, 1u);
  ASSERT_EQ(reader.Stats().issues.size(), 1u);
  EXPECT_EQ(reader.Stats().issues[0].where, where);
  EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr("the log ends here"));
}

TEST(RawlogReaderTest, TruncatedGzipRawlogIsDetected) {
  TempDir dir;
  const std::string bytes = ReadFile(kFixtureGz);
  const std::string path = dir.Write("half.rawlog.gz", bytes.substr(0, bytes.size() / 2));
  EXPECT_THAT([&] { ReadAllScans(path, LogReaderOptions{true}); },
              ThrowsMessage<LogError>(::testing::AllOf(HasSubstr(path + ": entry "),
                                                       HasSubstr("truncated gzip data"))));
  RawlogReader reader(path);
  const std::size_t scans = ReadAll(reader).size();
  EXPECT_GT(scans, 0u);
  EXPECT_LT(scans, 20u);
  ASSERT_EQ(reader.Stats().issues.size(), 1u);
  EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr("truncated gzip data"));
}

TEST(RawlogReaderTest, TruncatedBeforeTheFirstScanThrowsInBothModes) {
  TempDir dir;
  const EntryLayout layout = LayoutOf(kFixturePlain);
  const std::string bytes = ReadFile(kFixturePlain);
  const std::string path = dir.Write("short.rawlog", bytes.substr(0, layout.ends[0] + 100));
  for (const bool strict : {false, true}) {
    EXPECT_THAT([&] { RawlogReader reader(path, LogReaderOptions{strict}); },
                ThrowsMessage<LogError>(HasSubstr(path + ": entry 1: truncated or corrupt")));
  }
}

TEST(RawlogReaderTest, CorruptClassNameIsAnErrorNamingTheEntry) {
  TempDir dir;
  const EntryLayout layout = LayoutOf(kFixturePlain);
  std::string bytes = ReadFile(kFixturePlain);
  // Entry 11 is a scan: 1 byte (0x80 | length), then "mrpt::obs::CObservation2DRangeScan".
  ASSERT_EQ(bytes.substr(layout.ends[10] + 1, 23), "mrpt::obs::CObservation");
  bytes[layout.ends[10] + 20] = '#';
  const std::string path = dir.Write("corrupt.rawlog", bytes);
  EXPECT_THAT([&] { ReadAllScans(path, LogReaderOptions{true}); },
              ThrowsMessage<LogError>(HasSubstr(path + ": entry 11: truncated or corrupt")));
  std::size_t scans_before = 0;
  for (std::size_t entry = 0; entry < 11; ++entry) scans_before += layout.is_scan[entry] ? 1 : 0;
  RawlogReader reader(path);
  EXPECT_EQ(ReadAll(reader).size(), scans_before);
  EXPECT_EQ(reader.Stats().skipped_records, 1u);
}

TEST(RawlogReaderTest, MalformedScanIsSkippedOrThrowsWhenStrict) {
  TempDir dir;
  const auto good = CopyOfFirstSenaScan();
  auto no_aperture = std::make_shared<CObservation2DRangeScan>(*good);
  no_aperture->aperture = 0.0f;
  auto no_timestamp = std::make_shared<CObservation2DRangeScan>(*good);
  no_timestamp->timestamp = mrpt::Clock::time_point();
  const std::string path = dir.Path("malformed.rawlog");
  WriteRawlog(path, {good, no_aperture, good, no_timestamp, good});
  RawlogReader reader(path);
  EXPECT_EQ(ReadAll(reader).size(), 3u);
  EXPECT_EQ(reader.Stats().skipped_records, 2u);
  ASSERT_EQ(reader.Stats().issues.size(), 2u);
  EXPECT_EQ(reader.Stats().issues[0].where, path + ": entry 1");
  EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr("aperture 0 is not > 0"));
  EXPECT_EQ(reader.Stats().issues[1].where, path + ": entry 3");
  EXPECT_THAT(reader.Stats().issues[1].message, HasSubstr("no timestamp"));
  EXPECT_THAT([&] { ReadAllScans(path, LogReaderOptions{true}); },
              ThrowsMessage<LogError>(HasSubstr(path + ": entry 1: laser scan aperture")));
}

TEST(RawlogReaderTest, RawlogsWithoutUsableScansThrow) {
  TempDir dir;
  auto comment = std::make_shared<mrpt::obs::CObservationComment>();
  comment->text = "no scans here";
  const std::string comments = dir.Path("comments.rawlog");
  WriteRawlog(comments, {comment, comment});
  EXPECT_THAT([&] { OpenLog(comments); },
              ThrowsMessage<LogError>(HasSubstr(
                  comments + ": no laser scans (CObservation2DRangeScan) found in 2 entries")));

  EXPECT_THAT([&] { RawlogReader reader(kLogs + "/intel_head.log"); },
              ThrowsMessage<LogError>(HasSubstr("not an MRPT rawlog")));
}

// Sensory frames without actions (MRPT's CRawlog pairs frames with actions and reads nothing):
// every frame is a scan with no odometry increment, so the odometry stays at the origin.
TEST(RawlogReaderTest, SensoryFramesWithoutActionsAreScansAtTheOdometrySoFar) {
  TempDir dir;
  auto frame = std::make_shared<mrpt::obs::CSensoryFrame>();
  frame->insert(CopyOfFirstSenaScan());
  const std::string frames = dir.Path("frames.rawlog");
  WriteRawlog(frames, {frame, frame});
  const std::unique_ptr<LogReader> reader = OpenLog(frames);
  const std::vector<LaserScan> scans = ReadAll(*reader);
  ASSERT_EQ(scans.size(), 2u);
  for (const LaserScan& scan : scans) {
    ASSERT_TRUE(scan.T_odom_robot.has_value());
    ExpectPose(*scan.T_odom_robot, 0.0, 0.0, 0.0, 0.0);
  }
  EXPECT_TRUE(reader->Stats().issues.empty());
}

#endif  // SHAPE_SLAM_HAVE_MRPT

}  // namespace
}  // namespace shape_slam::io
