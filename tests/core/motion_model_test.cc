// The constant-velocity motion model (motion_model.h): the mean of the last motions, brought
// up to the usual speed only while driving straight, from confirmed straight motions only.
#include "shape_slam/motion_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace shape_slam {
namespace {

MotionModelParams UsualSpeed(int window) {
  MotionModelParams p;
  p.velocity_window = 3;
  p.usual_speed_window = window;
  p.usual_speed_max_turn_rad = 0.2;
  return p;
}

// The same motion `times` times over.
void AddTimes(ConstantVelocity& velocity, int times, const Pose2& motion, bool confirmed) {
  for (int i = 0; i < times; ++i) velocity.Add(motion, confirmed);
}

TEST(ConstantVelocity, PredictsTheMeanOfTheLastMotions) {
  ConstantVelocity velocity(UsualSpeed(0));
  EXPECT_FALSE(velocity.Predict().has_value());
  velocity.Add(Pose2(9.0, 9.0, 1.0), true);  // falls out of the window of 3
  velocity.Add(Pose2(1.0, 0.0, 0.0), true);
  velocity.Add(Pose2(0.5, 0.3, 0.3), true);
  velocity.Add(Pose2(0.0, 0.0, 0.0), true);
  const Pose2 p = *velocity.Predict();
  EXPECT_NEAR(p.x, 0.5, 1e-12);
  EXPECT_NEAR(p.y, 0.1, 1e-12);
  EXPECT_NEAR(p.theta, 0.1, 1e-12);
}

// The longest step of the window bounds what an override of the odometry may claim.
TEST(ConstantVelocity, LongestRecentStepIsThatOfTheWindow) {
  ConstantVelocity velocity(UsualSpeed(0));
  EXPECT_EQ(velocity.LongestRecentStep(), 0.0);
  velocity.Add(Pose2(9.0, 0.0, 0.0), true);  // falls out of the window of 3
  velocity.Add(Pose2(0.3, 0.4, 0.2), false);
  velocity.Add(Pose2(0.1, 0.0, 1.0), true);
  velocity.Add(Pose2(0.0, 0.0, 0.0), true);
  EXPECT_NEAR(velocity.LongestRecentStep(), 0.5, 1e-12);
}

// A turn on the spot dilutes the mean; driving straight again, the prediction keeps the usual
// speed (the median: one fast outlier does not move it), in the mean's direction.
TEST(ConstantVelocity, DrivingStraightKeepsTheUsualSpeed) {
  ConstantVelocity velocity(UsualSpeed(20));
  AddTimes(velocity, 10, Pose2(1.0, 0.0, 0.0), true);
  velocity.Add(Pose2(5.0, 0.0, 0.0), true);
  velocity.Add(Pose2(0.0, 0.0, 0.05), true);
  velocity.Add(Pose2(0.0, 0.0, -0.05), true);
  velocity.Add(Pose2(0.3, 0.1, 0.0), true);
  const Pose2 p = *velocity.Predict();
  EXPECT_NEAR(std::hypot(p.x, p.y), 1.0, 1e-9);
  EXPECT_NEAR(p.y / p.x, 1.0 / 3.0, 1e-9);
  EXPECT_NEAR(p.theta, 0.0, 1e-12);

  ConstantVelocity off(UsualSpeed(0));
  AddTimes(off, 10, Pose2(1.0, 0.0, 0.0), true);
  off.Add(Pose2(0.0, 0.0, 0.05), true);
  off.Add(Pose2(0.0, 0.0, -0.05), true);
  off.Add(Pose2(0.3, 0.0, 0.0), true);
  EXPECT_NEAR(off.Predict()->x, 0.1, 1e-12);
}

// Turning, standing still, a faster mean, or too few confirmed motions: the plain mean.
TEST(ConstantVelocity, OtherwiseThePlainMean) {
  ConstantVelocity turning(UsualSpeed(20));
  AddTimes(turning, 10, Pose2(1.0, 0.0, 0.0), true);
  AddTimes(turning, 3, Pose2(0.2, 0.0, 0.5), true);
  EXPECT_NEAR(turning.Predict()->x, 0.2, 1e-12);

  ConstantVelocity still(UsualSpeed(20));
  AddTimes(still, 10, Pose2(1.0, 0.0, 0.0), true);
  AddTimes(still, 3, Pose2(0.0, 0.0, 0.0), true);
  EXPECT_NEAR(still.Predict()->x, 0.0, 1e-12);

  ConstantVelocity faster(UsualSpeed(20));
  AddTimes(faster, 10, Pose2(1.0, 0.0, 0.0), true);
  AddTimes(faster, 3, Pose2(1.5, 0.0, 0.0), true);
  EXPECT_NEAR(faster.Predict()->x, 1.5, 1e-12);

  // Unconfirmed motions (placed at the prediction while lost) make no usual speed.
  ConstantVelocity unconfirmed(UsualSpeed(20));
  AddTimes(unconfirmed, 10, Pose2(1.0, 0.0, 0.0), false);
  AddTimes(unconfirmed, 3, Pose2(0.3, 0.0, 0.0), true);
  EXPECT_NEAR(unconfirmed.Predict()->x, 0.3, 1e-12);
}

// The usual speed is that of driving: confirmed turns on the spot (and other motions turning
// more than usual_speed_max_turn_rad) do not count, however many.
TEST(ConstantVelocity, TurnsOnTheSpotDoNotLowerTheUsualSpeed) {
  ConstantVelocity velocity(UsualSpeed(20));
  AddTimes(velocity, 6, Pose2(1.0, 0.0, 0.0), true);
  AddTimes(velocity, 30, Pose2(0.0, 0.0, 0.5), true);
  velocity.Add(Pose2(0.2, 0.0, 0.0), true);
  velocity.Add(Pose2(0.2, 0.0, 0.0), true);
  velocity.Add(Pose2(0.2, 0.0, 0.0), true);
  EXPECT_NEAR(velocity.Predict()->x, 1.0, 1e-12);
}

TEST(MotionModelParams, ValidateNamesTheField) {
  MotionModelParams p;
  EXPECT_NO_THROW(p.Validate());
  p.velocity_window = 0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = MotionModelParams();
  p.usual_speed_window = -1;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
  p = MotionModelParams();
  p.usual_speed_max_turn_rad = 0.0;
  EXPECT_THROW(p.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
