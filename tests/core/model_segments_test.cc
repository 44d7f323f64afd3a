#include "shape_slam/internal/model_segments.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

namespace shape_slam::internal {
namespace {

TEST(MakeModelSegmentsTest, DropsDuplicatesAndMarksOpenEnds) {
  const std::vector<ModelSegment> segments = MakeModelSegments(
      {{{0.0, 0.0}, {0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}, {1.0, 1.0}}, {{5.0, 5.0}, {5.0, 5.0}}, {}});
  ASSERT_EQ(segments.size(), 3u);
  EXPECT_EQ(segments[0].a, Point2(0.0, 0.0));
  EXPECT_EQ(segments[0].b(), Point2(1.0, 0.0));
  EXPECT_TRUE(segments[0].open_start);
  EXPECT_FALSE(segments[0].open_end);
  EXPECT_FALSE(segments[1].open_start);
  EXPECT_TRUE(segments[1].open_end);
  EXPECT_EQ(segments[1].b(), Point2(1.0, 1.0));
  // A polyline collapsing to one point is a point segment without open ends.
  EXPECT_EQ(segments[2].a, Point2(5.0, 5.0));
  EXPECT_EQ(segments[2].inv_length2, 0.0);
  EXPECT_FALSE(segments[2].open_start || segments[2].open_end);
}

TEST(MatchSegmentTest, FlagsProjectionsBeyondOpenEnds) {
  const std::vector<ModelSegment> s = MakeModelSegments({{{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}}});
  EXPECT_TRUE(MatchSegment({-0.5, 0.2}, s[0], 0).beyond_end);  // before the first vertex
  EXPECT_FALSE(MatchSegment({0.5, 0.2}, s[0], 0).beyond_end);
  EXPECT_FALSE(MatchSegment({1.5, -0.2}, s[0], 0).beyond_end);  // past an inner vertex
  EXPECT_TRUE(MatchSegment({1.2, 1.5}, s[1], 1).beyond_end);    // past the last vertex
  const SegmentMatch m = MatchSegment({1.5, -0.2}, s[0], 0);
  EXPECT_EQ(m.point, Point2(1.0, 0.0));
  EXPECT_NEAR(m.squared_distance, 0.25 + 0.04, 1e-15);
}

// Oracle: the grid finds exactly what a linear scan over all segments finds within the radius,
// for short and long segments, points, far-away queries and huge coordinates.
TEST(SegmentGridTest, AgreesWithLinearScan) {
  std::mt19937 prng(42);
  for (const double offset : {0.0, 1e6}) {
    for (const double radius : {0.05, 0.3, 2.0}) {
      std::uniform_real_distribution<double> coordinate(offset - 10.0, offset + 10.0);
      std::uniform_real_distribution<double> step(-0.8, 0.8);
      std::vector<Polyline> polylines;
      for (int i = 0; i < 30; ++i) {
        Polyline polyline = {{coordinate(prng), coordinate(prng)}};
        const int n = i % 7;  // 0: a point
        for (int k = 0; k < n; ++k)
          polyline.push_back(polyline.back() + Point2(step(prng), step(prng)));
        polylines.push_back(polyline);
      }
      polylines.push_back({{offset - 9.0, offset - 9.0}, {offset + 9.5, offset + 8.0}});  // long
      polylines.push_back(
          {{offset + 3.0, offset - 9.0}, {offset + 3.0, offset + 9.0}});  // vertical
      const std::vector<ModelSegment> segments = MakeModelSegments(polylines);
      const SegmentGrid grid(segments, radius);
      std::uniform_real_distribution<double> query(offset - 12.0, offset + 12.0);
      int found = 0;
      for (int q = 0; q < 3000; ++q) {
        const Point2 p(query(prng), query(prng));
        const SegmentMatch expected =
            NearestSegment(p, segments, 0, segments.size(), radius * radius);
        const SegmentMatch actual = grid.Nearest(p);
        ASSERT_EQ(actual.segment, expected.segment) << "query " << p.transpose();
        if (expected.segment >= 0) {
          ++found;
          EXPECT_EQ(actual.squared_distance, expected.squared_distance);
          EXPECT_EQ(actual.beyond_end, expected.beyond_end);
        }
      }
      EXPECT_GT(found, 30);  // the comparison is not vacuous
      EXPECT_EQ(grid.Nearest({offset + 1e4, offset}).segment, -1);
    }
  }
}

// A model much larger than the radius: the grid caps its cells per side and stays exact.
TEST(SegmentGridTest, LargeModelCapsTheGrid) {
  const std::vector<ModelSegment> segments =
      MakeModelSegments({{{0.0, 0.0}, {1000.0, 0.0}}, {{0.0, 500.0}, {1000.0, 500.0}}});
  const SegmentGrid grid(segments, 0.3);
  EXPECT_EQ(grid.Nearest({400.0, 0.2}).segment, 0);
  EXPECT_EQ(grid.Nearest({400.0, 499.75}).segment, 1);
  EXPECT_EQ(grid.Nearest({400.0, 250.0}).segment, -1);
}

TEST(SegmentGridTest, EmptyModelAndInvalidRadius) {
  EXPECT_EQ(SegmentGrid({}, 0.3).Nearest({0.0, 0.0}).segment, -1);
  EXPECT_THROW(SegmentGrid({}, 0.0), std::invalid_argument);
  EXPECT_THROW(SegmentGrid({}, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam::internal
