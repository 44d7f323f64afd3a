// ShapeSlam::Keyframes(): what the occupancy grids of `shape-slam run` are built from.
#include <gtest/gtest.h>

#include <random>

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

}  // namespace
}  // namespace shape_slam
