#include "shape_slam/evaluation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace shape_slam {
namespace {

std::vector<StampedPose> Spiral(int n) {
  std::vector<StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    const double a = 0.3 * i;
    poses.push_back({10.0 + i, Pose2((1.0 + 0.2 * i) * std::cos(a), (1.0 + 0.2 * i) * std::sin(a), a)});
  }
  return poses;
}

TEST(EvaluationTest, RigidlyMovedTrajectoryHasZeroError) {
  const std::vector<StampedPose> reference = Spiral(30);
  const Pose2 T(3.0, -2.0, 0.7);
  std::vector<StampedPose> estimate;
  for (const StampedPose& p : reference) estimate.push_back({p.timestamp_s, T * p.pose});
  std::vector<Relation> relations;
  for (std::size_t i = 0; i + 1 < reference.size(); ++i) {
    relations.push_back({reference[i].timestamp_s, reference[i + 1].timestamp_s,
                         reference[i].pose.Inverse() * reference[i + 1].pose});
  }
  relations.push_back({reference[0].timestamp_s, reference[20].timestamp_s,
                       reference[0].pose.Inverse() * reference[20].pose});
  const EvaluationResult r = EvaluateTrajectory(estimate, reference, relations);
  EXPECT_EQ(r.matched_poses, 30u);
  EXPECT_NEAR(r.ate_rmse_m, 0.0, 1e-9);
  EXPECT_EQ(r.local.count, 29u);
  EXPECT_EQ(r.revisit.count, 1u);
  EXPECT_NEAR(r.local.mean_translation_m, 0.0, 1e-9);
  EXPECT_NEAR(r.revisit.mean_rotation_deg, 0.0, 1e-9);
  // The recovered alignment is the inverse of the motion applied.
  EXPECT_NEAR(r.T_reference_estimate.theta, -0.7, 1e-9);
}

TEST(EvaluationTest, KnownErrorsAreMeasured) {
  // Reference on a line; the estimate has one pose displaced by 0.3 m sideways.
  std::vector<StampedPose> reference, estimate;
  for (int i = 0; i < 5; ++i) {
    reference.push_back({static_cast<double>(i), Pose2(i, 0.0, 0.0)});
    estimate.push_back({static_cast<double>(i), Pose2(i, i == 2 ? 0.3 : 0.0, i == 2 ? 0.1 : 0.0)});
  }
  const std::vector<Relation> relations = {{1.0, 2.0, Pose2(1, 0, 0)}, {2.0, 3.0, Pose2(1, 0, 0)}};
  const EvaluationResult r = EvaluateTrajectory(estimate, reference, relations);
  // Best alignment of {0,0,0.3,0,0} onto zeros: shift by -0.06 along y (rotation ~0 by symmetry).
  const double expected = std::sqrt((4 * 0.06 * 0.06 + 0.24 * 0.24) / 5.0);
  EXPECT_NEAR(r.ate_rmse_m, expected, 1e-9);
  EXPECT_EQ(r.local.count, 2u);
  // Relation 1->2: estimate (1, 0.3, 0.1) vs (1, 0, 0): error translation 0.3, rotation 0.1 rad.
  // Relation 2->3: x2^-1 x3 = rotation -0.1 and translation R(-0.1)(1, -0.3).
  const Pose2 e2 = Pose2(1, 0, 0).Inverse() * (Pose2(2, 0.3, 0.1).Inverse() * Pose2(3, 0, 0));
  EXPECT_NEAR(r.local.mean_translation_m, (0.3 + e2.Translation().norm()) / 2, 1e-9);
  EXPECT_NEAR(r.local.mean_rotation_deg, 0.1 * 180 / M_PI, 1e-9);
}

TEST(EvaluationTest, AssociatesByTimestampWithinTolerance) {
  std::vector<StampedPose> reference = {{1.0, Pose2(0, 0, 0)}, {2.0, Pose2(1, 0, 0)}};
  std::vector<StampedPose> estimate = {{1.0004, Pose2(0, 0, 0)}, {2.5, Pose2(1, 0, 0)}};
  const EvaluationResult r = EvaluateTrajectory(estimate, reference, {{1.0, 2.0, Pose2(1, 0, 0)}});
  EXPECT_EQ(r.matched_poses, 1u);
  EXPECT_EQ(r.local.missing, 1u);
  EXPECT_EQ(r.local.count, 0u);
  EXPECT_THROW(EvaluateTrajectory({{7.0, Pose2()}}, reference, {}), std::invalid_argument);
}

// The reference's own steps, each followed by `error_of(step)` in the moving frame.
template <typename ErrorOf>
std::vector<StampedPose> WithStepErrors(const std::vector<StampedPose>& reference,
                                        ErrorOf error_of) {
  std::vector<StampedPose> estimate = {reference[0]};
  for (std::size_t i = 1; i < reference.size(); ++i) {
    const Pose2 step = reference[i - 1].pose.Inverse() * reference[i].pose;
    estimate.push_back({reference[i].timestamp_s, estimate.back().pose * step * error_of(i)});
  }
  return estimate;
}

