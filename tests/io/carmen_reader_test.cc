#include "shape_slam_io/carmen_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "io/test_files.h"
#include "shape_slam_io/log_reader.h"

namespace shape_slam::io {
namespace {

using ::testing::HasSubstr;
using testing::ReadFile;
using testing::TempDir;

const std::string kDatasets = SHAPE_SLAM_DATASETS_DIR;
const std::string kLogs = std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/logs";
constexpr double kDeg = M_PI / 180.0;

std::vector<LaserScan> ReadAll(LogReader& reader) {
  std::vector<LaserScan> scans;
  while (std::optional<LaserScan> scan = reader.Next()) scans.push_back(std::move(*scan));
  return scans;
}

// The timestamps of the reference file (`timestamp x y theta` per FLASER scan).
std::vector<double> GroundTruthTimestamps(const std::string& path) {
  std::ifstream in(path);
  std::vector<double> timestamps;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    timestamps.push_back(std::stod(line.substr(0, line.find(' '))));
  }
  return timestamps;
}

// A well-formed FLASER line with 4 readings at odometry (1, 2, 0.5).
std::string Flaser(const std::string& readings, const std::string& timestamp) {
  return "FLASER 4 " + readings + " 1 2 0.5 1 2 0.5 " + timestamp + " host " + timestamp;
}

void ExpectPose(const Pose2& pose, double x, double y, double theta, double tolerance) {
  EXPECT_NEAR(pose.x, x, tolerance);
  EXPECT_NEAR(pose.y, y, tolerance);
  EXPECT_NEAR(NormalizeAngle(pose.theta - theta), 0.0, tolerance);
}

// ----------------------------------------------------------------------------------------------
// Real logs.

TEST(CarmenReaderTest, IntelLogMatchesItsReferenceTimestampsBeamsAndNoReturnValue) {
  const std::string path = kDatasets + "/radish/intel.log.gz";
  CarmenReader reader(path);
  const std::vector<LaserScan> scans = ReadAll(reader);
  const std::vector<double> reference = GroundTruthTimestamps(kDatasets + "/radish/intel.gt.txt");
  ASSERT_EQ(scans.size(), 910u);
  ASSERT_EQ(reference.size(), scans.size());
  EXPECT_EQ(scans.front().timestamp_s, 32.9068);
  for (std::size_t k = 0; k < scans.size(); ++k) EXPECT_EQ(scans[k].timestamp_s, reference[k]) << k;

  // "No return" readings are 81.83 m: exactly those are flagged by max_range_m.
  const double max_range_m = reader.flaser_max_range_m();
  EXPECT_GT(max_range_m, 81.82);
  EXPECT_LT(max_range_m, 81.83);
  std::size_t flagged = 0, at_no_return_value = 0;
  for (const LaserScan& scan : scans) {
    ASSERT_EQ(scan.ranges_m.size(), 180u);
    ASSERT_EQ(scan.angles_rad.size(), 180u);
    ASSERT_TRUE(scan.T_odom_robot.has_value());
    EXPECT_EQ(scan.max_range_m, max_range_m);
    for (const double r : scan.ranges_m) {
      flagged += r >= scan.max_range_m ? 1 : 0;
      at_no_return_value += std::abs(r - 81.83) < 1e-9 ? 1 : 0;
    }
  }
  EXPECT_EQ(flagged, at_no_return_value);
  EXPECT_EQ(flagged, 4172u);
  for (std::size_t i = 0; i < 180; ++i) {
    EXPECT_NEAR(scans[0].angles_rad[i], (-90.0 + static_cast<double>(i)) * kDeg, 1e-12);
  }
  ExpectPose(*scans[0].T_odom_robot, 0.698035, -0.013284, -0.460915, 1e-12);
  ExpectPose(scans[0].T_robot_sensor, 0.0, 0.0, 0.0, 0.0);
  EXPECT_EQ(reader.Stats().scans, 910u);
  EXPECT_EQ(reader.Stats().skipped_records, 0u);
  EXPECT_EQ(reader.Stats().invalid_ranges, 0u);
  // The log (and its reference file) goes back in time 4 times, first at line 5056.
  EXPECT_EQ(reader.Stats().non_monotonic_timestamps, 4u);
  ASSERT_EQ(reader.Stats().issues.size(), 4u);
  EXPECT_EQ(reader.Stats().issues[0].where, path + ":5056");
  EXPECT_THAT(reader.Stats().issues[0].message,
              HasSubstr("timestamp 940.54 s is earlier than the previous scan's 940.654 s"));
}

TEST(CarmenReaderTest, AcesAndFreiburgGetTheirMaxRangeAndLaserOffset) {
  CarmenReader aces(kDatasets + "/radish/aces.log.gz");  // no PARAM: the 50 m rule
  EXPECT_NEAR(aces.flaser_max_range_m(), 50.0 - 0.005, 1e-12);
  EXPECT_EQ(ReadAll(aces).size(), 440u);

  // freiburg-079: PARAM robot_front_laser_max 80.99 and robot_frontlaser_offset -0.04.
  CarmenReader freiburg(kDatasets + "/radish/freiburg-079.log.gz");
  EXPECT_EQ(freiburg.flaser_max_range_m(), 80.99);
  const std::vector<LaserScan> scans = ReadAll(freiburg);
  ASSERT_EQ(scans.size(), 4791u);
  EXPECT_EQ(scans[0].ranges_m.size(), 360u);
  EXPECT_NEAR(scans[0].angles_rad[1] - scans[0].angles_rad[0], 0.5 * kDeg, 1e-12);
  ExpectPose(scans[0].T_robot_sensor, -0.04, 0.0, 0.0, 0.0);
  EXPECT_EQ(scans[0].timestamp_s, 0.227623);
}

TEST(CarmenReaderTest, PlainTextFixtureOfRealLines) {
  CarmenReader reader(kLogs + "/intel_head.log");
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_EQ(scans[0].timestamp_s, 32.9068);
  EXPECT_EQ(scans[1].timestamp_s, 35.1051);
  EXPECT_EQ(scans[2].timestamp_s, 36.46);
  EXPECT_THAT(std::vector<double>(scans[0].ranges_m.begin(), scans[0].ranges_m.begin() + 3),
              ::testing::ElementsAre(1.09, 1.08, 1.08));
  ExpectPose(*scans[2].T_odom_robot, 0.694993, 0.003708, -1.530240, 1e-12);
  EXPECT_NEAR(scans[2].ranges_m[179], 81.83, 1e-12);
  EXPECT_GE(scans[2].ranges_m[179], scans[2].max_range_m);  // a "no return" reading
  EXPECT_NEAR(reader.flaser_max_range_m(), 81.825, 1e-12);
}

TEST(CarmenReaderTest, OddBeamCountsParamOffsetAndMaxRange) {
  CarmenReader reader(kLogs + "/flaser_181_361.log");
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), 2u);
  // 181 beams: 1 deg apart from -90 to +90 deg; 361 beams: 0.5 deg apart.
  ASSERT_EQ(scans[0].angles_rad.size(), 181u);
  EXPECT_NEAR(scans[0].angles_rad[0], -M_PI_2, 1e-12);
  EXPECT_NEAR(scans[0].angles_rad[90], 0.0, 1e-12);
  EXPECT_NEAR(scans[0].angles_rad[180], M_PI_2, 1e-12);
  ASSERT_EQ(scans[1].angles_rad.size(), 361u);
  EXPECT_NEAR(scans[1].angles_rad[1], -M_PI_2 + 0.5 * kDeg, 1e-12);
  EXPECT_NEAR(scans[1].angles_rad[360], M_PI_2, 1e-12);
  for (const LaserScan& scan : scans) {
    ExpectPose(scan.T_robot_sensor, 0.25, 0.0, 0.0, 0.0);  // the first PARAM value wins
    EXPECT_EQ(scan.max_range_m, 30.0);                     // laser_front_laser_max_range
  }
  EXPECT_GE(scans[0].ranges_m[90], scans[0].max_range_m);
  EXPECT_EQ(scans[0].timestamp_s, 1.25);  // `timestamp`, not logger_timestamp (1.26)
  EXPECT_EQ(scans[1].timestamp_s, 1.75);  // older variant ending after the timestamp
  ExpectPose(*scans[1].T_odom_robot, 1.5, 2.25, 0.75, 0.0);
  EXPECT_EQ(scans[1].ranges_m[360], 3.8);
}

