#include "shape_slam_io/log_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <random>
#include <string>

#include "io/test_files.h"

namespace shape_slam::io {
namespace {

using ::testing::HasSubstr;
using testing::ReadFile;
using testing::TempDir;
using ::testing::ThrowsMessage;

const std::string kDatasets = SHAPE_SLAM_DATASETS_DIR;
const std::string kLogs = std::string(SHAPE_SLAM_TEST_DATA_DIR) + "/logs";

std::string Gzip(const TempDir& dir, const std::string& name, const std::string& content) {
  const std::string path = dir.Path(name);
  gzFile out = gzopen(path.c_str(), "wb");
  if (out == nullptr) return path;
  if (!content.empty()) gzwrite(out, content.data(), static_cast<unsigned>(content.size()));
  gzclose(out);
  return path;
}

TEST(OpenLogTest, DetectsCarmenFromTheContentPlainOrGzipWhateverTheExtension) {
  TempDir dir;
  const std::string text = ReadFile(kLogs + "/intel_head.log");
  for (const std::string& path :
       {kLogs + "/intel_head.log", kDatasets + "/radish/intel.log.gz",
        Gzip(dir, "misnamed.rawlog", text), dir.Write("misnamed.bin", text)}) {
    SCOPED_TRACE(path);
    const std::unique_ptr<LogReader> reader = OpenLog(path);
    EXPECT_EQ(reader->Format(), "carmen");
    EXPECT_EQ(reader->Path(), path);
    ASSERT_TRUE(reader->Next().has_value());
    EXPECT_EQ(reader->Stats().scans, 1u);
  }
}

TEST(OpenLogTest, ReadAllScansReadsEveryScanInOrder) {
  const std::vector<LaserScan> scans = ReadAllScans(kLogs + "/intel_head.log");
  ASSERT_EQ(scans.size(), 3u);
  EXPECT_LT(scans[0].timestamp_s, scans[1].timestamp_s);
  EXPECT_LT(scans[1].timestamp_s, scans[2].timestamp_s);
}

TEST(OpenLogTest, MissingPathDirectoryAndEmptyFilesThrowNamingThePath) {
  TempDir dir;
  const std::string missing = dir.Path("missing.log");
  EXPECT_THAT([&] { OpenLog(missing); },
              ThrowsMessage<LogError>(HasSubstr(missing + ": no such file")));
  EXPECT_THAT([&] { OpenLog(dir.path()); },
              ThrowsMessage<LogError>(HasSubstr(dir.path() + ": is a directory")));
  EXPECT_THAT([&] { OpenLog(""); }, ThrowsMessage<LogError>(HasSubstr("no such file")));
  const std::string empty = dir.Write("empty.log", "");
  EXPECT_THAT([&] { OpenLog(empty); }, ThrowsMessage<LogError>(HasSubstr(empty + ": empty file")));
  const std::string empty_gz = Gzip(dir, "empty.log.gz", "");
  EXPECT_THAT([&] { OpenLog(empty_gz); },
              ThrowsMessage<LogError>(HasSubstr(empty_gz + ": no data")));
  EXPECT_THROW(ReadAllScans(missing), LogError);
}

TEST(OpenLogTest, BinaryGarbageIsNotACarmenLog) {
  TempDir dir;
  std::mt19937 prng(42);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(prng() & 0xFF);
  garbage[0] = 0x11;  // not an MRPT object header
  for (const std::string& path :
       {dir.Write("garbage.log", garbage), Gzip(dir, "garbage.gz", garbage)}) {
    EXPECT_THAT([&] { OpenLog(path); },
                ThrowsMessage<LogError>(HasSubstr(path + ": unknown format: not a CARMEN log")));
  }
  // Mostly control characters without any NUL byte is binary too.
  const std::string controls = dir.Write("controls.log", std::string(900, '\x01') + "FLASER");
  EXPECT_THAT([&] { OpenLog(controls); }, ThrowsMessage<LogError>(HasSubstr("not a CARMEN log")));
}

TEST(OpenLogTest, TruncatedOrCorruptGzipHeaderThrows) {
  TempDir dir;
  const std::string bytes = ReadFile(kDatasets + "/radish/intel.log.gz");
  for (const std::size_t size : {2, 5, 10, 16}) {
    const std::string path = dir.Write("cut" + std::to_string(size) + ".gz", bytes.substr(0, size));
    SCOPED_TRACE(path);
    EXPECT_THAT([&] { OpenLog(path); },
                ThrowsMessage<LogError>(
                    ::testing::AllOf(::testing::StartsWith(path + ":"), HasSubstr("gzip data"))));
  }
  std::string bad_method = bytes;
  bad_method[2] = 7;  // compression method other than deflate
  const std::string path = dir.Write("bad_method.gz", bad_method);
  EXPECT_THAT([&] { OpenLog(path); }, ThrowsMessage<LogError>(HasSubstr("corrupt gzip data")));
}

TEST(OpenLogTest, TruncatedGzipLogThrowsInsteadOfEndingEarly) {
  TempDir dir;
  const std::string bytes = ReadFile(kDatasets + "/radish/intel.log.gz");
  const std::string path = dir.Write("half.log.gz", bytes.substr(0, bytes.size() / 2));
  EXPECT_THAT([&] { ReadAllScans(path); },
              ThrowsMessage<LogError>(HasSubstr("truncated gzip data")));
}

}  // namespace
}  // namespace shape_slam::io
