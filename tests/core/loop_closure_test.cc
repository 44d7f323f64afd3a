// Loop closure (loop_closure.h) on simulated keyframe graphs: a robot drives through a building,
// one scan per metre; the graph's consecutive edges carry a growing heading drift (as a badly
// calibrated odometry or a biased scan matcher would), so the estimate is metres off when the
// robot returns. Loops must close and the optimised graph must be right (a large loop, a figure
// eight); in a building that is symmetric under a half turn (two identical parallel corridors)
// no closure may join the wrong corridor.
#include "shape_slam/loop_closure.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include "shape_slam/pipeline.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

using testing::Scene;

// A rectangular ring corridor: the outer walls [x0, x1] x [y0, y1], a block inside `width` from
// them.
Scene RingCorridor(double x0, double y0, double x1, double y1, double width) {
  Scene s = testing::Room(x0, y0, x1, y1);
  const Scene block = testing::Room(x0 + width, y0 + width, x1 - width, y1 - width);
  s.insert(s.end(), block.begin(), block.end());
  return s;
}

// A box 1 m wide standing `depth` out of the wall y = y_wall (into +y when depth > 0), from x.
void AddBumpX(Scene& s, double x, double y_wall, double depth) {
  s.push_back({{x, y_wall}, {x, y_wall + depth}});
  s.push_back({{x, y_wall + depth}, {x + 1.0, y_wall + depth}});
  s.push_back({{x + 1.0, y_wall + depth}, {x + 1.0, y_wall}});
}

// The same out of the wall x = x_wall (into +x when depth > 0), from y.
void AddBumpY(Scene& s, double y, double x_wall, double depth) {
  s.push_back({{x_wall, y}, {x_wall + depth, y}});
  s.push_back({{x_wall + depth, y}, {x_wall + depth, y + 1.0}});
  s.push_back({{x_wall + depth, y + 1.0}, {x_wall, y + 1.0}});
}

struct Drive {
  std::vector<Pose2> truth;     // robot poses, one per metre
  std::vector<Pose2> estimate;  // composed from the drifting relative motions
  std::vector<Pose2> measured;  // the drifting relative motion to each pose from the previous
};

// Poses every `step` metres along the waypoints (heading along each leg); the measured motion
// turns `drift_rad_per_m` too far per metre driven, plus a little noise.
Drive DriveAlong(const std::vector<Point2>& waypoints, double step, double drift_rad_per_m,
                 unsigned seed) {
  std::mt19937 prng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Drive d;
  for (std::size_t w = 0; w + 1 < waypoints.size(); ++w) {
    const Point2 a = waypoints[w], b = waypoints[w + 1];
    const double heading = std::atan2(b.y() - a.y(), b.x() - a.x());
    const int n = std::max(1, static_cast<int>(std::lround((b - a).norm() / step)));
    for (int k = (w == 0 ? 0 : 1); k <= n; ++k) {
      const Point2 p = a + (b - a) * (static_cast<double>(k) / n);
      d.truth.emplace_back(p.x(), p.y(), heading);
    }
  }
  d.estimate.push_back(d.truth[0]);
  d.measured.emplace_back();
  for (std::size_t i = 1; i < d.truth.size(); ++i) {
    const Pose2 rel = d.truth[i - 1].Inverse() * d.truth[i];
    const double moved = rel.Translation().norm();
    const Pose2 m(rel.x + 0.005 * noise(prng), rel.y + 0.005 * noise(prng),
                  rel.theta + drift_rad_per_m * moved + 0.001 * noise(prng));
    d.measured.push_back(m);
    d.estimate.push_back(d.estimate.back() * m);
  }
  return d;
}

double PositionRmse(const std::vector<Pose2>& a, const std::vector<Pose2>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += (a[i].Translation() - b[i].Translation()).squaredNorm();
  return std::sqrt(sum / a.size());
}

