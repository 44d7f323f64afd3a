// The turn between two scans from their orientation histograms (orientation_histogram.h): found
// without a pose guess in a room with a pillar, both ways, whatever the robot's position did; no
// turn from an empty scan; bad params refused.
#include "shape_slam/orientation_histogram.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "shape_slam/scan_shapes.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

testing::Scene RoomWithPillar() {
  testing::Scene scene = testing::Room(0.0, 0.0, 8.0, 5.0);
  testing::AddPillar(scene, Point2(5.5, 3.0), 0.4);
  return scene;
}

TEST(OrientationHistogramTest, FindsTheTurnBetweenTwoScansBothWays) {
  const testing::Scene scene = RoomWithPillar();
  const testing::ScannerModel model;
  std::mt19937 prng(7);
  const Pose2 before{2.0, 2.0, 0.3};
  const OrientationHistogramParams params;
  for (const double turn : {-0.6, -0.25, 0.0, 0.15, 0.45}) {
    const Pose2 after{2.4, 2.1, before.theta + turn};  // moved as well: directions do not care
    const auto histogram = [&](const Pose2& pose) {
      const LaserScan scan = testing::SimulateScan(scene, pose, model, prng);
      return ComputeOrientationHistogram(ExtractScanShapes(scan, ScanShapesParams()).fine, params);
    };
    const OrientationHistogram h0 = histogram(before), h1 = histogram(after);
    const std::optional<double> found = HistogramTurn(h0, h1, params);
    ASSERT_TRUE(found.has_value()) << "turn " << turn;
    // Within 0.03 rad: what the scanner sees changes as it turns (a 180 deg view), and the field
    // track searches 0.1 rad around the heading.
    EXPECT_NEAR(*found, turn, 0.03) << "turn " << turn;
  }
}

TEST(OrientationHistogramTest, NoTurnWithoutReadingsAndBadParamsRefused) {
  const OrientationHistogramParams params;
  const OrientationHistogram h = ComputeOrientationHistogram({{Point2(1.0, 1.0)}}, params);
  EXPECT_EQ(h.total_m, 0.0);
  EXPECT_FALSE(HistogramTurn(h, h, params).has_value());
  OrientationHistogramParams bad;
  bad.max_turn_rad = 2.0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
  bad = OrientationHistogramParams();
  bad.bin_rad = 0.0;
  EXPECT_THROW(bad.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
