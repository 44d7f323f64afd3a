// Internal (not installed): the checks the parameter structs' Validate() share. Each throws
// std::invalid_argument naming the field.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

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

}  // namespace shape_slam::internal
