// The mapper continued from a saved map (ShapeSlam's constructor from a map, `shape-slam run
// --map`): a map of the first part of a simulated drive is the starting map of a second mapper
// over the whole drive; its poses agree with the first mapper's, the loaded polylines stay in
// its map and the map grows where the first never went. The first pose comes from a known pose
// or from the localizer's global search (LocalizeFirstScan).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "pose_matchers.h"
#include "shape_slam/geometry.h"
#include "shape_slam/localizer.h"
#include "shape_slam/pipeline.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

// One lap around the block of LoopWorld, 1.5 m from it, a scan every 0.15 m of the perimeter
// (the heading follows the path, rounding each corner over one step); the odometry has a 2 %
// scale error. Truth in the world frame.
std::vector<LaserScan> DriveAroundTheBlock(int num_scans, unsigned seed) {
  const testing::Scene world = testing::LoopWorld();
  const std::vector<Point2> corners = {{1.5, 1.5}, {12.5, 1.5}, {12.5, 8.5}, {1.5, 8.5}};
  std::mt19937 prng(seed);
  std::vector<Pose2> truth;
  for (int side = 0; static_cast<int>(truth.size()) < num_scans; ++side) {
    const Point2 a = corners[side % 4], b = corners[(side + 1) % 4];
    const double heading = std::atan2(b.y() - a.y(), b.x() - a.x());
    const int steps = static_cast<int>(std::ceil((b - a).norm() / 0.15));
    for (int k = 0; k < steps; ++k) {
      const Point2 p = a + (b - a) * (static_cast<double>(k) / steps);
      truth.emplace_back(p.x(), p.y(), heading);
    }
  }
  std::vector<LaserScan> scans;
  Pose2 T_odom_robot;
  for (int i = 0; i < num_scans; ++i) {
    if (i > 0) {
      const Pose2 step = truth[i - 1].Inverse() * truth[i];
      T_odom_robot = T_odom_robot * Pose2(1.02 * step.x, step.y, step.theta);
    }
    LaserScan scan = testing::SimulateScan(world, truth[i], testing::ScannerModel{}, prng);
    scan.timestamp_s = 10.0 + 0.1 * i;
    scan.T_odom_robot = T_odom_robot;
    scans.push_back(std::move(scan));
  }
  return scans;
}

struct Mapped {
  std::vector<StampedPose> trajectory;
  PolylineMap map;
};

Mapped MapScans(ShapeSlam& slam, const std::vector<LaserScan>& scans, std::size_t first,
                std::size_t end) {
  for (std::size_t i = first; i < end; ++i) slam.Process(scans[i]);
  slam.Finish();
  return {slam.Trajectory(), slam.Map()};
}

// Distance from p to the nearest polyline of the map.
double DistanceToMap(const Point2& p, const PolylineMap& map) {
  double best = std::numeric_limits<double>::infinity();
  for (const PolylineId id : map.Ids()) {
    const Polyline& poly = map.Get(id).points;
    for (std::size_t k = 0; k + 1 < poly.size(); ++k) {
      best = std::min(best, SquaredDistanceToSegment(p, poly[k], poly[k + 1]));
    }
    if (poly.size() == 1) best = std::min(best, (p - poly[0]).squaredNorm());
  }
  return std::sqrt(best);
}

// The fraction of the vertices of `part` within `distance_m` of `whole`.
double FractionCovered(const PolylineMap& part, const PolylineMap& whole, double distance_m) {
  int covered = 0, total = 0;
  for (const PolylineId id : part.Ids()) {
    for (const Point2& p : part.Get(id).points) {
      ++total;
      covered += DistanceToMap(p, whole) <= distance_m ? 1 : 0;
    }
  }
  return total == 0 ? 0.0 : static_cast<double>(covered) / total;
}

// The fraction of the scans of `a` whose pose in `b` (same timestamp) is within 0.1 m.
double FractionAgreeing(const std::vector<StampedPose>& a, const std::vector<StampedPose>& b) {
  int agree = 0;
  for (const StampedPose& pa : a) {
    const auto it = std::find_if(b.begin(), b.end(), [&](const StampedPose& pb) {
      return pb.timestamp_s == pa.timestamp_s;
    });
    if (it != b.end() && (it->pose.Translation() - pa.pose.Translation()).norm() <= 0.1) ++agree;
  }
  return a.empty() ? 0.0 : static_cast<double>(agree) / a.size();
}