TEST(CarmenReaderTest, RobotLaser1AnglesMountingAndOdometry) {
  CarmenReader reader(kLogs + "/robotlaser1.log");
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), 2u);  // the FLASER duplicate is ignored
  for (const LaserScan& scan : scans) {
    ASSERT_EQ(scan.angles_rad.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
      EXPECT_NEAR(scan.angles_rad[i], (-90.0 + 45.0 * static_cast<double>(i)) * kDeg, 1e-12);
    }
    EXPECT_EQ(scan.max_range_m, 8.0);
    ExpectPose(scan.T_robot_sensor, 0.3, -0.1, 0.1, 1e-12);
  }
  ExpectPose(*scans[0].T_odom_robot, 2.0, 1.0, M_PI_2, 1e-12);
  ExpectPose(*scans[1].T_odom_robot, -1.0, 0.5, -3.0, 1e-12);
  EXPECT_EQ(scans[0].timestamp_s, 10.0);
  EXPECT_EQ(scans[1].timestamp_s, 10.5);
  EXPECT_EQ(scans[0].ranges_m[2], 8.0);
  EXPECT_TRUE(std::isnan(scans[0].ranges_m[3]));
  EXPECT_TRUE(std::isnan(scans[1].ranges_m[2]));  // -1.0
  EXPECT_EQ(scans[1].ranges_m[4], 8.5);
  EXPECT_EQ(reader.Stats().invalid_ranges, 2u);
  ASSERT_EQ(reader.Stats().issues.size(), 1u);
  EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr("FLASER records ignored"));
}

