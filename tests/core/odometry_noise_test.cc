// The odometry noise model and its learning from a log (odometry_noise.h): the learned scale
// matches the spread of the corrections it is given, ignores a few glitches, stays within its
// bounds, and nothing changes unless learning is on.
#include "shape_slam/odometry_noise.h"

#include <gtest/gtest.h>

#include <cmath>
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

}  // namespace
}  // namespace shape_slam
