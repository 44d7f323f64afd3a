// CShapeMatcher: MRPT's alignment interface over the core's scan matcher.
#include "shape_slam_mrpt/shape_matcher.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <mrpt/config/CConfigFileMemory.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/stock_observations.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPosePDFGaussian.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "core/pose_matchers.h"
#include "mrpt/mrpt_test_scenes.h"
#include "shape_slam_mrpt/conversions.h"
#include "shape_slam_mrpt/polyline_map.h"

namespace shape_slam {
namespace {

using testing::SimulateScan;

// A points map of `points` (robot frame of scan 1) seen from T_1_2: the same points in frame 2.
mrpt::maps::CSimplePointsMap MovedPoints(const mrpt::maps::CSimplePointsMap& points,
                                         const Pose2& T_1_2) {
  mrpt::maps::CSimplePointsMap moved;
  const PointTransform T_2_1(T_1_2.Inverse());
  for (const Point2& p : PointsOf(points)) {
    const Point2 q = T_2_1(p);
    moved.insertPoint(static_cast<float>(q.x()), static_cast<float>(q.y()), 0.0f);
  }
  return moved;
}

Eigen::Matrix3d Covariance(const mrpt::poses::CPosePDFGaussian& pdf) {
  Eigen::Matrix3d c;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c(r, k) = pdf.cov(r, k);
  }
  return c;
}

// The real SICK scan MRPT ships, matched against itself moved by a known pose.
TEST(CShapeMatcher, RecoversAKnownPoseOnMrptsExampleScan) {
  mrpt::obs::CObservation2DRangeScan scan;
  mrpt::obs::stock_observations::example2DRangeScan(scan, 0);
  const mrpt::maps::CSimplePointsMap m1 = testing::ScanPoints(scan);
  const Pose2 T_1_2(0.25, -0.10, 0.08);
  const mrpt::maps::CSimplePointsMap m2 = MovedPoints(m1, T_1_2);
  CShapeMatcher matcher;
  CShapeMatcher::ReturnInfo info;
  const mrpt::poses::CPosePDF::Ptr pdf =
      matcher.Align(&m1, &m2, mrpt::poses::CPose2D(0, 0, 0), info);
  const auto gaussian = std::dynamic_pointer_cast<mrpt::poses::CPosePDFGaussian>(pdf);
  ASSERT_NE(gaussian, nullptr);
  EXPECT_THAT(ToPose2(gaussian->mean), IsNearly(T_1_2, 0.01, 0.005));
  EXPECT_TRUE(info.converged);
  EXPECT_GT(info.goodness, 0.9);
  EXPECT_GT(info.scan_points_m1, 100);
  const Eigen::Matrix3d c = Covariance(*gaussian);
  EXPECT_TRUE(c.isApprox(c.transpose()));
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues().minCoeff(), 0.0);
  EXPECT_LT(c(0, 0), 0.01);
}

// Two simulated scans of the room from different poses, from perturbed guesses (seeded).
TEST(CShapeMatcher, RecoversRelativePosesBetweenTwoScans) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> x(-2.5, 2.5), y(-1.5, 1.5), heading(-M_PI, M_PI);
  std::uniform_real_distribution<double> step(-0.4, 0.4), turn(-0.3, 0.3);
  std::uniform_real_distribution<double> noise(-0.1, 0.1), noise_turn(-0.05, 0.05);
  CShapeMatcher matcher;
  int recovered = 0;
  const int trials = 10;
  for (int trial = 0; trial < trials; ++trial) {
    const Pose2 T_world_1(x(prng), y(prng), heading(prng));
    const Pose2 T_1_2(step(prng), step(prng), turn(prng));
    const auto m1 = testing::ScanPoints(SimulateScan(T_world_1));
    const auto m2 = testing::ScanPoints(SimulateScan(T_world_1 * T_1_2));
    const Pose2 guess = T_1_2 * Pose2(noise(prng), noise(prng), noise_turn(prng));
    const mrpt::poses::CPosePDF::Ptr pdf = matcher.Align(&m1, &m2, ToCPose2D(guess));
    const Pose2 found = ToPose2(pdf->getMeanVal());
    const bool ok = (found.Translation() - T_1_2.Translation()).norm() < 0.03 &&
                    std::abs(NormalizeAngle(found.theta - T_1_2.theta)) < 0.01;
    recovered += ok ? 1 : 0;
    EXPECT_TRUE(ok) << "trial " << trial << ": found " << found.x << " " << found.y << " "
                    << found.theta << ", truth " << T_1_2.x << " " << T_1_2.y << " " << T_1_2.theta;
  }
  EXPECT_EQ(recovered, trials);
}