struct Result {
  int closures = 0;
  double rmse_before = 0.0;
  double rmse_after = 0.0;
  PoseGraph graph;
  std::vector<Pose2> truth;
  std::vector<LoopEvent> events;
};

// Feeds the drive to a LoopCloser keyframe by keyframe, optimising whenever it asks and once
// at the end, as the mapper does.
// From keyframe `changed_from` on the scans see `changed` instead of `world` (when given).
// `final_update`: the end-of-log searches too (LoopCloser::FinalUpdate, as ShapeSlam::Finish).
Result CloseLoops(const Scene& world, const Drive& drive, unsigned seed,
                  const ShapeSlamParams& params = ShapeSlamParams(),
                  const Scene* changed = nullptr, std::size_t changed_from = 0,
                  bool final_update = false) {
  LoopCloser closer(params.loop_closure, ToScanMatchParams(params));
  std::mt19937 prng(seed);
  std::vector<LoopKeyframe> keyframes;
  Result r;
  double travel = 0.0;
  for (std::size_t i = 0; i < drive.truth.size(); ++i) {
    const LaserScan scan = testing::SimulateScan(changed && i >= changed_from ? *changed : world, drive.truth[i],
                                                testing::ScannerModel{}, prng);
    const int node = r.graph.AddNode(i == 0 ? drive.truth[0] : r.graph.Node(static_cast<int>(i) - 1) * drive.measured[i]);
    if (i > 0) {
      travel += drive.measured[i].Translation().norm();
      PoseGraphEdge e;
      e.from = node - 1;
      e.to = node;
      e.T_from_to = drive.measured[i];
      e.covariance = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.01 * 0.01).asDiagonal();
      r.graph.AddEdge(e);
    }
    keyframes.push_back({node, ExtractScanShapes(scan, params.shapes), Pose2(), travel});
    if (closer.Update(keyframes, r.graph)) r.graph.Optimize(params.loop_closure.graph);
  }
  if (final_update) {
    const int searches = closer.NumSearches();
    const auto optimize = [&] { r.graph.Optimize(params.loop_closure.graph); };
    closer.FinalUpdate(keyframes, r.graph, optimize);
    const int sweep = params.loop_closure.final_sweep_every;
    const int swept = sweep > 0 ? (static_cast<int>(keyframes.size()) - 2) / sweep : 0;
    EXPECT_LE(closer.NumSearches() - searches, swept + params.loop_closure.final_searches);
    const int after = closer.NumSearches();
    closer.FinalUpdate(keyframes, r.graph, optimize);  // once per last keyframe
    EXPECT_EQ(closer.NumSearches(), after);
  }
  r.rmse_before = PositionRmse(drive.estimate, drive.truth);
  r.graph.Optimize(params.loop_closure.graph);
  std::vector<Pose2> optimised;
  for (int n = 0; n < r.graph.NumNodes(); ++n) optimised.push_back(r.graph.Node(n));
  r.rmse_after = PositionRmse(optimised, drive.truth);
  r.closures = closer.NumLoopClosures();
  r.events = closer.Events();
  r.truth = drive.truth;
  return r;
}

// Every accepted loop edge agrees with the true relative pose.
void ExpectLoopEdgesRight(const Result& r) {
  for (const PoseGraphEdge& e : r.graph.Edges()) {
    if (!e.loop) continue;
    const Pose2 truth = r.truth[e.from].Inverse() * r.truth[e.to];
    const Pose2 error = truth.Inverse() * e.T_from_to;
    EXPECT_LT(error.Translation().norm(), 0.3) << "loop edge " << e.from << " -> " << e.to;
    EXPECT_LT(std::abs(error.theta), 0.05) << "loop edge " << e.from << " -> " << e.to;
  }
}

