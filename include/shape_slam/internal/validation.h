// Internal (not installed): the checks the parameter structs' Validate() share, and the check
// of an input scan shared by the mapper and the localizer. Each throws std::invalid_argument
// naming the field or the scan.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/types.h"

namespace shape_slam::internal {

inline void Positive(double value, const std::string& name) {
  if (!(value > 0.0) || !std::isfinite(value)) throw std::invalid_argument(name + " must be > 0");
}

inline void NonNegative(double value, const std::string& name) {
  if (!(value >= 0.0) || !std::isfinite(value)) throw std::invalid_argument(name + " must be >= 0");
}

inline void Fraction(double value, const std::string& name) {
  if (!(value >= 0.0 && value <= 1.0)) throw std::invalid_argument(name + " must be in [0, 1]");
}

/// A scan the mapper and the localizer can process: as many ranges as angles, a finite
/// timestamp and finite beam angles (ranges may be anything: NaN and the like are no reading).
inline void ValidateScan(const LaserScan& scan) {
  if (scan.ranges_m.size() != scan.angles_rad.size()) {
    throw std::invalid_argument("scan at t=" + std::to_string(scan.timestamp_s) + " has " +
                                std::to_string(scan.ranges_m.size()) + " ranges but " +
                                std::to_string(scan.angles_rad.size()) + " angles");
  }
  if (!std::isfinite(scan.timestamp_s)) throw std::invalid_argument("scan timestamp is not finite");
  for (const double a : scan.angles_rad) {
    if (!std::isfinite(a)) throw std::invalid_argument("scan has a non-finite beam angle");
  }
}

}  // namespace shape_slam::internal
