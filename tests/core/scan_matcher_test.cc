// Scan-to-scan registration (scan_matcher.h; paper §4.2, §4.3, §5.1) on synthetic scenes with
// 1 cm range noise: the known motion is recovered with no guess at all and from guesses off by
// 1.5 m and 30 deg, which point-based ICP started there cannot do.
#include "shape_slam/scan_matcher.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_scenes.h"

namespace shape_slam {
namespace {

using testing::Scene;
using testing::ScannerModel;

constexpr double kDeg = M_PI / 180.0;

struct Case {
  const char* name;
  Scene scene;
  Pose2 A, B;  // robot poses of scans I and J in the world
};

std::vector<Case> Cases() {
  Scene clutter = testing::OfficeRoom();
  testing::AddPillar(clutter, {3.0, 2.5}, 0.1);
  clutter.push_back({{1.0, 4.2}, {1.6, 4.6}});
  return {
      {"office, small motion", testing::OfficeRoom(), Pose2(2.5, 2.0, 0.3), Pose2(2.9, 2.2, 0.55)},
      {"office, turn", testing::OfficeRoom(), Pose2(3.0, 2.5, 0.0), Pose2(3.3, 2.3, -0.6)},
      // Towards the corridor's end wall: looking the other way, only the door recesses at
      // grazing angles would fix the position along the axis (see the degenerate case below).
      {"corridor", testing::Corridor(20.0), Pose2(6.0, 1.0, M_PI - 0.1),
       Pose2(5.4, 1.1, M_PI)},
      {"clutter", clutter, Pose2(1.0, 1.0, 0.8), Pose2(1.4, 1.5, 0.5)},
  };
}

void ExpectNear(const Pose2& estimate, const Pose2& truth, const std::string& what) {
  const Pose2 d = truth.Inverse() * estimate;
  EXPECT_LT(d.Translation().norm(), 0.03) << what;
  EXPECT_LT(std::abs(d.theta), 0.5 * kDeg) << what;
}

TEST(ScanMatcherTest, RecoversTheMotionWithoutAnyGuess) {
  for (const Case& c : Cases()) {
    for (unsigned seed = 1; seed <= 3; ++seed) {
      std::mt19937 prng(seed);
      const LaserScan i = testing::SimulateScan(c.scene, c.A, ScannerModel{}, prng);
      const LaserScan j = testing::SimulateScan(c.scene, c.B, ScannerModel{}, prng);
      const ScanMatchResult m = MatchScans(i, j, std::nullopt);
      const std::string what = std::string(c.name) + " seed " + std::to_string(seed);
      EXPECT_TRUE(m.converged) << what;
      EXPECT_GT(m.matched_pairs, 0) << what;
      EXPECT_TRUE(std::isfinite(m.reliability)) << what;
      ExpectNear(m.T_i_j, c.A.Inverse() * c.B, what);
    }
  }
}

TEST(ScanMatcherTest, RecoversTheMotionFromGuessesOffByUpTo1p5mAnd30deg) {
  for (const Case& c : Cases()) {
    const Pose2 truth = c.A.Inverse() * c.B;
    std::mt19937 prng(7);
    const LaserScan i = testing::SimulateScan(c.scene, c.A, ScannerModel{}, prng);
    const LaserScan j = testing::SimulateScan(c.scene, c.B, ScannerModel{}, prng);
    for (const double direction : {0.0, 2.0, 4.0}) {
      for (const double sign : {-1.0, 1.0}) {
        const Pose2 guess(truth.x + 1.5 * std::cos(direction), truth.y + 1.5 * std::sin(direction),
                          truth.theta + sign * 30.0 * kDeg);
        const ScanMatchResult m = MatchScans(i, j, guess);
        const std::string what = std::string(c.name) + " guess direction " +
                                 std::to_string(direction) + " turn " + std::to_string(sign);
        EXPECT_TRUE(m.converged) << what;
        ExpectNear(m.T_i_j, truth, what);
      }
    }
  }
}

TEST(ScanMatcherTest, ResultIsInRobotFramesWhenTheSensorIsOffset) {
  const Scene scene = testing::OfficeRoom();
  const Pose2 T_robot_sensor(0.3, 0.05, 0.1);
  const Pose2 A(2.5, 2.0, 0.3), B(2.9, 2.3, 0.5);
  std::mt19937 prng(3);
  LaserScan i = testing::SimulateScan(scene, A * T_robot_sensor, ScannerModel{}, prng);
  LaserScan j = testing::SimulateScan(scene, B * T_robot_sensor, ScannerModel{}, prng);
  i.T_robot_sensor = j.T_robot_sensor = T_robot_sensor;
  const ScanMatchResult m = MatchScans(i, j, std::nullopt);
  EXPECT_TRUE(m.converged);
  ExpectNear(m.T_i_j, A.Inverse() * B, "offset sensor");
}

TEST(ScanMatcherTest, CovarianceShowsTheAxisOfAFeaturelessCorridor) {
  // Two long parallel walls and nothing else in range: the motion along the corridor is
  // unobservable, and the covariance must say so (much larger along x than across). Noise-free
  // ranges: with noise, the alignment polylines follow the noise in small kinks (up to
  // alignment_max_deviation_m) which the covariance takes for real structure, so it is then
  // over-confident along the axis (a known limitation, see alignment_refinement.h).
  const Scene scene = {{{-100.0, 0.0}, {100.0, 0.0}}, {{100.0, 2.0}, {-100.0, 2.0}}};
  testing::ScannerModel model;
  model.max_range_m = 8.0;
  model.noise_sigma_m = 0.0;
  std::mt19937 prng(5);
  const LaserScan i = testing::SimulateScan(scene, Pose2(0.0, 1.0, 0.0), model, prng);
  const LaserScan j = testing::SimulateScan(scene, Pose2(0.5, 1.1, 0.05), model, prng);
  const ScanMatchResult m = MatchScans(i, j, Pose2(0.5, 0.1, 0.05));
  EXPECT_NEAR(m.T_i_j.y, 0.1, 0.02);
  EXPECT_NEAR(m.T_i_j.theta, 0.05, 0.01);
  EXPECT_GT(m.covariance(0, 0), 100.0 * m.covariance(1, 1));
}

TEST(ScanMatcherTest, ScansWithoutPointsDoNotConverge) {
  std::mt19937 prng(1);
  const LaserScan good = testing::SimulateScan(testing::OfficeRoom(), Pose2(2, 2, 0),
                                               ScannerModel{}, prng);
  const LaserScan empty = [&] {
    LaserScan e = good;
    for (double& r : e.ranges_m) r = std::nan("");
    return e;
  }();
  const Pose2 guess(0.1, 0.2, 0.3);
  for (const auto& [a, b] : {std::pair{&good, &empty}, std::pair{&empty, &good}}) {
    const ScanMatchResult m = MatchScans(*a, *b, guess);
    EXPECT_FALSE(m.converged);
    EXPECT_EQ(m.T_i_j.x, guess.x);
    EXPECT_EQ(m.T_i_j.theta, guess.theta);
  }
  EXPECT_FALSE(MatchScans(good, empty, std::nullopt).converged);
}

TEST(ScanMatcherTest, InvalidParametersThrow) {
  std::mt19937 prng(1);
  const LaserScan scan =
      testing::SimulateScan(testing::OfficeRoom(), Pose2(2, 2, 0), ScannerModel{}, prng);
  ScanMatchParams params;
  params.shapes.dce.threshold_m = -1.0;
  EXPECT_THROW(MatchScans(scan, scan, std::nullopt, params), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