// A 40 x 24 m ring corridor driven once around and on for half a side: the heading drift
// (0.25 deg per metre, 32 deg around the loop) puts the estimate metres off the start.
Scene LargeLoopWorld() {
  Scene world = RingCorridor(0.0, 0.0, 40.0, 24.0, 3.0);
  AddBumpX(world, 7.0, 0.0, 0.6);
  AddBumpX(world, 18.5, 0.0, 0.4);
  AddBumpX(world, 31.0, 24.0, -0.5);
  AddBumpX(world, 12.0, 24.0, -0.7);
  AddBumpY(world, 9.0, 40.0, -0.5);
  AddBumpY(world, 15.0, 0.0, 0.6);
  return world;
}

Drive LargeLoopDrive() {
  const std::vector<Point2> path = {{1.5, 1.5}, {38.5, 1.5}, {38.5, 22.5}, {1.5, 22.5},
                                    {1.5, 1.5}, {22.0, 1.5}};
  return DriveAlong(path, 1.0, 0.25 * M_PI / 180.0, 1);
}

TEST(LoopClosureTest, ClosesALargeLoopWithGrowingDrift) {
  const Result r = CloseLoops(LargeLoopWorld(), LargeLoopDrive(), 2);
  EXPECT_GT(r.rmse_before, 3.0);                  // the drift is large ...
  EXPECT_GE(r.closures, 2);                       // ... the loop closes ...
  EXPECT_LT(r.rmse_after, 0.2 * r.rmse_before);   // ... and most of the drift is gone
  EXPECT_LT(r.rmse_after, 1.0) << "before " << r.rmse_before;
  ExpectLoopEdgesRight(r);
}

// The record of the closures (loops.csv): every loop edge in the graph is one event that put
// it there, with the same edge; every pending closure was found before it was confirmed.
TEST(LoopClosureTest, EventsRecordEveryClosureAndItsFate) {
  const Result r = CloseLoops(LargeLoopWorld(), LargeLoopDrive(), 2);
  ASSERT_GE(r.closures, 2);
  std::vector<const LoopEvent*> added;
  for (const LoopEvent& e : r.events) {
    if (e.decision == LoopDecision::kAgreed || e.decision == LoopDecision::kTaken ||
        e.decision == LoopDecision::kConfirmed) {
      added.push_back(&e);
    }
    EXPECT_LT(e.closure.old_keyframe, e.closure.new_keyframe);
  }
  ASSERT_EQ(static_cast<int>(added.size()), r.closures);
  std::size_t next = 0;
  for (const PoseGraphEdge& edge : r.graph.Edges()) {
    if (!edge.loop) continue;
    ASSERT_LT(next, added.size());
    const PoseGraphEdge& recorded = added[next++]->closure.edge;
    EXPECT_EQ(recorded.from, edge.from);
    EXPECT_EQ(recorded.to, edge.to);
    EXPECT_DOUBLE_EQ(recorded.T_from_to.x, edge.T_from_to.x);
    EXPECT_DOUBLE_EQ(recorded.T_from_to.theta, edge.T_from_to.theta);
  }
  EXPECT_EQ(next, added.size());
  for (std::size_t i = 0; i < r.events.size(); ++i) {
    if (r.events[i].decision != LoopDecision::kConfirmed) continue;
    const int key = r.events[i].closure.new_keyframe;
    const bool found_earlier =
        std::any_of(r.events.begin(), r.events.begin() + i, [&](const LoopEvent& e) {
          return e.decision == LoopDecision::kPending && e.closure.new_keyframe == key;
        });
    const bool last_of_group =
        i + 1 == r.events.size() || r.events[i + 1].decision != LoopDecision::kConfirmed;
    EXPECT_TRUE(found_earlier || last_of_group) << "event " << i;
  }
  EXPECT_STREQ(LoopDecisionName(LoopDecision::kRefused), "refused");
}

