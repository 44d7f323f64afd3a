#include "shape_slam_io/json_writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace shape_slam::io {
namespace {

TEST(JsonWriterTest, WritesValidCompactJson) {
  JsonWriter json;
  json.BeginObject().Key("a").Value(1).Key("b").BeginArray().Value(0.1).Value(true).Null().EndArray();
  json.Key("s").Value("q\"\\\n").Key("nan").Value(std::nan("")).Key("p").Value(Point2(1.5, -2));
  json.EndObject();
  EXPECT_EQ(json.str(),
            "{\"a\":1,\"b\":[0.1,true,null],\"s\":\"q\\\"\\\\\\u000a\",\"nan\":null,\"p\":[1.5,-2]}");
}

TEST(JsonWriterTest, DoublesRoundTrip) {
  for (const double v : {0.1, 1.0 / 3.0, 1e-300, 1137783293.2456784, -2.5e17}) {
    EXPECT_EQ(std::stod(FormatDouble(v)), v);
  }
}

}  // namespace
}  // namespace shape_slam::io
