// The motion model that predicts a scan's pose without odometry (not in the paper): constant
// velocity, shared by the mapper and the localizer's hypotheses.
#pragma once

#include <deque>
#include <optional>

#include "shape_slam/types.h"

namespace shape_slam {

struct MotionModelParams {
  /// The prediction is the mean motion of this many last scans.
  int velocity_window = 3;
  /// The robot's usual speed is the median translation of this many last confirmed motions
  /// that turned less than usual_speed_max_turn_rad (0: no usual speed). A prediction slower
  /// than it that turns less than that is brought up to it.
  int usual_speed_window = 20;
  double usual_speed_max_turn_rad = 0.2;  ///< radians per scan

  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// Constant velocity: the mean of the last motions, so that one wrong step (a corridor matched
/// short) does not stop the prediction; while the robot drives straight, no slower than its
/// usual speed (MotionModelParams::usual_speed_window).
class ConstantVelocity {
 public:
  explicit ConstantVelocity(const MotionModelParams& params) : params_(params) {}

  /// Adds the latest scan's motion T_prev_cur; `confirmed` when a match confirmed its pose.
  void Add(const Pose2& T_prev_cur, bool confirmed);
  /// T_prev_cur predicted for the next scan, or nullopt before the first motion.
  std::optional<Pose2> Predict() const;
  /// The longest translation among the last motions (velocity_window of them), metres; 0
  /// before the first.
  double LongestRecentStep() const;
  /// The largest turn (absolute) among the last motions, radians; 0 before the first.
  double LargestRecentTurn() const;

 private:
  double UsualSpeed() const;  // metres per scan; 0 while fewer than 5 motions are confirmed

  MotionModelParams params_;
  std::deque<Pose2> recent_motions_;
  std::deque<double> confirmed_speeds_;  // metres per scan
};

}  // namespace shape_slam
