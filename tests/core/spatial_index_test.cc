#include "shape_slam/spatial_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

TEST(SegmentIndexTest, DiscQueryEqualsBruteForce) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> u(-30.0, 30.0), len(-8.0, 8.0);
  SegmentIndex index(2.0);
  std::vector<Polyline> polylines;
  for (PolylineId id = 0; id < 200; ++id) {
    Polyline p = {{u(prng), u(prng)}};
    for (int k = 0; k < 1 + static_cast<int>(id % 4); ++k) p.push_back(p.back() + Point2(len(prng), len(prng)));
    if (id % 17 == 0) p = {{std::floor(u(prng)), 4.0}, {std::floor(u(prng)), 4.0}};  // on cell lines
    polylines.push_back(p);
    index.Insert(id, p);
  }
  for (int q = 0; q < 200; ++q) {
    const Point2 c(u(prng), u(prng));
    const double r = std::abs(len(prng)) + 0.1;
    std::vector<SegmentRef> expected;
    for (PolylineId id = 0; id < polylines.size(); ++id) {
      for (std::uint32_t s = 0; s + 1 < polylines[id].size(); ++s) {
        if (SquaredDistanceToSegment(c, polylines[id][s], polylines[id][s + 1]) <= r * r) {
          expected.push_back({id, s});
        }
      }
    }
    ASSERT_EQ(index.QueryDisc(c, r), expected) << "query " << q;
    // The box query is a superset of the segments crossing the box.
    const std::vector<SegmentRef> box = index.QueryBox(c - Point2(r, r), c + Point2(r, r));
    for (const SegmentRef& ref : expected) {
      EXPECT_TRUE(std::binary_search(box.begin(), box.end(), ref));
    }
  }
}

TEST(SegmentIndexTest, InsertReplaceRemove) {
  SegmentIndex index(1.0);
  index.Insert(7, {{0, 0}, {10, 0}});
  EXPECT_EQ(index.QueryDisc({5, 0.5}, 1.0).size(), 1u);
  index.Insert(7, {{0, 5}, {1, 5}});  // replaces
  EXPECT_TRUE(index.QueryDisc({5, 0.5}, 1.0).empty());
  EXPECT_EQ(index.QueryDisc({0.5, 5}, 0.1).size(), 1u);
  index.Insert(8, {{-3.5, -3.5}});  // one vertex: a point
  EXPECT_EQ(index.QueryDisc({-3.5, -3.4}, 0.2), std::vector<SegmentRef>({{8, 0}}));
  EXPECT_EQ(index.NumPolylines(), 2u);
  index.Remove(7);
  index.Remove(99);  // absent: no-op
  EXPECT_TRUE(index.QueryDisc({0.5, 5}, 1.0).empty());
  index.Clear();
  EXPECT_EQ(index.NumPolylines(), 0u);
  EXPECT_THROW(SegmentIndex(0.0), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
