#include "shape_slam/motion_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "shape_slam/internal/median.h"
#include "shape_slam/internal/validation.h"

namespace shape_slam {

namespace {

// The fewest confirmed motions that make a usual speed.
constexpr std::size_t kMinSpeeds = 5;

}  // namespace

void MotionModelParams::Validate() const {
  if (velocity_window < 1) throw std::invalid_argument("MotionModelParams::velocity_window must be >= 1");
  if (usual_speed_window < 0) {
    throw std::invalid_argument("MotionModelParams::usual_speed_window must be >= 0");
  }
  internal::Positive(usual_speed_max_turn_rad, "MotionModelParams::usual_speed_max_turn_rad");
}

void ConstantVelocity::Add(const Pose2& T_prev_cur, bool confirmed) {
  recent_motions_.push_back(T_prev_cur);
  while (static_cast<int>(recent_motions_.size()) > params_.velocity_window) {
    recent_motions_.pop_front();
  }
  // Only confirmed motions driving straight: turns on the spot would make the usual speed zero.
  if (!confirmed || params_.usual_speed_window <= 0 ||
      !(std::abs(T_prev_cur.theta) < params_.usual_speed_max_turn_rad)) {
    return;
  }
  confirmed_speeds_.push_back(T_prev_cur.Translation().norm());
  while (static_cast<int>(confirmed_speeds_.size()) > params_.usual_speed_window) {
    confirmed_speeds_.pop_front();
  }
}

double ConstantVelocity::UsualSpeed() const {
  if (confirmed_speeds_.size() < kMinSpeeds) return 0.0;
  std::vector<double> speeds(confirmed_speeds_.begin(), confirmed_speeds_.end());
  return internal::MedianInPlace(speeds);
}

// A turn of a scan or two dilutes the mean of the last motions; the robot then enters a
// featureless corridor with a speed it never had, and the corridor, which fits every position
// along it alike, cannot correct it: the slower prediction is reproduced scan after scan (aces
// without odometry slid 1-2 m per corridor so). Driving straight, the robot keeps its usual speed
// (a median, which one slow start or stop does not move); the bounded motion prior lets a scan
// that shows the robot slower override it.
std::optional<Pose2> ConstantVelocity::Predict() const {
  if (recent_motions_.empty()) return std::nullopt;
  Pose2 mean(0.0, 0.0, 0.0);
  for (const Pose2& m : recent_motions_) mean.x += m.x, mean.y += m.y, mean.theta += m.theta;
  const double n = static_cast<double>(recent_motions_.size());
  mean = Pose2(mean.x / n, mean.y / n, mean.theta / n);
  const double speed = mean.Translation().norm();
  const double usual = UsualSpeed();
  if (speed > 1e-3 && speed < usual && std::abs(mean.theta) < params_.usual_speed_max_turn_rad) {
    mean.x *= usual / speed;
    mean.y *= usual / speed;
  }
  return mean;
}

double ConstantVelocity::LongestRecentStep() const {
  double longest = 0.0;
  for (const Pose2& m : recent_motions_) longest = std::max(longest, m.Translation().norm());
  return longest;
}

double ConstantVelocity::LargestRecentTurn() const {
  double largest = 0.0;
  for (const Pose2& m : recent_motions_) largest = std::max(largest, std::abs(m.theta));
  return largest;
}

}  // namespace shape_slam