// ----------------------------------------------------------------------------------------------
// The max range rule on synthetic logs.

std::string LogWithReadings(int scans, int readings_at_25m) {
  std::ostringstream log;
  for (int k = 0; k < scans; ++k) {
    log << "FLASER 100";
    for (int i = 0; i < 100; ++i) log << ' ' << (k * 100 + i < readings_at_25m ? 25.0 : 1.5);
    log << " 0 0 0 0 0 0 " << k << " host " << k << "\n";
  }
  return log.str();
}

// Some scanners report "no return" as values that vary a little (51.05-51.16 m on the infinite
// corridor): all of them are flagged, a real reading 0.2 m below them is not.
TEST(CarmenReaderTest, NoReturnValuesThatVaryALittleAreAllFlagged) {
  TempDir dir;
  std::ostringstream log;
  const double values[] = {51.05, 51.06, 51.11, 51.16, 50.86, 1.5, 1.5, 1.5};
  for (int k = 0; k < 20; ++k) {
    log << "FLASER 100";
    for (int i = 0; i < 100; ++i) log << ' ' << (i < 8 && (k == 0 || i < 4) ? values[i] : 1.5);
    log << " 0 0 0 0 0 0 " << k << " host " << k << "\n";
  }
  EXPECT_NEAR(CarmenReader(dir.Write("varying.log", log.str())).flaser_max_range_m(), 51.045, 1e-9);
}

TEST(CarmenReaderTest, MaxRangeRuleNeedsFrequentLargeReadings) {
  TempDir dir;
  // 3 of 2000 readings (0.15 %) at the largest value: "no return" readings.
  EXPECT_NEAR(CarmenReader(dir.Write("frequent.log", LogWithReadings(20, 3))).flaser_max_range_m(),
              24.995, 1e-12);
  // 1 of 2000 (0.05 %): a real reading, nothing flagged.
  EXPECT_NEAR(CarmenReader(dir.Write("rare.log", LogWithReadings(20, 1))).flaser_max_range_m(),
              26.0, 1e-12);
  // Largest reading below 20 m: never a "no return" value.
  EXPECT_NEAR(CarmenReader(dir.Write("short.log", LogWithReadings(20, 0))).flaser_max_range_m(),
              2.5, 1e-12);
}

// ----------------------------------------------------------------------------------------------
// Malformed records.

struct MalformedCase {
  std::string line;
  std::string message;
};

TEST(CarmenReaderTest, EachKindOfMalformedRecordIsSkippedAndRecordedOrThrowsWhenStrict) {
  const std::vector<MalformedCase> cases = {
      {Flaser("1 2 3 4 5", "2"), "needs 15 fields"},
      {Flaser("1 abc 3 4", "2"), "range reading (field 4) is not a number: 'abc'"},
      {"FLASER 0 1 2 0.5 1 2 0.5 2 host 2", "reading count n 0 is out of range"},
      {"FLASER 200000 1", "reading count n 200000 is out of range"},
      {"FLASER 4.5 1 2 3 4 1 2 0.5 1 2 0.5 2 host 2", "is not a count: '4.5'"},
      {"FLASER 4 1 2 3 4 1 2 0.5 nan 2 0.5 2 host 2", "odometry pose x (field 10) is not finite"},
      {Flaser("1 2 3 4", "inf"), "timestamp (field 13) is not finite"},
      {"PARAM robot_frontlaser_offset", "PARAM needs a name and a value"},
      {"PARAM robot_front_laser_max -3", "is not > 0"},
      {"ROBOTLASER1 0 -1.57 3.14 0.78 0 0.01 0 1 1.0 0 0 0 0 0 0 0 0 0 0 0 0 1 h 1",
       "max_range 0 is not > 0"},
  };
  for (const MalformedCase& c : cases) {
    SCOPED_TRACE(c.line);
    TempDir dir;
    const std::string path = dir.Write(
        "bad.log", Flaser("1 2 3 4", "1") + "\n" + c.line + "\n" + Flaser("1 2 3 4", "3") + "\n");
    CarmenReader reader(path);
    const std::vector<LaserScan> scans = ReadAll(reader);
    ASSERT_EQ(scans.size(), 2u);
    EXPECT_EQ(scans[1].timestamp_s, 3.0);
    EXPECT_EQ(reader.Stats().skipped_records, 1u);
    ASSERT_EQ(reader.Stats().issues.size(), 1u);
    EXPECT_EQ(reader.Stats().issues[0].where, path + ":2");
    EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr(c.message));
    try {
      CarmenReader strict_reader(path, LogReaderOptions{true});
      ADD_FAILURE() << "strict mode accepted a malformed record";
    } catch (const LogError& e) {
      EXPECT_THAT(e.what(), HasSubstr(path + ":2: "));
      EXPECT_THAT(e.what(), HasSubstr(c.message));
    }
  }
}

