// A progress bar on stderr for long runs: shown only when stderr is a terminal and not quiet.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace shape_slam::app {

class ProgressBar {
 public:
  ProgressBar(std::size_t total, std::string label, bool enabled);
  /// Reports `done` items; redraws at most ~10 times per second.
  void Update(std::size_t done);
  /// Draws the final state and ends the line.
  void Finish();

 private:
  void Draw(std::size_t done);
  std::size_t total_;
  std::string label_;
  bool enabled_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace shape_slam::app
