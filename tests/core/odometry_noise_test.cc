// The odometry noise model and its learning from a log (odometry_noise.h): the learned scale
// matches the spread of the corrections it is given, ignores a few glitches, stays within its
// bounds, and nothing changes unless learning is on. The heading calibration finds a wheel-base
// error and a per-metre drift through noise and outliers, and leaves unbiased odometry alone.
// The pose graph's odometry edges learn their heading noise per metre and per radian turned.
#include "shape_slam/odometry_noise.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <optional>
#include <random>
#include <stdexcept>

namespace shape_slam {
namespace {

OdometryNoiseParams Learning() {
  OdometryNoiseParams p;
  p.learn = true;
  return p;
}

// Corrections drawn with sigmas `k_xy` and `k_theta` times the configured model's, for steps of
// 0.5 m and 0.1 rad.
void Feed(OdometryNoiseLearner& learner, const OdometryNoiseParams& p, double k_xy,
          double k_theta, int n, std::mt19937& prng) {
  const Pose2 step(0.5, 0.0, 0.1);
  const Eigen::Matrix3d covariance = OdometryCovariance(step, p);
  std::normal_distribution<double> xy(0.0, k_xy * std::sqrt(covariance(0, 0)));
  std::normal_distribution<double> theta(0.0, k_theta * std::sqrt(covariance(2, 2)));
  for (int i = 0; i < n; ++i) learner.Add(step, Pose2(xy(prng), xy(prng), theta(prng)));
}

TEST(OdometryNoiseTest, CovarianceGrowsWithDistanceAndTurn) {
  const OdometryNoiseParams p;
  const Eigen::Matrix3d still = OdometryCovariance(Pose2(), p);
  EXPECT_DOUBLE_EQ(still(0, 0), p.sigma_xy_m * p.sigma_xy_m);
  EXPECT_DOUBLE_EQ(still(2, 2), p.sigma_theta_rad * p.sigma_theta_rad);
  const Eigen::Matrix3d moved = OdometryCovariance(Pose2(1.0, 0.0, 0.5), p);
  EXPECT_NEAR(std::sqrt(moved(0, 0)), p.sigma_xy_m + p.sigma_xy_per_m, 1e-12);
  EXPECT_NEAR(std::sqrt(moved(2, 2)),
              p.sigma_theta_rad + 0.5 * p.sigma_theta_per_rad + p.sigma_theta_per_m, 1e-12);
}

TEST(OdometryNoiseTest, LearnsTheScaleOfTheCorrections) {
  std::mt19937 prng(3);
  for (const auto& [k_xy, k_theta] : {std::pair{0.3, 0.5}, std::pair{2.0, 3.0}}) {
    const OdometryNoiseParams p = Learning();
    OdometryNoiseLearner learner(p);
    Feed(learner, p, k_xy, k_theta, 100, prng);
    EXPECT_NEAR(learner.TranslationScale(), k_xy, 0.2 * k_xy);
    EXPECT_NEAR(learner.RotationScale(), k_theta, 0.2 * k_theta);
    EXPECT_NEAR(learner.Current().sigma_xy_m, p.sigma_xy_m * learner.TranslationScale(), 1e-12);
    EXPECT_NEAR(learner.Current().sigma_theta_per_m,
                p.sigma_theta_per_m * learner.RotationScale(), 1e-12);
  }
}

TEST(OdometryNoiseTest, AFewGlitchesMoveNothingMuch) {
  std::mt19937 prng(5);
  const OdometryNoiseParams p = Learning();
  OdometryNoiseLearner clean(p), glitched(p);
  Feed(clean, p, 0.5, 0.5, 100, prng);
  prng.seed(5);
  Feed(glitched, p, 0.5, 0.5, 95, prng);
  for (int i = 0; i < 5; ++i) glitched.Add(Pose2(0.5, 0.0, 0.1), Pose2(1.0, -1.0, 1.4));
  EXPECT_NEAR(glitched.TranslationScale(), clean.TranslationScale(), 0.1);
  EXPECT_NEAR(glitched.RotationScale(), clean.RotationScale(), 0.1);
}

TEST(OdometryNoiseTest, ScaleStaysWithinItsBoundsAndWaitsForEnoughSamples) {
  std::mt19937 prng(9);
  OdometryNoiseParams p = Learning();
  p.learn_min_samples = 30;
  OdometryNoiseLearner learner(p);
  Feed(learner, p, 0.01, 20.0, 29, prng);
  EXPECT_EQ(learner.TranslationScale(), 1.0);  // not yet
  Feed(learner, p, 0.01, 20.0, 1, prng);
  EXPECT_EQ(learner.TranslationScale(), p.learn_min_scale);
  EXPECT_EQ(learner.RotationScale(), p.learn_max_scale);
}

TEST(OdometryNoiseTest, NothingIsLearnedWhenLearningIsOff) {
  std::mt19937 prng(1);
  const OdometryNoiseParams p;
  OdometryNoiseLearner learner(p);
  Feed(learner, p, 3.0, 3.0, 100, prng);
  EXPECT_EQ(learner.TranslationScale(), 1.0);
  EXPECT_EQ(learner.Current().sigma_theta_rad, p.sigma_theta_rad);
}

TEST(OdometryNoiseTest, InvalidParamsAreRefused) {
  OdometryNoiseParams p;
  p.learn_min_samples = 0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryNoiseParams{};
  p.learn_min_samples = p.learn_window + 1;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryNoiseParams{};
  p.learn_max_scale = p.learn_min_scale / 2;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryNoiseParams{};
  p.sigma_xy_m = 0.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
}

// A Gaussian fusion of a scan's own estimate x_s (information Is) with the prior at the
// prediction (information Ip): x = (Is + Ip)^-1 Is x_s, covariance (Is + Ip)^-1.
struct Fused {
  Pose2 correction;
  Eigen::Matrix3d covariance;
};
Fused Fuse(const Eigen::Vector3d& own, const Eigen::Matrix3d& scan_information,
           const Eigen::Matrix3d& prior_covariance) {
  const Eigen::Matrix3d covariance = (scan_information + prior_covariance.inverse()).inverse();
  const Eigen::Vector3d x = covariance * scan_information * own;
  return {Pose2(x.x(), x.y(), x.z()), covariance};
}

TEST(OdometryNoiseTest, ScanOwnCorrectionTakesThePriorsPullOut) {
  const Eigen::Matrix3d prior =
      Eigen::Vector3d(0.01 * 0.01, 0.02 * 0.02, 0.005 * 0.005).asDiagonal();
  Eigen::Matrix3d scan_information;
  scan_information << 4.0e4, 1.0e3, 2.0e3, 1.0e3, 2.0e4, -5.0e2, 2.0e3, -5.0e2, 9.0e4;
  const Eigen::Vector3d own(0.03, -0.02, 0.01);
  const Fused fused = Fuse(own, scan_information, prior);
  // The prior pulled the estimate towards the prediction ...
  EXPECT_LT(std::abs(fused.correction.x), 0.9 * own.x());
  // ... and the scan's own estimate is recovered.
  const std::optional<Pose2> recovered =
      ScanOwnCorrection(fused.correction, fused.covariance, prior, 0.05, 0.05);
  ASSERT_TRUE(recovered.has_value());
  EXPECT_NEAR(recovered->x, own.x(), 1e-9);
  EXPECT_NEAR(recovered->y, own.y(), 1e-9);
  EXPECT_NEAR(recovered->theta, own.z(), 1e-9);
}

TEST(OdometryNoiseTest, ScanOwnCorrectionNoneWhereTheScanIsBlindOrInvalid) {
  const Eigen::Matrix3d prior =
      Eigen::Vector3d(0.01 * 0.01, 0.01 * 0.01, 0.005 * 0.005).asDiagonal();
  // A corridor along x: the scan fixes y and the heading, x only to 1 m.
  const Eigen::Matrix3d corridor = Eigen::Vector3d(1.0, 1.0e4, 1.0e5).asDiagonal();
  const Fused fused = Fuse(Eigen::Vector3d(0.0, 0.01, 0.0), corridor, prior);
  EXPECT_FALSE(ScanOwnCorrection(fused.correction, fused.covariance, prior, 0.05, 0.05));
  EXPECT_TRUE(ScanOwnCorrection(fused.correction, fused.covariance, prior, 2.0, 0.05));
  // Covariances that are not positive definite, or a fused one looser than the prior alone.
  EXPECT_FALSE(ScanOwnCorrection(Pose2(), Eigen::Matrix3d::Zero(), prior, 0.05, 0.05));
  EXPECT_FALSE(ScanOwnCorrection(Pose2(), prior, Eigen::Matrix3d::Zero(), 0.05, 0.05));
  EXPECT_FALSE(ScanOwnCorrection(Pose2(), 2.0 * prior, prior, 0.05, 0.05));
}

// The learning loop of the mapper in one dimension (heading): each scan's estimate fuses the
// scan's own (noise s) with the odometry (true noise t) under the learned prior. Fed the fused
// corrections, the learner collapses to its floor although the odometry is as noisy as the
// scan; fed the scan's own, it learns the spread of scan minus odometry.
TEST(OdometryNoiseTest, LearningFromTheScansOwnCorrectionDoesNotCollapse) {
  OdometryNoiseParams p = Learning();
  p.learn_min_scale = 0.001;
  p.learn_max_scale = 1000.0;
  const Pose2 step(1.0, 0.0, 0.0);
  const double configured = std::sqrt(OdometryCovariance(step, p)(2, 2));
  const double s = 0.005, t = 0.005;  // radians: scan and odometry equally noisy
  for (const bool own : {false, true}) {
    OdometryNoiseLearner learner(p);
    std::mt19937 prng(7);
    std::normal_distribution<double> scan_noise(0.0, s), odometry_noise(0.0, t);
    for (int i = 0; i < 2000; ++i) {
      const double prior_sigma = std::sqrt(OdometryCovariance(step, learner.Current())(2, 2));
      const double truth = odometry_noise(prng);  // the true motion off the odometry's
      const double scan = truth + scan_noise(prng);
      const double w = prior_sigma * prior_sigma / (prior_sigma * prior_sigma + s * s);
      const double fused = w * scan;  // prior at 0, the prediction
      learner.Add(step, Pose2(0.0, 0.0, own ? scan : fused));
    }
    const double learned = learner.RotationScale() * configured;
    if (own) {
      EXPECT_NEAR(learned, std::hypot(s, t), 0.25 * std::hypot(s, t));
    } else {
      EXPECT_LT(learned, 0.1 * t);  // the collapse this guards against
    }
  }
}

// Steps of 0.1-0.5 m turning up to +-0.5 rad, whose heading the robot really turned `per_m` per
// metre and `per_rad` per radian beyond the odometry's, seen through `noise_rad` of scan noise;
// every 20th sample a wrong match 0.3 rad off.
void FeedHeading(OdometryCalibrator& calibrator, double per_m, double per_rad, double noise_rad,
                 int n, std::mt19937& prng, bool turns = true) {
  std::uniform_real_distribution<double> distance(0.1, 0.5), turn(-0.5, 0.5);
  std::normal_distribution<double> noise(0.0, noise_rad);
  for (int i = 0; i < n; ++i) {
    const Pose2 step(distance(prng), 0.0, turns ? turn(prng) : 0.0);
    double error = per_m * step.x + per_rad * step.theta + noise(prng);
    if (i % 20 == 19) error += 0.3;
    calibrator.Add(step, error);
  }
}

TEST(OdometryCalibrationTest, LearnsAWheelBaseErrorAndADriftPerMetre) {
  OdometryCalibrator calibrator{OdometryCalibrationParams{}};
  std::mt19937 prng(3);
  FeedHeading(calibrator, -0.0175, 0.05, 0.003, 300, prng);
  EXPECT_NEAR(calibrator.HeadingPerMetre(), -0.0175, 0.003);
  EXPECT_NEAR(calibrator.HeadingPerRadian(), 0.05, 0.005);
  const Pose2 corrected = calibrator.Correct(Pose2(0.5, 0.1, 0.2));
  EXPECT_DOUBLE_EQ(corrected.x, 0.5);
  EXPECT_DOUBLE_EQ(corrected.y, 0.1);
  EXPECT_NEAR(corrected.theta,
              0.2 + calibrator.HeadingPerRadian() * 0.2 +
                  calibrator.HeadingPerMetre() * std::hypot(0.5, 0.1),
              1e-12);
}

TEST(OdometryCalibrationTest, UnbiasedOdometryIsLeftAsItIs) {
  OdometryCalibrator calibrator{OdometryCalibrationParams{}};
  std::mt19937 prng(5);
  FeedHeading(calibrator, 0.0, 0.0, 0.01, 300, prng);
  EXPECT_EQ(calibrator.HeadingPerMetre(), 0.0);
  EXPECT_EQ(calibrator.HeadingPerRadian(), 0.0);
  const Pose2 step(0.3, 0.0, 0.1);
  EXPECT_EQ(calibrator.Correct(step).theta, step.theta);
}

TEST(OdometryCalibrationTest, ATermTheLogNeverExercisesStaysZero) {
  OdometryCalibrator calibrator{OdometryCalibrationParams{}};
  std::mt19937 prng(9);
  FeedHeading(calibrator, 0.02, 0.0, 0.003, 300, prng, /*turns=*/false);
  EXPECT_NEAR(calibrator.HeadingPerMetre(), 0.02, 0.003);
  EXPECT_EQ(calibrator.HeadingPerRadian(), 0.0);
}

TEST(OdometryCalibrationTest, WaitsForSamplesStaysInBoundsAndCanBeOff) {
  OdometryCalibrationParams p;
  p.max_per_m = 0.01;
  OdometryCalibrator bounded(p);
  std::mt19937 prng(11);
  FeedHeading(bounded, 0.05, 0.0, 0.002, p.min_samples - 1, prng);
  EXPECT_EQ(bounded.HeadingPerMetre(), 0.0);  // not enough samples yet
  FeedHeading(bounded, 0.05, 0.0, 0.002, 100, prng);
  EXPECT_DOUBLE_EQ(bounded.HeadingPerMetre(), 0.01);
  p.enabled = false;
  OdometryCalibrator off(p);
  FeedHeading(off, 0.05, 0.0, 0.002, 100, prng);
  EXPECT_EQ(off.HeadingPerMetre(), 0.0);
}

TEST(OdometryCalibrationTest, InvalidParamsAreRefused) {
  OdometryCalibrationParams p;
  p.min_samples = p.window + 1;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryCalibrationParams{};
  p.max_per_m = -1.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  EXPECT_NO_THROW(OdometryCalibrationParams{}.Validate());
}

// Stalled: the same odometry pose to the bit while the robot was moving; a robot at rest, or
// odometry that moved by a rounding step, is not stalled.
TEST(OdometryStalledTest, OnlyTheSamePoseWhileMoving) {
  const Pose2 last(1.5, -2.0, 0.3);
  EXPECT_TRUE(OdometryStalled(last, last, 0.6, 0.05));
  EXPECT_FALSE(OdometryStalled(last, last, 0.01, 0.05));  // at rest
  EXPECT_FALSE(OdometryStalled(Pose2(1.5 + 1e-12, -2.0, 0.3), last, 0.6, 0.05));
  EXPECT_FALSE(OdometryStalled(Pose2(1.5, -2.0, 0.3 + 1e-12), last, 0.6, 0.05));
}

}  // namespace
// Keyframe steps: straight ones of 1 m whose heading errs by sigma_m_rad per sqrt(metre), and
// turning ones (0.5 m, 0.6 rad) by sigma_turn_rad per sqrt(radian); position errors 2 cm.
void FeedSteps(OdometryEdgeNoise& noise, double sigma_m_rad, double sigma_turn_rad, int n,
               std::mt19937& prng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  const OdometryEdgeParams defaults;
  for (int i = 0; i < n; ++i) {
    const bool turning = i % 2 == 1;
    const Pose2 step = turning ? Pose2(0.5, 0.0, 0.6) : Pose2(1.0, 0.0, 0.0);
    const double sigma = turning ? sigma_turn_rad * std::sqrt(0.6)
                                 : sigma_m_rad * std::sqrt(1.0 + defaults.distance_floor_m);
    noise.Add(step, step * Pose2(0.02 * unit(prng), 0.02 * unit(prng), sigma * unit(prng)));
  }
}

// A window of 2000 steps: the medians' sampling error is then about 7 %.
OdometryEdgeParams LongWindow() {
  OdometryEdgeParams p;
  p.window = 2000;
  return p;
}

TEST(OdometryEdgeNoiseTest, LearnsTheHeadingNoisePerMetreAndPerRadianTurned) {
  std::mt19937 prng(5);
  const OdometryEdgeParams p = LongWindow();
  OdometryEdgeNoise noise(p);
  FeedSteps(noise, 0.01, 0.05, p.min_samples - 1, prng);
  EXPECT_FALSE(noise.Covariance(Pose2(1.0, 0.0, 0.0)));  // not enough steps yet
  FeedSteps(noise, 0.01, 0.05, p.window, prng);
  EXPECT_EQ(noise.Samples(), p.window);  // the older steps are gone
  const std::optional<Eigen::Matrix3d> straight = noise.Covariance(Pose2(1.0, 0.0, 0.0));
  const std::optional<Eigen::Matrix3d> turning = noise.Covariance(Pose2(0.0, 0.0, 0.6));
  ASSERT_TRUE(straight && turning);
  // Heading variance: variance_scale times the steps' own, within the medians' sampling error.
  const double want_straight = p.variance_scale * 0.01 * 0.01 * (1.0 + p.distance_floor_m);
  EXPECT_NEAR((*straight)(2, 2), want_straight, 0.2 * want_straight);
  // A turn on the spot: the per-radian rate (0.05^2 per radian) and the floor's share per metre.
  const double want_turning =
      p.variance_scale * (0.05 * 0.05 * 0.6 + 0.01 * 0.01 * p.distance_floor_m);
  EXPECT_NEAR((*turning)(2, 2), want_turning, 0.2 * want_turning);
  // The position is left to the scans: its variance many times the steps' own (2 cm a axis).
  EXPECT_GT((*straight)(0, 0), 10.0 * p.variance_scale * 0.02 * 0.02);
  EXPECT_EQ((*straight)(0, 0), (*straight)(1, 1));
  EXPECT_EQ((*straight)(0, 1), 0.0);
}

TEST(OdometryEdgeNoiseTest, AGlitchAmongTheStepsMovesNothingMuch) {
  const OdometryEdgeParams p = LongWindow();
  OdometryEdgeNoise clean(p), glitched(p);
  std::mt19937 same(7);
  FeedSteps(clean, 0.01, 0.05, 1990, same);
  same.seed(7);
  FeedSteps(glitched, 0.01, 0.05, 1990, same);
  for (int i = 0; i < 10; ++i) glitched.Add(Pose2(1.0, 0.0, 0.0), Pose2(1.0, 0.0, 1.4));  // 80 deg
  const double a = (*clean.Covariance(Pose2(1.0, 0.0, 0.0)))(2, 2);
  const double b = (*glitched.Covariance(Pose2(1.0, 0.0, 0.0)))(2, 2);
  EXPECT_NEAR(b, a, 0.1 * a);
}

TEST(OdometryEdgeNoiseTest, InvalidParamsAreRefused) {
  OdometryEdgeParams p;
  p.window = 0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryEdgeParams{};
  p.position_variance_factor = 0.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryEdgeParams{};
  p.loss_sigmas = -1.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = OdometryEdgeParams{};
  p.variance_scale = 0.0;
  EXPECT_THROW(OdometryEdgeNoise{p}, std::invalid_argument);
  p.enabled = false;
  EXPECT_NO_THROW(p.Validate());
}

}  // namespace shape_slam