TEST(CarmenReaderTest, StrictErrorNamesTheLineOfTheFirstMalformedRecord) {
  TempDir dir;
  const std::string path =
      dir.Write("bad.log", "# comment\nODOM 0 0 0 0 0 0 0 h 0\n" + Flaser("1 2 3 4", "1") + "\n\n" +
                               Flaser("1 2 x 4", "2") + "\n" + Flaser("1 2 3", "3") + "\n");
  try {
    ReadAllScans(path, LogReaderOptions{true});
    FAIL() << "expected LogError";
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), ::testing::StartsWith(path + ":5: "));
  }
  CarmenReader lenient(path);
  EXPECT_EQ(ReadAll(lenient).size(), 1u);
  EXPECT_EQ(lenient.Stats().skipped_records, 2u);
  ASSERT_EQ(lenient.Stats().issues.size(), 2u);
  EXPECT_EQ(lenient.Stats().issues[1].where, path + ":6");
}

TEST(CarmenReaderTest, TruncatedLastLineIsAMalformedRecord) {
  TempDir dir;
  const std::string path =
      dir.Write("cut.log", Flaser("1 2 3 4", "1") + "\n" + Flaser("1 2 3 4", "2").substr(0, 20));
  CarmenReader reader(path);
  EXPECT_EQ(ReadAll(reader).size(), 1u);
  EXPECT_EQ(reader.Stats().skipped_records, 1u);
  ASSERT_EQ(reader.Stats().issues.size(), 1u);
  EXPECT_EQ(reader.Stats().issues[0].where, path + ":2");
  EXPECT_THROW(CarmenReader(path, LogReaderOptions{true}), LogError);
}

TEST(CarmenReaderTest, NanInfAndNegativeReadingsBecomeNanAndAreCounted) {
  TempDir dir;
  const std::string path = dir.Write("nan.log", Flaser("nan -1.0 inf 2.0", "1") + "\r\n" +
                                                    Flaser("-inf 0 1e999 NaN", "2") + "\r\n");
  CarmenReader reader(path, LogReaderOptions{true});  // not malformed: strict accepts them
  const std::vector<LaserScan> scans = ReadAll(reader);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_TRUE(std::isnan(scans[0].ranges_m[0]));
  EXPECT_TRUE(std::isnan(scans[0].ranges_m[1]));
  EXPECT_TRUE(std::isnan(scans[0].ranges_m[2]));
  EXPECT_EQ(scans[0].ranges_m[3], 2.0);
  EXPECT_EQ(scans[1].ranges_m[1], 0.0);  // zero is a reading, not an invalid one
  EXPECT_EQ(reader.Stats().invalid_ranges, 6u);
  EXPECT_EQ(reader.Stats().skipped_records, 0u);
}

TEST(CarmenReaderTest, TimestampsGoingBackwardsAreCountedNotErrors) {
  TempDir dir;
  const std::string path =
      dir.Write("order.log", Flaser("1 2 3 4", "2") + "\n" + Flaser("1 2 3 4", "1") + "\n" +
                                 Flaser("1 2 3 4", "3") + "\n");
  CarmenReader reader(path, LogReaderOptions{true});
  EXPECT_EQ(ReadAll(reader).size(), 3u);
  EXPECT_EQ(reader.Stats().non_monotonic_timestamps, 1u);
  ASSERT_EQ(reader.Stats().issues.size(), 1u);
  EXPECT_EQ(reader.Stats().issues[0].where, path + ":2");
  EXPECT_THAT(reader.Stats().issues[0].message, HasSubstr("earlier than the previous"));
}

