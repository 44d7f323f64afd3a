// A minimal streaming JSON writer for the command-line outputs (stats.json, --json results).
// Numbers use the shortest representation that round-trips; NaN and infinity become null.
#pragma once

#include <string>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam::io {

class JsonWriter {
 public:
  JsonWriter& BeginObject();
  JsonWriter& EndObject();
  JsonWriter& BeginArray();
  JsonWriter& EndArray();
  JsonWriter& Key(const std::string& key);
  JsonWriter& Value(double value);
  JsonWriter& Value(int value) { return Value(static_cast<long long>(value)); }
  JsonWriter& Value(long long value);
  JsonWriter& Value(std::size_t value) { return Value(static_cast<long long>(value)); }
  JsonWriter& Value(bool value);
  JsonWriter& Value(const std::string& value);
  JsonWriter& Value(const char* value) { return Value(std::string(value)); }
  JsonWriter& Null();
  /// [x, y]
  JsonWriter& Value(const Point2& point);
  /// [[x, y], ...]
  JsonWriter& Value(const Polyline& polyline);

  /// The document so far (complete once every Begin has its End).
  const std::string& str() const { return out_; }

 private:
  void Separate();
  std::string out_;
  std::vector<bool> first_in_scope_;
  bool after_key_ = false;
};

/// `value` in the shortest decimal form that parses back to the same double.
std::string FormatDouble(double value);

}  // namespace shape_slam::io