TEST(PipelineFromMapTest, ContinuesTheMapFromAKnownFirstPose) {
  const std::vector<LaserScan> scans = DriveAroundTheBlock(190, 3);
  ShapeSlam first;
  const Mapped part = MapScans(first, scans, 0, 80);  // the first side of the block only
  ShapeSlam continued(ShapeSlamParams{}, part.map, Pose2());  // scan 0 is the map origin
  const Mapped whole = MapScans(continued, scans, 0, scans.size());

  ASSERT_EQ(whole.trajectory.size(), scans.size());
  // Its keyframes on the loaded part are tied to the map (a frozen submap), not only the first.
  EXPECT_GE(continued.NumKeyframesInLoadedMap(), 10);
  EXPECT_GE(FractionAgreeing(part.trajectory, whole.trajectory), 0.9);
  EXPECT_GE(FractionCovered(part.map, whole.map, 0.1), 0.95);  // the loaded map is kept
  // ... and extended where the first part never saw: the block's north wall (world y = 7),
  // in the loaded map's frame (scan 0, at world (1.5, 1.5) heading +x, is its origin).
  const Pose2 T_world_map(1.5, 1.5, 0.0);
  const Point2 north_wall = T_world_map.Inverse() * Point2(7.0, 7.0);
  EXPECT_GT(DistanceToMap(north_wall, part.map), 0.5);
  EXPECT_LT(DistanceToMap(north_wall, whole.map), 0.15);
  const Pose2 last = T_world_map * whole.trajectory.back().pose;
  EXPECT_NEAR(last.y, 8.5, 0.2);  // scan 189: the far side of the block (world y = 8.5)
}

TEST(PipelineFromMapTest, TheLocalizerPlacesTheFirstScan) {
  const std::vector<LaserScan> scans = DriveAroundTheBlock(120, 4);
  ShapeSlam first;
  const Mapped part = MapScans(first, scans, 0, scans.size());
  // A later part of the drive, without its pose: found in the map by the global search.
  const std::vector<LaserScan> later(scans.begin() + 60, scans.end());
  const std::optional<FirstPose> found = LocalizeFirstScan(part.map, later, 10);
  ASSERT_TRUE(found.has_value());
  EXPECT_LT(found->scan, 10u);
  EXPECT_THAT(found->T_map_robot, IsNearly(part.trajectory[60 + found->scan].pose, 0.1, 0.05));

  ShapeSlam continued(ShapeSlamParams{}, part.map, found->T_map_robot);
  const Mapped again = MapScans(continued, later, found->scan, later.size());
  EXPECT_GE(FractionAgreeing(again.trajectory, part.trajectory), 0.9);
  EXPECT_GE(FractionCovered(part.map, again.map, 0.1), 0.95);
}

// A first pose that the next scans do not confirm (they see nothing, so the tracking is lost)
// does not count: the log enters the map where a pose holds for first_pose_confirm_scans more
// matched scans.
TEST(PipelineFromMapTest, AFirstPoseTheNextScansDoNotConfirmIsDropped) {
  const std::vector<LaserScan> scans = DriveAroundTheBlock(120, 4);
  ShapeSlam first;
  const Mapped part = MapScans(first, scans, 0, scans.size());
  std::vector<LaserScan> later(scans.begin() + 60, scans.end());
  LocalizerParams at_once;
  at_once.first_pose_confirm_scans = 0;
  const std::optional<FirstPose> unconfirmed = LocalizeFirstScan(part.map, later, 10, at_once);
  ASSERT_TRUE(unconfirmed.has_value());
  const std::size_t k = unconfirmed->scan;
  for (std::size_t i = k + 1; i <= k + 5; ++i) {  // blinded: no return on any beam
    std::fill(later[i].ranges_m.begin(), later[i].ranges_m.end(), later[i].max_range_m);
  }
  const std::optional<FirstPose> again = LocalizeFirstScan(part.map, later, 20, at_once);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->scan, k);  // at once: the pose the blinded scans never confirm

  const std::optional<FirstPose> found = LocalizeFirstScan(part.map, later, 20);
  ASSERT_TRUE(found.has_value());
  EXPECT_GT(found->scan, k + 5);
  EXPECT_LT(found->scan, 20u);
  EXPECT_THAT(found->T_map_robot, IsNearly(part.trajectory[60 + found->scan].pose, 0.1, 0.05));
}

TEST(PipelineFromMapTest, NoScanLocalizedInAnUnrelatedMapIsNoFirstPose) {
  const std::vector<LaserScan> scans = DriveAroundTheBlock(5, 5);
  PolylineMap elsewhere;  // one short wall far away: nothing of the scans fits it
  elsewhere.Add({{{100.0, 100.0}, {100.5, 100.0}}, {1.0, 1.0}, 1, 0});
  EXPECT_FALSE(LocalizeFirstScan(elsewhere, scans, 5).has_value());
}

TEST(PipelineFromMapTest, RejectsAnEmptyMapAndANonFinitePose) {
  PolylineMap map;
  EXPECT_THROW(ShapeSlam(ShapeSlamParams{}, map, Pose2()), std::invalid_argument);
  map.Add({{{0.0, 0.0}, {1.0, 0.0}}, {1.0, 1.0}, 1, 0});
  EXPECT_THROW(ShapeSlam(ShapeSlamParams{}, map, Pose2(NAN, 0.0, 0.0)), std::invalid_argument);
  ShapeSlamParams bad;
  bad.min_inlier_ratio = 2.0;
  EXPECT_THROW(ShapeSlam(bad, map, Pose2()), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