// confirm_near_m: closures that ask for large corrections confirm each other when their new
// keyframes are near, however many keyframes apart. With the keyframe window at 1 no two
// searches (every 4th keyframe, 4 m apart in this drive) could confirm each other, so the
// drifted loop stays open, and so it does with the rule at 3.5 m; at 4.5 m the same searches
// close it.
TEST(LoopClosureTest, LargeCorrectionsNearEachOtherConfirmEachOther) {
  ShapeSlamParams params;
  params.loop_closure.confirm_within_keyframes = 1;
  params.loop_closure.confirm_near_m = 0.0;
  const Result open = CloseLoops(LargeLoopWorld(), LargeLoopDrive(), 2, params);
  EXPECT_GT(open.rmse_after, 0.9 * open.rmse_before) << "closed without the rule";
  params.loop_closure.confirm_near_m = 3.5;  // searches 4 m apart are not near
  const Result apart = CloseLoops(LargeLoopWorld(), LargeLoopDrive(), 2, params);
  EXPECT_GT(apart.rmse_after, 0.9 * apart.rmse_before) << "closed by closures 4 m apart";
  params.loop_closure.confirm_near_m = 4.5;
  const Result closed = CloseLoops(LargeLoopWorld(), LargeLoopDrive(), 2, params);
  EXPECT_GE(closed.closures, 2);
  EXPECT_LT(closed.rmse_after, 0.3 * closed.rmse_before);
  ExpectLoopEdgesRight(closed);
  const bool confirmed = std::any_of(closed.events.begin(), closed.events.end(), [](const LoopEvent& e) {
    return e.decision == LoopDecision::kConfirmed;
  });
  EXPECT_TRUE(confirmed);
}

// Two closures of a revisit, 2 -> 12 and 3 -> 13, that agree exactly with a graph of keyframes
// one metre apart: consistent, unless the step 12 -> 13 is one only the motion model guessed
// (the cycle then crosses a motion nothing measured); a loop edge around that step restores it.
TEST(LoopClosureTest, ClosuresConfirmEachOtherOnlyAcrossMeasuredSteps) {
  const auto check = [](bool guessed, bool bypass) {
    PoseGraph graph;
    std::vector<LoopKeyframe> keyframes;
    for (int k = 0; k < 16; ++k) {
      // The second pass (10..15) runs back over the first, 0.5 m to the side.
      const Pose2 pose = k < 10 ? Pose2(k, 0.0, 0.0) : Pose2(k - 10.0, 0.5, 0.0);
      const int node = graph.AddNode(pose);
      if (k > 0) {
        PoseGraphEdge e;
        e.from = node - 1;
        e.to = node;
        e.T_from_to = graph.Node(node - 1).Inverse() * pose;
        e.guessed = guessed && k == 13;
        graph.AddEdge(e);
      }
      keyframes.push_back({node, ScanShapes(), Pose2(), static_cast<double>(k)});
    }
    if (bypass) graph.AddEdge({11, 14, graph.Node(11).Inverse() * graph.Node(14),
                               Eigen::Matrix3d::Identity(), true});
    const auto closure = [&](int old, int now) {
      LoopClosure c;
      c.edge = {old, now, graph.Node(old).Inverse() * graph.Node(now), Eigen::Matrix3d::Identity(), true};
      c.old_keyframe = old;
      c.new_keyframe = now;
      return c;
    };
    const LoopCloser closer(LoopClosureParams{}, ScanMatchParams{});
    return closer.Consistent(closure(2, 12), closure(3, 13), keyframes, graph);
  };
  EXPECT_TRUE(check(/*guessed=*/false, /*bypass=*/false));
  EXPECT_FALSE(check(/*guessed=*/true, /*bypass=*/false));
  EXPECT_TRUE(check(/*guessed=*/true, /*bypass=*/true));
}

