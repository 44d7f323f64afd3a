// Regression tests for what fuzzing found (fuzz/findings/, described in its README): each
// reproducer is now read into a clean result or a documented error, quickly.
#include <gtest/gtest.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "shape_slam_io/carmen_reader.h"
#include "shape_slam_io/map_file.h"

namespace shape_slam::io {
namespace {

namespace fs = std::filesystem;
const fs::path kFindings = fs::path(SHAPE_SLAM_DATASETS_DIR) / ".." / "fuzz" / "findings";

std::vector<fs::path> Files(const std::string& target) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kFindings / target)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(FuzzFindingsTest, TruncatedCarmenRecordsAreSkippedOrALogError) {
  const std::vector<fs::path> files = Files("carmen_reader");
  ASSERT_FALSE(files.empty());
  for (const fs::path& file : files) {
    for (const bool strict : {false, true}) {
      try {
        CarmenReader reader(file.string(), LogReaderOptions{strict});
        while (const std::optional<LaserScan> scan = reader.Next()) {
          for (const double a : scan->angles_rad) EXPECT_TRUE(std::isfinite(a)) << file;
        }
      } catch (const LogError&) {
        // documented
      }
    }
  }
}

TEST(FuzzFindingsTest, MapFilesWithHugeCoordinatesLoadQuicklyOrFail) {
  const std::vector<fs::path> files = Files("map_file");
  ASSERT_FALSE(files.empty());
  for (const fs::path& file : files) {
    const auto start = std::chrono::steady_clock::now();
    try {
      const PolylineMap map = LoadMapFile(file.string());
      EXPECT_EQ(FormatMapFile(ParseMapFile(FormatMapFile(map), "again")), FormatMapFile(map));
    } catch (const MapFileError&) {
      // documented
    }
    // Was 20 s and 1.9 GB for a 60-byte file; a generous bound, not a benchmark.
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5)) << file;
  }
}

TEST(FuzzFindingsTest, RobotLaserWithAbsurdStartAngleIsSkipped) {
  const fs::path dir = fs::temp_directory_path() / "shape-slam-fuzz-finding";
  fs::create_directories(dir);
  const fs::path log = dir / "angle.log";
  {
    std::ofstream out(log);
    out << "ROBOTLASER1 0 1e308 3.14 0.0174 80 0.01 0 3 1 1 1 0 0 0 0 0 0 0 0 0 0 0 0 0 1.0 h 1.0\n";
  }
  EXPECT_THROW(CarmenReader(log.string(), LogReaderOptions{true}), LogError);
  EXPECT_THROW(CarmenReader(log.string(), LogReaderOptions{false}), LogError);  // no scan left
  fs::remove_all(dir);
}

}  // namespace
}  // namespace shape_slam::io
