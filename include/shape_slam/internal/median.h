// Internal (not installed): the median that the robust estimates share (the odometry noise's
// scales, the usual speed, the alignment's robust sigma, how far a refinement moved the scan).
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace shape_slam::internal {

/// The upper median (the element at index size / 2 once sorted), found in linear time; reorders
/// `values`. Requires a non-empty vector.
inline double MedianInPlace(std::vector<double>& values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace shape_slam::internal
