// The polyline map's bookkeeping (polyline_map.h): ids, the vertex count, the index behind the
// visible shape, and snapshots (a copy of the polylines to restore the map to).
#include "shape_slam/polyline_map.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

namespace shape_slam {
namespace {

MapPolyline Wall(const Point2& a, const Point2& b) {
  MapPolyline p;
  p.points = {a, b};
  p.support = {1.0, 1.0};
  return p;
}

TEST(PolylineMapTest, IdsAreNeverReusedAndCountsFollowTheContent) {
  PolylineMap map;
  const PolylineId a = map.Add(Wall({0.0, 0.0}, {1.0, 0.0}));
  const PolylineId b = map.Add(Wall({0.0, 1.0}, {1.0, 1.0}));
  EXPECT_NE(a, b);
  EXPECT_EQ(map.NumVertices(), 4u);
  map.Remove(a);
  EXPECT_FALSE(map.Contains(a));
  EXPECT_GT(map.Add(Wall({2.0, 0.0}, {3.0, 0.0})), b);
  EXPECT_EQ(map.NumPolylines(), 2u);
  MapPolyline broken = Wall({0.0, 0.0}, {1.0, 0.0});
  broken.support.pop_back();
  EXPECT_THROW(map.Add(broken), std::invalid_argument);
}

// Polylines() is every polyline's points in the order of Ids(), whatever the order of adding.
TEST(PolylineMapTest, PolylinesFollowTheIds) {
  PolylineMap map;
  const PolylineId a = map.Add(Wall({0.0, 0.0}, {1.0, 0.0}));
  map.Add(Wall({0.0, 1.0}, {1.0, 1.0}));
  const PolylineId c = map.Add(Wall({2.0, 0.0}, {3.0, 0.0}));
  map.Remove(a);
  map.Replace(c, Wall({5.0, 0.0}, {6.0, 0.0}));
  const std::vector<Polyline> polylines = map.Polylines();
  const std::vector<PolylineId> ids = map.Ids();
  ASSERT_EQ(polylines.size(), ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) EXPECT_EQ(polylines[i], map.Get(ids[i]).points);
  EXPECT_EQ(polylines.back().front(), Point2(5.0, 0.0));
  EXPECT_TRUE(PolylineMap().Polylines().empty());
}

TEST(PolylineMapTest, RestoredSnapshotIsTheMapItWasTakenFrom) {
  PolylineMap map;
  map.Add(Wall({2.0, -1.0}, {2.0, 1.0}));
  const PolylineId kept = map.Add(Wall({-1.0, 3.0}, {1.0, 3.0}));
  const PolylineMap::Snapshot snapshot = map.TakeSnapshot();
  VisibilityParams visibility;
  visibility.fov_rad = 2.0 * M_PI;
  const std::vector<VisiblePolyline> before = map.Visible(Pose2(), visibility);
  // Change it, then go back.
  map.Remove(kept);
  const PolylineId added = map.Add(Wall({-2.0, -1.0}, {-2.0, 1.0}));
  map.Restore(snapshot);
  EXPECT_EQ(map.NumPolylines(), 2u);
  EXPECT_EQ(map.NumVertices(), 4u);
  EXPECT_TRUE(map.Contains(kept));
  EXPECT_FALSE(map.Contains(added));
  EXPECT_EQ(map.Get(kept).points, snapshot[1].second.points);
  const std::vector<VisiblePolyline> after = map.Visible(Pose2(), visibility);
  ASSERT_EQ(after.size(), before.size());
  for (std::size_t i = 0; i < after.size(); ++i) {
    EXPECT_EQ(after[i].source, before[i].source);
    EXPECT_EQ(after[i].points_sensor, before[i].points_sensor);
  }
  // The index was rebuilt too: the removed-and-restored wall is found near where it lies.
  EXPECT_EQ(map.IdsNear({-0.5, 2.5}, {0.5, 3.5}), std::vector<PolylineId>{kept});
  // Ids added after the restore still follow every id used before it.
  EXPECT_GT(map.Add(Wall({0.0, -3.0}, {1.0, -3.0})), added);
}

}  // namespace
}  // namespace shape_slam