TEST(EvaluationTest, CountsInjectedGrossLocalErrors) {
  const std::vector<StampedPose> reference = Spiral(40);
  // Gross: a 0.8 m slide at step 5, a 0.6 m sideways slide at 12, a 15 deg heading jump at 20,
  // a -11 deg jump at 33. Not gross: 0.45 m at 8, 9 deg at 27, (0.3 m, 5 deg) at 30.
  const auto error_of = [](std::size_t step) {
    const double deg = M_PI / 180.0;
    switch (step) {
      case 5: return Pose2(0.8, 0.0, 0.0);
      case 12: return Pose2(0.0, 0.6, 0.0);
      case 20: return Pose2(0.0, 0.0, 15 * deg);
      case 33: return Pose2(0.0, 0.0, -11 * deg);
      case 8: return Pose2(0.45, 0.0, 0.0);
      case 27: return Pose2(0.0, 0.0, 9 * deg);
      case 30: return Pose2(0.3, 0.0, 5 * deg);
      default: return Pose2();
    }
  };
  const std::vector<StampedPose> estimate = WithStepErrors(reference, error_of);
  const EvaluationResult r = EvaluateTrajectory(estimate, reference, {});
  EXPECT_EQ(r.gross_local.steps, 39u);
  EXPECT_EQ(r.gross_local.count, 4u);
  // The thresholds are parameters: above 0.7 m and 12 deg, only the slide and the 15 deg jump.
  EvaluationParams strict;
  strict.gross_translation_m = 0.7;
  strict.gross_rotation_deg = 12.0;
  EXPECT_EQ(EvaluateTrajectory(estimate, reference, {}, strict).gross_local.count, 2u);
  EvaluationParams loose;
  loose.gross_translation_m = 0.25;
  loose.gross_rotation_deg = 8.0;
  EXPECT_EQ(EvaluateTrajectory(estimate, reference, {}, loose).gross_local.count, 7u);
}

TEST(EvaluationTest, ListsEachGrossLocalErrorWithBothMotions) {
  const std::vector<StampedPose> reference = Spiral(30);
  const double deg = M_PI / 180.0;
  const auto error_of = [&](std::size_t step) {
    if (step == 7) return Pose2(0.7, -0.2, 0.0);  // gross: a slide
    if (step == 18) return Pose2(0.0, 0.0, -14 * deg);  // gross: a heading jump
    if (step == 25) return Pose2(0.2, 0.0, 3 * deg);  // within both thresholds
    return Pose2();
  };
  std::vector<StampedPose> estimate = WithStepErrors(reference, error_of);
  // Steps are taken in time order, whatever the order of the poses given.
  std::mt19937 rng(3);
  std::shuffle(estimate.begin(), estimate.end(), rng);
  const GrossLocalErrors gross = EvaluateTrajectory(estimate, reference, {}).gross_local;
  ASSERT_EQ(gross.listed.size(), 2u);
  EXPECT_EQ(gross.count, gross.listed.size());
  for (const auto& [g, step] : {std::pair{gross.listed[0], 7}, std::pair{gross.listed[1], 18}}) {
    EXPECT_EQ(g.index, static_cast<std::size_t>(step));
    EXPECT_DOUBLE_EQ(g.t1_s, reference[step - 1].timestamp_s);
    EXPECT_DOUBLE_EQ(g.t2_s, reference[step].timestamp_s);
    const Pose2 truth = reference[step - 1].pose.Inverse() * reference[step].pose;
    EXPECT_NEAR(g.reference.x, truth.x, 1e-9);
    EXPECT_NEAR(g.reference.y, truth.y, 1e-9);
    EXPECT_NEAR(g.reference.theta, truth.theta, 1e-9);
    const Pose2 error = g.reference.Inverse() * g.estimated;
    const Pose2 injected = error_of(step);
    EXPECT_NEAR(error.x, injected.x, 1e-9);
    EXPECT_NEAR(error.y, injected.y, 1e-9);
    EXPECT_NEAR(error.theta, injected.theta, 1e-9);
  }
}

TEST(EvaluationTest, GrossLocalErrorsSkipStepsWithoutReference) {
  const std::vector<StampedPose> reference = Spiral(10);
  std::vector<StampedPose> estimate = WithStepErrors(
      reference, [](std::size_t step) { return step == 4 ? Pose2(1.0, 0, 0) : Pose2(); });
  // Pose 4 has no reference pose: steps 3->4 and 4->5 are not counted, the jump goes unseen.
  estimate[4].timestamp_s += 0.5;
  const EvaluationResult r = EvaluateTrajectory(estimate, reference, {});
  EXPECT_EQ(r.gross_local.steps, 7u);
  EXPECT_EQ(r.gross_local.count, 0u);
  // The same jump between two poses that both have a reference pose is counted.
  estimate[4].timestamp_s -= 0.5;
  EXPECT_EQ(EvaluateTrajectory(estimate, reference, {}).gross_local.count, 1u);
}

TEST(EvaluationTest, GrossThresholdsAreValidated) {
  EvaluationParams params;
  params.gross_rotation_deg = -1.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.gross_translation_m = std::nan("");
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

TEST(EvaluationTest, BestRigidAlignmentRecoversRandomMotions) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<Point2> from, to;
    const Pose2 T(u(prng), u(prng), u(prng) / 4.0);
    for (int i = 0; i < 10; ++i) {
      from.emplace_back(u(prng), u(prng));
      to.push_back(T * from.back());
    }
    const Pose2 found = BestRigidAlignment(from, to);
    EXPECT_NEAR(found.x, T.x, 1e-9);
    EXPECT_NEAR(found.y, T.y, 1e-9);
    EXPECT_NEAR(NormalizeAngle(found.theta - T.theta), 0.0, 1e-9);
  }
}

}  // namespace
}  // namespace shape_slam
