// ShapeSlam::Keyframes(): what the occupancy grids of `shape-slam run` are built from.
#include <gtest/gtest.h>

#include <random>
#include <utility>
#include <vector>

#include "shape_slam/pipeline.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

TEST(PipelineKeyframesTest, OneViewPerKeyframeAtItsGraphPose) {
  const testing::Scene room = testing::OfficeRoom();
  std::mt19937 prng(7);
  ShapeSlam slam;
  std::size_t keyframes = 0;
  for (int i = 0; i < 20; ++i) {
    const Pose2 T_world_robot(1.0 + 0.1 * i, 1.5, 0.02 * i);
    LaserScan scan = testing::SimulateScan(room, T_world_robot, testing::ScannerModel{}, prng);
    scan.timestamp_s = 0.1 * i;
    scan.T_odom_robot = T_world_robot;
    keyframes += slam.Process(scan).keyframe ? 1 : 0;
  }
  const std::vector<ShapeSlam::KeyframeView> views = slam.Keyframes();
  ASSERT_EQ(views.size(), keyframes);
  ASSERT_GE(views.size(), 5u);  // 1.9 m driven, a keyframe every 0.2 m
  for (std::size_t k = 0; k < views.size(); ++k) {
    const Pose2 node = slam.Graph().Node(static_cast<int>(k));
    EXPECT_DOUBLE_EQ(views[k].T_map_robot.x, node.x);
    EXPECT_DOUBLE_EQ(views[k].T_map_robot.y, node.y);
    EXPECT_DOUBLE_EQ(views[k].T_map_robot.theta, node.theta);
    ASSERT_NE(views[k].scan, nullptr);
    EXPECT_EQ(views[k].scan->ranges_m.size(), views[k].scan->angles_rad.size());
    EXPECT_LT(views[k].scan->angles_rad.front(), views[k].scan->angles_rad.back());
  }
  EXPECT_DOUBLE_EQ(views.front().scan->timestamp_s, 0.0);  // the first scan is a keyframe
}

// TakeResult hands over what Map(), Keyframes(), LoopEvents() and Odometry() gave (the scans
// themselves, not views), after Finish; the map is the same map.
TEST(PipelineKeyframesTest, TakeResultHandsOverTheMapAndKeyframes) {
  const testing::Scene room = testing::OfficeRoom();
  std::mt19937 prng(11);
  ShapeSlam slam;
  for (int i = 0; i < 20; ++i) {
    const Pose2 T_world_robot(1.0 + 0.1 * i, 1.5 - 0.02 * i, -0.03 * i);
    LaserScan scan = testing::SimulateScan(room, T_world_robot, testing::ScannerModel{}, prng);
    scan.timestamp_s = 0.1 * i;
    scan.T_odom_robot = T_world_robot;
    slam.Process(scan);
  }
  slam.Finish();
  const std::vector<ShapeSlam::KeyframeView> views = slam.Keyframes();
  std::vector<LaserScan> scans;
  for (const ShapeSlam::KeyframeView& v : views) scans.push_back(*v.scan);
  const std::size_t polylines = slam.Map().NumPolylines(), vertices = slam.Map().NumVertices();
  const std::size_t events = slam.LoopEvents().size();
  const bool odometry_used = slam.Odometry().scans_with_odometry > 0;
  ASSERT_GT(polylines, 0u);

  const ShapeSlam::Result result = std::move(slam).TakeResult();
  EXPECT_EQ(result.map.NumPolylines(), polylines);
  EXPECT_EQ(result.map.NumVertices(), vertices);
  EXPECT_EQ(result.loop_events.size(), events);
  EXPECT_EQ(result.odometry.scans_with_odometry > 0, odometry_used);
  const std::vector<ShapeSlam::KeyframeView> taken = result.KeyframeViews();
  ASSERT_EQ(taken.size(), views.size());
  for (std::size_t k = 0; k < taken.size(); ++k) {
    EXPECT_EQ(taken[k].scan, &result.keyframes[k].scan);
    EXPECT_EQ(taken[k].scan->ranges_m, scans[k].ranges_m);
    EXPECT_DOUBLE_EQ(taken[k].scan->timestamp_s, scans[k].timestamp_s);
    EXPECT_DOUBLE_EQ(taken[k].T_map_robot.x, views[k].T_map_robot.x);
    EXPECT_DOUBLE_EQ(taken[k].T_map_robot.y, views[k].T_map_robot.y);
    EXPECT_DOUBLE_EQ(taken[k].T_map_robot.theta, views[k].T_map_robot.theta);
  }
}

}  // namespace
}  // namespace shape_slam