TEST(LoopClosureTest, MatchesThatPutTheKeyframeApartAreAmbiguous) {
  const std::vector<ImpliedPose> agree = {{Pose2(10.0, 2.0, 0.1), 0.95},
                                          {Pose2(10.3, 2.2, 0.12), 0.9},
                                          {Pose2(9.8, 2.1, 0.1), 0.8}};
  EXPECT_FALSE(AmbiguousMatches(agree, 1.0, 0.1));
  EXPECT_FALSE(AmbiguousMatches({agree[0]}, 1.0, 0.1));
  EXPECT_FALSE(AmbiguousMatches({}, 1.0, 0.1));
  // A look-alike place one corridor period on, fitting nearly as well: ambiguous ...
  std::vector<ImpliedPose> apart = agree;
  apart.push_back({Pose2(25.0, 2.0, 0.1), 0.9});
  EXPECT_TRUE(AmbiguousMatches(apart, 1.0, 0.1));
  EXPECT_FALSE(AmbiguousMatches(apart, 0.0, 0.1));  // off
  // ... fitting clearly worse than the best: not.
  apart.back().fit = 0.8;
  EXPECT_FALSE(AmbiguousMatches(apart, 1.0, 0.1));
  // The best is the one that fits best, wherever it lies.
  apart.back().fit = 1.0;
  EXPECT_TRUE(AmbiguousMatches(apart, 1.0, 0.1));
  EXPECT_STREQ(LoopDecisionName(LoopDecision::kAmbiguous), "ambiguous");
}