TEST(CarmenReaderTest, IssuesAreCappedButCountersKeepCounting) {
  TempDir dir;
  std::string log = Flaser("1 2 3 4", "0") + "\n";
  for (int i = 0; i < 150; ++i) log += "FLASER 4 1 2\n";
  CarmenReader reader(dir.Write("many.log", log));
  EXPECT_EQ(ReadAll(reader).size(), 1u);
  EXPECT_EQ(reader.Stats().skipped_records, 150u);
  EXPECT_EQ(reader.Stats().issues.size(), kMaxLogIssues);
}

// ----------------------------------------------------------------------------------------------
// Files that are not readable CARMEN logs.

TEST(CarmenReaderTest, LogWithoutLaserRecordsThrows) {
  TempDir dir;
  const std::string odom_only = dir.Write("odom.log", "PARAM a b\nODOM 0 0 0 0 0 0 1 h 1\n");
  EXPECT_THAT(
      [&] { CarmenReader reader(odom_only); },
      ::testing::ThrowsMessage<LogError>(HasSubstr("no laser scans (FLASER/ROBOTLASER1) found")));
  const std::string all_bad = dir.Write("bad.log", "FLASER 4 1 2\nFLASER x\n");
  EXPECT_THAT([&] { CarmenReader reader(all_bad); },
              ::testing::ThrowsMessage<LogError>(HasSubstr("(2 malformed laser records)")));
}

TEST(CarmenReaderTest, BinaryContentIsNotACarmenLog) {
  TempDir dir;
  std::string content = Flaser("1 2 3 4", "1") + "\n";
  content += std::string(64, '\0');
  EXPECT_THAT([&] { CarmenReader reader(dir.Write("nul.log", content)); },
              ::testing::ThrowsMessage<LogError>(HasSubstr("not a CARMEN log")));
}

// Writes the first `fraction` of a real gzip log to a temporary file.
std::string CutCopy(const TempDir& dir, const std::string& source, double fraction) {
  const std::string bytes = ReadFile(source);
  return dir.Write(
      "cut.log.gz",
      bytes.substr(0, static_cast<std::size_t>(fraction * static_cast<double>(bytes.size()))));
}

TEST(CarmenReaderTest, TruncatedGzipIsAnErrorNamingTheLineInBothModes) {
  TempDir dir;
  const std::string path = CutCopy(dir, kDatasets + "/radish/intel.log.gz", 0.5);
  for (const bool strict : {false, true}) {
    try {
      CarmenReader reader(path, LogReaderOptions{strict});
      ADD_FAILURE() << "a truncated gzip log was accepted";
    } catch (const LogError& e) {
      EXPECT_THAT(e.what(), ::testing::MatchesRegex(".*cut\\.log\\.gz:[0-9]+: truncated gzip data "
                                                    "\\(zlib: unexpected end of file\\)"));
    }
  }
}

TEST(CarmenReaderTest, CorruptGzipIsAnError) {
  TempDir dir;
  std::string bytes = ReadFile(kDatasets + "/radish/intel.log.gz");
  for (std::size_t i = bytes.size() / 2; i < bytes.size() / 2 + 64; ++i) bytes[i] ^= 0x5A;
  const std::string path = dir.Write("corrupt.log.gz", bytes);
  EXPECT_THAT([&] { CarmenReader reader(path); },
              ::testing::ThrowsMessage<LogError>(HasSubstr("corrupt gzip data")));
}

TEST(CarmenReaderTest, ReadsGzipCompressedFixtureLikeThePlainOne) {
  TempDir dir;
  const std::string path = dir.Path("head.clf.gz");
  const std::string text = ReadFile(kLogs + "/intel_head.log");
  gzFile out = gzopen(path.c_str(), "wb");
  ASSERT_NE(out, nullptr);
  ASSERT_EQ(gzwrite(out, text.data(), static_cast<unsigned>(text.size())),
            static_cast<int>(text.size()));
  ASSERT_EQ(gzclose(out), Z_OK);
  CarmenReader gz(path);
  CarmenReader plain(kLogs + "/intel_head.log");
  const std::vector<LaserScan> a = ReadAll(gz);
  const std::vector<LaserScan> b = ReadAll(plain);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].timestamp_s, b[k].timestamp_s);
    EXPECT_EQ(a[k].ranges_m, b[k].ranges_m);
  }
}

}  // namespace
}  // namespace shape_slam::io