TEST(CShapeMatcher, WorksWithoutAGuessAndAgainstAPolylineMap) {
  CPolylineMap map;
  for (const Pose2& pose : testing::MappingPoses()) {
    map.insertObservation(SimulateScan(pose), testing::ToCPose3D(pose));
  }
  const Pose2 truth(0.5, -1.0, 0.6);
  const auto scan = testing::ScanPoints(SimulateScan(truth));
  CShapeMatcher::Options options;
  options.view_m1_from_guess = true;  // the map is seen from where the robot is thought to be
  CShapeMatcher matcher(options);
  const auto pdf = matcher.Align(&map, &scan, ToCPose2D(truth * Pose2(0.15, -0.1, 0.05)));
  EXPECT_THAT(ToPose2(pdf->getMeanVal()), IsNearly(truth, 0.03, 0.01));

  // §4.3: two scans of the same place, no guess at all.
  options = CShapeMatcher::Options();
  options.use_initial_guess = false;
  matcher.SetOptions(options);
  const Pose2 T_1_2(0.3, 0.2, 0.35);
  const auto m1 = testing::ScanPoints(SimulateScan(Pose2(-1.0, 0.0, 0.2)));
  const auto m2 = testing::ScanPoints(SimulateScan(Pose2(-1.0, 0.0, 0.2) * T_1_2));
  CShapeMatcher::ReturnInfo info;
  const auto global = matcher.Align(&m1, &m2, mrpt::poses::CPose2D(5, 5, 3), info);
  EXPECT_TRUE(info.converged);
  EXPECT_THAT(ToPose2(global->getMeanVal()), IsNearly(T_1_2, 0.03, 0.01));
}

TEST(CShapeMatcher, Align3DReturnsThePlanarResult) {
  mrpt::obs::CObservation2DRangeScan scan;
  mrpt::obs::stock_observations::example2DRangeScan(scan, 1);
  const auto m1 = testing::ScanPoints(scan);
  const Pose2 T_1_2(-0.2, 0.1, -0.05);
  const auto m2 = MovedPoints(m1, T_1_2);
  CShapeMatcher matcher;
  const mrpt::poses::CPose3DPDF::Ptr pdf = matcher.Align3D(&m1, &m2, mrpt::poses::CPose3D());
  const mrpt::poses::CPose3D mean = pdf->getMeanVal();
  EXPECT_THAT(ToPose2(mean), IsNearly(T_1_2, 0.01, 0.005));
  EXPECT_DOUBLE_EQ(mean.z(), 0.0);
}

TEST(CShapeMatcher, BadInputIsAClearError) {
  CShapeMatcher matcher;
  const mrpt::maps::CSimplePointsMap points;
  EXPECT_THROW(matcher.Align(nullptr, &points, mrpt::poses::CPose2D()), std::invalid_argument);
  // Empty maps: no match, no crash, no information.
  CShapeMatcher::ReturnInfo info;
  const auto pdf = matcher.Align(&points, &points, mrpt::poses::CPose2D(1, 2, 0.5), info);
  EXPECT_FALSE(info.converged);
  EXPECT_THAT(ToPose2(pdf->getMeanVal()), IsNearly(Pose2(1, 2, 0.5), 1e-9, 1e-9));
  CShapeMatcher::Options options;
  options.bearing_bin_rad = 0.0;
  EXPECT_THROW(matcher.SetOptions(options), std::invalid_argument);
}

TEST(CShapeMatcher, OptionsFromAnIniSection) {
  CShapeMatcher matcher;
  matcher.LoadOptions(mrpt::config::CConfigFileMemory(std::string(
                          "[align]\nuse_initial_guess = false\nbearing_bin_deg = 0.5\n")),
                      "align");
  EXPECT_FALSE(matcher.GetOptions().use_initial_guess);
  EXPECT_NEAR(matcher.GetOptions().bearing_bin_rad, 0.5 * M_PI / 180.0, 1e-12);
  try {
    matcher.LoadOptions(mrpt::config::CConfigFileMemory(std::string("[align]\nuse_guess = 1\n")),
                        "align");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(),
                ::testing::HasSubstr("ini section 'align', key 'use_guess': unknown key"));
  }
  EXPECT_THROW(matcher.LoadOptions(mrpt::config::CConfigFileMemory(
                                       std::string("[align]\nparams_file = /nonexistent.ini\n")),
                                   "align"),
               std::invalid_argument);
  EXPECT_FALSE(matcher.GetOptions().use_initial_guess);  // unchanged by the failed loads
}

}  // namespace
}  // namespace shape_slam