// Look-alikes along one corridor (AcrossCorridor): the matches agree on the heading and on the
// offset across the corridor and disagree along it, so the best is kept for those two: its
// position along the corridor the graph's own, loosely held; turned or scattered rivals, or the
// option off, keep the search ambiguous.
TEST(LoopClosureTest, LookAlikesAlongOneCorridorKeepTheHeadingAndTheOffsetAcrossIt) {
  PoseGraph graph;
  graph.AddNode(Pose2());                 // the old keyframe
  graph.AddNode(Pose2(20.0, 1.0, 0.0));   // the new one, as the drifted graph has it
  LoopClosure best;
  const Eigen::Matrix3d tight = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  best.edge = {0, 1, Pose2(25.0, 0.5, 0.1), tight, true};
  best.inlier_ratio = 0.9;
  // The new keyframe as each match puts it: the best, and look-alikes 5 m ahead and behind along
  // the corridor (the keyframe's own x axis), nearly as good.
  const Pose2 at = graph.Node(0) * best.edge.T_from_to;
  std::vector<ImpliedPose> implied = {
      {at * Pose2(-5.0, 0.02, 0.01), 0.85}, {at, 0.9}, {at * Pose2(5.0, -0.03, -0.01), 0.88}};
  ASSERT_TRUE(AmbiguousMatches(implied, 1.0, 0.2));
  const LoopClosureParams params;
  const std::optional<LoopClosure> across = AcrossCorridor(implied, best, graph, params);
  ASSERT_TRUE(across);
  EXPECT_TRUE(across->across_only);
  // The farthest rival sets the line: 5 m along and 3 cm across it.
  EXPECT_NEAR(across->along_rad, 0.1 + std::atan2(-0.03, 5.0), 1e-9);
  const Point2 line = Point2(std::cos(across->along_rad), std::sin(across->along_rad));
  const Point2 across_line(-line.y(), line.x());
  const Pose2& edge = across->edge.T_from_to;
  EXPECT_DOUBLE_EQ(edge.theta, 0.1);  // the heading the matches agree on
  EXPECT_NEAR(edge.Translation().dot(line), Point2(20.0, 1.0).dot(line), 1e-9);  // the graph's
  EXPECT_NEAR(edge.Translation().dot(across_line), Point2(25.0, 0.5).dot(across_line), 1e-9);
  const Eigen::Matrix2d c = across->edge.covariance.topLeftCorner<2, 2>();
  EXPECT_NEAR(line.dot(c * line), 1e-4 + params.corridor_sigma_m * params.corridor_sigma_m, 1e-9);
  EXPECT_NEAR(across_line.dot(c * across_line), 1e-4, 1e-9);
  EXPECT_DOUBLE_EQ(across->edge.covariance(2, 2), 1e-5);
  // The correction asks nothing along the line: only the heading and the offset across it.
  // (The graph's new keyframe heads 0: its frame is the old one's turned by nothing.)
  EXPECT_NEAR(across->correction.Translation().dot(line), 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(across->correction.theta, 0.1);

  // A rival turned beyond corridor_heading_rad, one off the line, or the option off: none.
  std::vector<ImpliedPose> turned = implied;
  turned[0].T_graph_keyframe = at * Pose2(-5.0, 0.0, 0.2);
  EXPECT_FALSE(AcrossCorridor(turned, best, graph, params));
  std::vector<ImpliedPose> scattered = implied;
  scattered[2].T_graph_keyframe = at * Pose2(5.0, -3.0, 0.0);
  EXPECT_FALSE(AcrossCorridor(scattered, best, graph, params));
  LoopClosureParams off = params;
  off.corridor_sigma_m = 0.0;
  EXPECT_FALSE(AcrossCorridor(implied, best, graph, off));
  // A rival clearly worse than the margin does not count, and without the others nothing is
  // ambiguous along a line.
  const std::vector<ImpliedPose> near = {
      {at, 0.9}, {at * Pose2(0.3, 0.0, 0.0), 0.88}, {at * Pose2(8.0, 4.0, 0.5), 0.5}};
  EXPECT_FALSE(AcrossCorridor(near, best, graph, params));
}

// The loop above needs the full search (the estimate is metres off when the robot returns).
// On the second lap boxes stand along the first corridor, which the old place does not have:
// the scans fit it only in part. The loop closes with the default refine_min_fit and stays open
// when no candidate fits well enough to be refined (the quick check off).
TEST(LoopClosureTest, CandidatesBelowRefineMinFitAreNotRefined) {
  const Scene world = LargeLoopWorld();
  Scene cluttered = world;
  for (double x = 4.0; x < 24.0; x += 2.5) AddBumpX(cluttered, x, 3.0, -0.4);
  const std::size_t second_lap = 110;  // keyframes, one per metre: the first lap is 116 m
  ShapeSlamParams params;
  params.loop_closure.quick_min_fit = 1.01;
  const Result closed = CloseLoops(world, LargeLoopDrive(), 2, params, &cluttered, second_lap);
  EXPECT_GE(closed.closures, 2);
  EXPECT_LT(closed.rmse_after, 1.0);
  params.loop_closure.refine_min_fit = 0.99;
  const Result open = CloseLoops(world, LargeLoopDrive(), 2, params, &cluttered, second_lap);
  EXPECT_EQ(open.closures, 0);
  EXPECT_GT(open.rmse_after, 3.0);
}

// Two ring corridors side by side sharing the middle one, driven as a figure eight: the middle
// corridor twice, in opposite directions.
TEST(LoopClosureTest, ClosesAFigureEight) {
  Scene world = testing::Room(0.0, 0.0, 44.0, 22.0);
  for (const Scene& block : {testing::Room(3.0, 3.0, 20.0, 19.0), testing::Room(24.0, 3.0, 41.0, 19.0)}) {
    world.insert(world.end(), block.begin(), block.end());
  }
  AddBumpX(world, 6.0, 0.0, 0.5);
  AddBumpX(world, 33.0, 0.0, 0.6);
  AddBumpX(world, 12.0, 22.0, -0.5);
  AddBumpX(world, 28.5, 22.0, -0.6);
  AddBumpY(world, 8.0, 0.0, 0.5);
  AddBumpY(world, 13.0, 44.0, -0.5);
  AddBumpY(world, 6.0, 20.0, 0.4);   // in the middle corridor
  AddBumpY(world, 14.0, 24.0, -0.4);
  const std::vector<Point2> path = {{22.0, 1.5},  {22.0, 20.5}, {42.5, 20.5}, {42.5, 1.5},
                                    {22.0, 1.5},  {1.5, 1.5},   {1.5, 20.5},  {22.0, 20.5},
                                    {22.0, 1.5},  {32.0, 1.5}};
  const Drive drive = DriveAlong(path, 1.0, 0.2 * M_PI / 180.0, 3);
  const Result r = CloseLoops(world, drive, 4);
  EXPECT_GT(r.rmse_before, 3.0);
  EXPECT_GE(r.closures, 2);
  EXPECT_LT(r.rmse_after, 0.2 * r.rmse_before);
  EXPECT_LT(r.rmse_after, 1.2) << "before " << r.rmse_before;
  ExpectLoopEdgesRight(r);
}

// Two identical parallel corridors (the building looks the same turned by half a turn about
// its centre), joined at both ends, driven twice around with little drift: the way back along
// the second corridor looks exactly like the first one driven the other way. Closures must
// join each corridor to itself, never to its twin.
TEST(LoopClosureTest, DoesNotJoinLookAlikeParallelCorridors) {
  Scene world = RingCorridor(0.0, 0.0, 36.0, 11.0, 3.0);
  // Boxes placed symmetrically under the half turn about (18, 5.5).
  for (const double x : {6.0, 14.0, 25.5}) {
    AddBumpX(world, x, 0.0, 0.5);
    AddBumpX(world, 36.0 - x - 1.0, 11.0, -0.5);
  }
  const std::vector<Point2> path = {{1.5, 1.5}, {34.5, 1.5}, {34.5, 9.5}, {1.5, 9.5},
                                    {1.5, 1.5}, {34.5, 1.5}, {34.5, 9.5}, {1.5, 9.5}};
  const Drive drive = DriveAlong(path, 1.0, 0.05 * M_PI / 180.0, 5);
  const Result r = CloseLoops(world, drive, 6);
  EXPECT_GE(r.closures, 2);
  ExpectLoopEdgesRight(r);
  EXPECT_LT(r.rmse_after, 0.3) << "before " << r.rmse_before;
}

// Only a closure from a later keyframe confirms a pending one: not one from the same keyframe
// searched again, nor one from an earlier keyframe searched after it (the end-of-log searches).
TEST(LoopClosureTest, OnlyALaterKeyframeConfirms) {
  PoseGraph graph;
  std::vector<LoopKeyframe> keyframes;
  for (int k = 0; k < 16; ++k) {
    graph.AddNode(Pose2(k, 0.0, 0.0));
    keyframes.push_back({k, ScanShapes(), Pose2(), static_cast<double>(k)});
  }
  const auto closure = [](int old, int now) {
    LoopClosure c;
    c.old_keyframe = old;
    c.new_keyframe = now;
    return c;
  };
  const LoopCloser closer(LoopClosureParams{}, ScanMatchParams{});
  EXPECT_TRUE(closer.MayConfirm(closure(2, 12), closure(3, 14), keyframes, graph));
  EXPECT_FALSE(closer.MayConfirm(closure(2, 12), closure(2, 12), keyframes, graph));
  EXPECT_FALSE(closer.MayConfirm(closure(2, 12), closure(1, 10), keyframes, graph));
}

// The robot drives along the ring's first side, turns round and drives 14 m back: its last
// keyframes look the other way from every earlier keyframe near them, so the searches during
// the run find no candidate and the way back keeps its drift against the way out. The
// end-of-log searches take candidates from every heading (final_searches) and lay the two
// passes over each other.
TEST(LoopClosureTest, TheLastKeyframesAreSearchedFromEveryHeading) {
  const std::vector<Point2> path = {{1.5, 1.5}, {34.0, 1.5}, {20.0, 1.5}};
  const Drive drive = DriveAlong(path, 1.0, 0.5 * M_PI / 180.0, 3);
  // The last keyframe against the outbound keyframe at its place: the two passes overlaid.
  const int last = static_cast<int>(drive.truth.size()) - 1;
  int beside = 0;
  for (int k = 0; k < last; ++k) {
    const double d = (drive.truth[k].Translation() - drive.truth[last].Translation()).norm();
    if (d < (drive.truth[beside].Translation() - drive.truth[last].Translation()).norm()) beside = k;
  }
  const Pose2 truth = drive.truth[beside].Inverse() * drive.truth[last];
  const auto last_error = [&](const Result& r) {
    const Pose2 estimate = r.graph.Node(beside).Inverse() * r.graph.Node(last);
    return (estimate.Translation() - truth.Translation()).norm();
  };
  // The final searches alone (the sweep before them changes which old places the rotation of
  // candidates offers them).
  ShapeSlamParams on;
  on.loop_closure.final_sweep_every = 0;
  ShapeSlamParams off = on;
  off.loop_closure.final_searches = 0;
  const Result open = CloseLoops(LargeLoopWorld(), drive, 4, off, nullptr, 0, true);
  const Result closed = CloseLoops(LargeLoopWorld(), drive, 4, on, nullptr, 0, true);
  EXPECT_EQ(open.closures, 0);
  EXPECT_GT(last_error(open), 0.3);
  EXPECT_GE(closed.closures, 1);
  EXPECT_LT(last_error(closed), 0.5 * last_error(open));
  ExpectLoopEdgesRight(closed);
}

// A corridor driven out and back: the way back sees the outbound keyframes' places from the
// opposite heading, beyond max_view_angle_rad, so the run's searches have no candidate there.
// The sweep at the end closes the two passes in the middle of the way back, not only at its
// end (the final searches).
TEST(LoopClosureTest, TheSweepClosesACorridorDrivenBothWays) {
  const std::vector<Point2> path = {{1.5, 1.5}, {34.0, 1.5}, {6.0, 1.5}};
  const Drive drive = DriveAlong(path, 1.0, 0.25 * M_PI / 180.0, 3);
  const int last = static_cast<int>(drive.truth.size()) - 1;
  ShapeSlamParams off;
  off.loop_closure.final_searches = 0;
  off.loop_closure.final_sweep_every = 0;
  ShapeSlamParams sweep_only = off;
  sweep_only.loop_closure.final_sweep_every = ShapeSlamParams().loop_closure.final_sweep_every;
  const Result open = CloseLoops(LargeLoopWorld(), drive, 4, off, nullptr, 0, true);
  const Result swept = CloseLoops(LargeLoopWorld(), drive, 4, sweep_only, nullptr, 0, true);
  EXPECT_EQ(open.closures, 0);
  // Closures from the middle of the way back, at least 8 keyframes before the last.
  const int from_middle = static_cast<int>(std::count_if(
      swept.events.begin(), swept.events.end(), [&](const LoopEvent& e) {
        return e.decision != LoopDecision::kPending && e.decision != LoopDecision::kAmbiguous &&
               e.decision != LoopDecision::kRefused && e.closure.new_keyframe < last - 8;
      }));
  EXPECT_GE(from_middle, 1);
  EXPECT_LT(swept.rmse_after, open.rmse_after);
  ExpectLoopEdgesRight(swept);
}

TEST(LoopClosureTest, InvalidParametersAreRejected) {
  const ShapeSlamParams params;
  const auto rejected = [&](const std::function<void(LoopClosureParams&)>& spoil) {
    LoopClosureParams bad = params.loop_closure;
    spoil(bad);
    EXPECT_THROW(LoopCloser(bad, ToScanMatchParams(params)), std::invalid_argument);
  };
  rejected([](LoopClosureParams& p) { p.max_search_radius_m = p.search_radius_m - 1.0; });
  rejected([](LoopClosureParams& p) { p.submap_step_m = -1.0; });
  rejected([](LoopClosureParams& p) { p.refine_min_fit = 1.5; });
  rejected([](LoopClosureParams& p) { p.confirm_near_m = -1.0; });
  rejected([](LoopClosureParams& p) { p.confirm_near_keyframes = 0; });
  rejected([](LoopClosureParams& p) { p.final_searches = -1; });
  rejected([](LoopClosureParams& p) { p.final_sweep_every = -1; });
  rejected([](LoopClosureParams& p) { p.corridor_sigma_m = -1.0; });
  rejected([](LoopClosureParams& p) { p.corridor_offset_m = -0.1; });
}

}  // namespace
}  // namespace shape_slam

