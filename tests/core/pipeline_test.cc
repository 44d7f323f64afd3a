// The mapper (pipeline.h) end to end on a simulated run: a robot drives twice around a block
// in a furnished loop corridor with drifting odometry; the map and trajectory come out right,
// the run is bit-for-bit deterministic, and it also works without odometry.
#include "shape_slam/pipeline.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "shape_slam/evaluation.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

struct SimRun {
  std::vector<LaserScan> scans;
  std::vector<StampedPose> truth;
};

// Twice around the block at 1.5 m from it, 0.15 m and up to 0.15 rad per scan; odometry with
// 3 % scale error and a heading bias, so that it drifts by metres over the run.
SimRun Simulate(unsigned seed) {
  const testing::Scene world = testing::LoopWorld();
  std::mt19937 prng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::vector<Point2> corners = {{1.5, 1.5}, {12.5, 1.5}, {12.5, 8.5}, {1.5, 8.5}};
  SimRun run;
  Pose2 odom;
  Pose2 previous(corners[0].x(), corners[0].y(), 0.0);
  double t = 100.0;
  // One scan at `next`, the odometry advanced by its noisy measurement of the step.
  const auto record = [&](const Pose2& next, const Pose2& odometry_step) {
    run.truth.push_back({t, next});
    odom = odom * odometry_step;
    LaserScan scan = testing::SimulateScan(world, next, testing::ScannerModel{}, prng);
    scan.timestamp_s = t;
    scan.T_odom_robot = odom;
    run.scans.push_back(scan);
    previous = next;
    t += 0.1;
  };
  for (int lap = 0; lap < 2; ++lap) {
    for (int c = 0; c < 4; ++c) {
      const Point2 a = corners[c], b = corners[(c + 1) % 4];
      const double heading = std::atan2(b.y() - a.y(), b.x() - a.x());
      // Turn on the spot, then drive.
      while (std::abs(NormalizeAngle(heading - previous.theta)) > 1e-9) {
        const double turn = std::clamp(NormalizeAngle(heading - previous.theta), -0.15, 0.15);
        const Pose2 next(previous.x, previous.y, NormalizeAngle(previous.theta + turn));
        const Pose2 d = previous.Inverse() * next;
        record(next, Pose2(d.x * 1.03, d.y, d.theta * 1.02 + 0.002 + 0.003 * n(prng)));
      }
      const double length = (b - a).norm();
      const int steps = static_cast<int>(std::ceil(length / 0.15));
      for (int k = 1; k <= steps; ++k) {
        const Point2 p = a + (b - a) * (static_cast<double>(k) / steps);
        const Pose2 next(p.x(), p.y(), heading);
        const Pose2 d = previous.Inverse() * next;
        record(next, Pose2(d.x * 1.03 + 0.005 * n(prng), d.y + 0.005 * n(prng),
                           d.theta + 0.004 + 0.003 * n(prng)));
      }
    }
  }
  return run;
}

struct Outcome {
  std::vector<StampedPose> trajectory;
  std::size_t polylines = 0, vertices = 0;
};

Outcome Map(const SimRun& run, const ShapeSlamParams& params) {
  ShapeSlam slam(params);
  for (const LaserScan& scan : run.scans) slam.Process(scan);
  return {slam.Trajectory(), slam.Map().NumPolylines(), slam.Map().NumVertices()};
}

double Ate(const Outcome& outcome, const SimRun& run) {
  return EvaluateTrajectory(outcome.trajectory, run.truth, {}).ate_rmse_m;
}

// Odometry alone, for comparison.
double OdometryAte(const SimRun& run) {
  std::vector<StampedPose> odom;
  for (const LaserScan& s : run.scans) odom.push_back({s.timestamp_s, *s.T_odom_robot});
  return EvaluateTrajectory(odom, run.truth, {}).ate_rmse_m;
}

TEST(PipelineTest, MapsTheLoopWithOdometry) {
  const SimRun run = Simulate(1);
  const double odometry_ate = OdometryAte(run);
  ASSERT_GT(odometry_ate, 0.5);  // the odometry really drifts
  const Outcome outcome = Map(run, ShapeSlamParams{});
  ASSERT_EQ(outcome.trajectory.size(), run.scans.size());
  EXPECT_LT(Ate(outcome, run), 0.05) << "odometry alone: " << odometry_ate;
  // A compact map: the hall has 8 walls + 4 sides of the block + 3 pillars + 4 features.
  EXPECT_GT(outcome.polylines, 5u);
  EXPECT_LT(outcome.polylines, 80u);
  EXPECT_LT(outcome.vertices, 400u);
}

// The final optimisation: the loop closes, Finish keeps the trajectory right and the map made
// of the keyframes at their corrected poses; processing may go on after it. Finish adds loop
// edges only (the end-of-log sweep and searches, LoopClosureParams::final_sweep_every and
// final_searches), none without them.
TEST(PipelineTest, FinishOptimisesAndRebuildsTheMap) {
  const SimRun run = Simulate(5);
  ShapeSlamParams no_final;
  no_final.loop_closure.final_searches = 0;
  no_final.loop_closure.final_sweep_every = 0;
  ShapeSlam without(no_final);
  for (const LaserScan& scan : run.scans) without.Process(scan);
  const std::size_t edges_without = without.Graph().Edges().size();
  without.Finish();
  EXPECT_EQ(without.Graph().Edges().size(), edges_without);
  ShapeSlam slam;
  for (const LaserScan& scan : run.scans) slam.Process(scan);
  ASSERT_GT(slam.NumLoopClosures(), 0);
  const std::size_t loops = slam.Graph().Edges().size();
  slam.Finish();
  const auto& edges = slam.Graph().Edges();
  for (std::size_t e = loops; e < edges.size(); ++e) EXPECT_TRUE(edges[e].loop) << "edge " << e;
  EXPECT_LT(EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m, 0.05);
  EXPECT_GT(slam.Map().NumPolylines(), 5u);
  const ScanReport more = slam.Process(run.scans.back());
  EXPECT_TRUE(more.matched);
}

// The fast track: where the odometry prediction fits, the scan is placed without shape matching,
// as accurately; where the prediction is off by more than the quick ICP captures, shape matching
// takes over. Above 1 the fast track is off.
TEST(PipelineTest, FastTrackPlacesTheScansThePredictionExplains) {
  SimRun run = Simulate(6);
  const auto fast_tracked = [](const SimRun& r, const ShapeSlamParams& params, double& ate) {
    ShapeSlam slam(params);
    int fast = 0;
    for (const LaserScan& scan : r.scans) fast += slam.Process(scan).fast_track ? 1 : 0;
    ate = EvaluateTrajectory(slam.Trajectory(), r.truth, {}).ate_rmse_m;
    return fast;
  };
  ShapeSlamParams on;
  on.keyframe_track_min_fit = 1.5;  // every scan is matched against the map
  ShapeSlamParams off = on;
  off.fast_track_min_fit = 1.5;
  double ate_on = 0.0, ate_off = 0.0;
  const int on_count = fast_tracked(run, on, ate_on);
  EXPECT_EQ(fast_tracked(run, off, ate_off), 0);
  EXPECT_GT(on_count, static_cast<int>(run.scans.size()) / 2);
  EXPECT_LT(ate_on, 0.05);
  EXPECT_LT(ate_off, 0.05);
  // Odometry that turns by 0.3 rad too much at one scan (a wheel slip): that scan cannot be
  // fast-tracked from the prediction, shape matching places it, and the trajectory stays right.
  const std::size_t slip = run.scans.size() / 3;
  const Pose2 before_slip = *run.scans[slip - 1].T_odom_robot;
  for (std::size_t i = slip; i < run.scans.size(); ++i) {
    *run.scans[i].T_odom_robot =
        before_slip * Pose2(0.0, 0.0, 0.3) * (before_slip.Inverse() * *run.scans[i].T_odom_robot);
  }
  ShapeSlam slam;
  std::vector<ScanReport> reports;
  for (const LaserScan& scan : run.scans) reports.push_back(slam.Process(scan));
  EXPECT_FALSE(reports[slip].fast_track);
  EXPECT_FALSE(reports[slip].keyframe_tracked);
  EXPECT_TRUE(reports[slip].matched);
  EXPECT_LT(EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m, 0.05);
}

// A run mapped with `params`: the scans placed by the keyframe track (each of them matched, none
// by the fast track), the keyframes and the ATE.
struct KeyframeTrackRun {
  int tracked = 0;
  int keyframes = 0;
  int tracked_with_odometry = 0;
  double ate_m = 0.0;
};

KeyframeTrackRun TrackKeyframes(const SimRun& run, const ShapeSlamParams& params) {
  ShapeSlam slam(params);
  KeyframeTrackRun out;
  for (const LaserScan& scan : run.scans) {
    const ScanReport report = slam.Process(scan);
    out.tracked += report.keyframe_tracked ? 1 : 0;
    out.keyframes += report.keyframe ? 1 : 0;
    if (report.keyframe_tracked) {
      EXPECT_TRUE(report.matched && !report.fast_track);
      out.tracked_with_odometry += report.used_odometry ? 1 : 0;
    }
  }
  out.ate_m = EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m;
  return out;
}

// The keyframe track: a scan predicted short of the next keyframe (0.15 m steps, keyframes every
// 0.2 m: about every other scan on the straights) is placed against the last keyframe alone,
// never updates the map itself, and the trajectory is as right as with every scan matched
// against the map. Above 1 it is off.
TEST(PipelineTest, KeyframeTrackPlacesTheScansBetweenKeyframes) {
  const SimRun run = Simulate(6);
  ShapeSlamParams off;
  off.keyframe_track_min_fit = 1.5;
  const KeyframeTrackRun on_run = TrackKeyframes(run, ShapeSlamParams{});
  const KeyframeTrackRun off_run = TrackKeyframes(run, off);
  EXPECT_EQ(off_run.tracked, 0);
  const int between = static_cast<int>(run.scans.size()) - off_run.keyframes;
  ASSERT_GT(between, static_cast<int>(run.scans.size()) / 4);
  EXPECT_GT(on_run.tracked, between / 2);
  EXPECT_EQ(on_run.tracked_with_odometry, on_run.tracked);
  EXPECT_LT(on_run.ate_m, 0.05);
  EXPECT_LT(off_run.ate_m, 0.05);
  ShapeSlamParams invalid;
  invalid.keyframe_track_min_fit = -0.1;
  EXPECT_THROW(ShapeSlam{invalid}, std::invalid_argument);
  invalid = ShapeSlamParams{};
  invalid.fast_track_min_fit = -0.1;
  EXPECT_THROW(ShapeSlam{invalid}, std::invalid_argument);
}

// Without odometry the constant-velocity motion stands for the odometry's increment: the scans
// it leaves short of the next keyframe (0.15 m steps, turns of 0.15 rad on the spot) are placed
// against the last keyframe alone, and the trajectory is as right as with every scan searched
// without a guess. Off, nothing is tracked so without odometry.
TEST(PipelineTest, KeyframeTrackWithoutOdometryUsesTheConstantVelocity) {
  const SimRun run = Simulate(6);
  ShapeSlamParams on;
  on.use_odometry = false;
  ShapeSlamParams off = on;
  off.keyframe_track_without_odometry = false;
  const KeyframeTrackRun on_run = TrackKeyframes(run, on);
  const KeyframeTrackRun off_run = TrackKeyframes(run, off);
  EXPECT_EQ(off_run.tracked, 0);
  const int between = static_cast<int>(run.scans.size()) - off_run.keyframes;
  ASSERT_GT(between, static_cast<int>(run.scans.size()) / 4);
  EXPECT_GT(on_run.tracked, between / 2);
  EXPECT_EQ(on_run.tracked_with_odometry, 0);
  EXPECT_LT(on_run.ate_m, 0.10);
  EXPECT_LT(off_run.ate_m, 0.10);
  ShapeSlamParams invalid;
  invalid.keyframe_track_turn_without_odometry_rad = -0.1;
  EXPECT_THROW(ShapeSlam{invalid}, std::invalid_argument);
}

TEST(PipelineTest, IsDeterministic) {
  const SimRun run = Simulate(2);
  const Outcome a = Map(run, ShapeSlamParams{});
  const Outcome b = Map(run, ShapeSlamParams{});
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  for (std::size_t i = 0; i < a.trajectory.size(); ++i) {
    // Bit-identical, not merely close.
    EXPECT_EQ(a.trajectory[i].pose.x, b.trajectory[i].pose.x) << i;
    EXPECT_EQ(a.trajectory[i].pose.y, b.trajectory[i].pose.y) << i;
    EXPECT_EQ(a.trajectory[i].pose.theta, b.trajectory[i].pose.theta) << i;
  }
  EXPECT_EQ(a.vertices, b.vertices);
}

TEST(PipelineTest, MapsTheLoopWithoutOdometry) {
  const SimRun run = Simulate(3);
  ShapeSlamParams params;
  params.use_odometry = false;
  const Outcome outcome = Map(run, params);
  ASSERT_EQ(outcome.trajectory.size(), run.scans.size());
  EXPECT_LT(Ate(outcome, run), 0.10);
}

TEST(PipelineTest, ScansWithoutPointsAndMalformedScans) {
  const SimRun run = Simulate(4);
  ShapeSlam slam;
  for (std::size_t i = 0; i < 20; ++i) slam.Process(run.scans[i]);
  LaserScan empty = run.scans[20];
  for (double& r : empty.ranges_m) r = std::nan("");
  const ScanReport report = slam.Process(empty);  // not an error: predicted, map unchanged
  EXPECT_FALSE(report.matched);
  LaserScan bad = run.scans[21];
  bad.angles_rad.pop_back();
  EXPECT_THROW(slam.Process(bad), std::invalid_argument);
  bad = run.scans[21];
  bad.timestamp_s = std::nan("");
  EXPECT_THROW(slam.Process(bad), std::invalid_argument);
  EXPECT_NO_THROW(slam.Process(run.scans[22]));
}

}  // namespace
}  // namespace shape_slam

namespace shape_slam {
namespace {

// `shape-slam match` and the mapper agree: the mapper's defaults give the registration's.
TEST(ToScanMatchParamsTest, MapperDefaultsGiveTheRegistrationDefaults) {
  const ScanMatchParams from_mapper = ToScanMatchParams(ShapeSlamParams{});
  const ScanMatchParams defaults;
  EXPECT_EQ(from_mapper.seed_pairs, defaults.seed_pairs);
  EXPECT_EQ(from_mapper.seeds, defaults.seeds);
  EXPECT_EQ(from_mapper.coarse_gate_m, defaults.coarse_gate_m);
  EXPECT_EQ(from_mapper.min_inlier_ratio, defaults.min_inlier_ratio);
  EXPECT_EQ(from_mapper.window_search.half_window_rad, defaults.window_search.half_window_rad);
  EXPECT_EQ(from_mapper.window_search.half_window_m, defaults.window_search.half_window_m);
  EXPECT_EQ(from_mapper.window_search_spacing_m, defaults.window_search_spacing_m);
  EXPECT_EQ(from_mapper.shapes.dce.threshold_m, defaults.shapes.dce.threshold_m);
  EXPECT_EQ(from_mapper.shapes.extraction.gap_beam_spacing_factor,
            defaults.shapes.extraction.gap_beam_spacing_factor);
  ShapeSlamParams changed;
  changed.scan_match_seed_pairs = 7;
  changed.shapes.dce.threshold_m = 0.08;
  EXPECT_EQ(ToScanMatchParams(changed).seed_pairs, 7);
  EXPECT_EQ(ToScanMatchParams(changed).shapes.dce.threshold_m, 0.08);
}

}  // namespace
}  // namespace shape_slam

namespace shape_slam {
namespace {

ShapeSlamParams SubmapParamsWith(int keyframes_per_submap) {
  ShapeSlamParams params;
  params.submaps.keyframes = keyframes_per_submap;
  return params;
}

// The polylines of a map, point by point, to compare two states of it exactly.
std::vector<std::vector<Point2>> Polylines(const PolylineMap& map) {
  std::vector<std::vector<Point2>> out;
  for (const PolylineId id : map.Ids()) out.push_back(map.Get(id).points);
  return out;
}

// Submaps: bounded (each finished one holds exactly its keyframes, at most two active), finished
// ones never change again, and the loop is still mapped right.
TEST(PipelineSubmapTest, SubmapsAreBoundedAndFinishedOnesNeverChange) {
  const SimRun run = Simulate(1);
  ShapeSlam slam(SubmapParamsWith(20));
  std::vector<std::vector<std::vector<Point2>>> finished_then;
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    slam.Process(run.scans[i]);
    EXPECT_LE(slam.NumActiveSubmaps(), 2);
    if (i == run.scans.size() / 2) {
      for (const auto& submap : slam.FinishedSubmaps()) finished_then.push_back(Polylines(submap.map));
    }
  }
  ASSERT_GE(finished_then.size(), 2u);
  ASSERT_GT(slam.FinishedSubmaps().size(), finished_then.size());
  for (std::size_t s = 0; s < slam.FinishedSubmaps().size(); ++s) {
    EXPECT_EQ(slam.FinishedSubmaps()[s].num_keyframes, 20);
    EXPECT_EQ(slam.FinishedSubmaps()[s].first_keyframe, 10 * static_cast<int>(s));
    if (s < finished_then.size()) {
      EXPECT_EQ(Polylines(slam.FinishedSubmaps()[s].map), finished_then[s]) << "submap " << s;
    }
  }
  ASSERT_GT(slam.NumLoopClosures(), 0);
  slam.Finish();
  EXPECT_LT(EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m, 0.05);
  EXPECT_GT(slam.Map().NumPolylines(), 5u);
  EXPECT_LT(slam.Map().NumVertices(), 400u);
}

// Loop closures move only the pose graph: the scans' tracking in the local frame is the same,
// bit for bit, with and without them, while the closed trajectory is right and the open one
// is not as good.
TEST(PipelineSubmapTest, LoopClosuresNeverChangeTheLocalTrajectory) {
  const SimRun run = Simulate(5);
  ShapeSlamParams open = SubmapParamsWith(20);
  open.loop_closure.enabled = false;
  ShapeSlam closed_slam(SubmapParamsWith(20)), open_slam(open);
  for (const LaserScan& scan : run.scans) {
    closed_slam.Process(scan);
    open_slam.Process(scan);
  }
  closed_slam.Finish();
  open_slam.Finish();
  ASSERT_GT(closed_slam.NumLoopClosures(), 0);
  const auto closed_local = closed_slam.LocalTrajectory(), open_local = open_slam.LocalTrajectory();
  ASSERT_EQ(closed_local.size(), open_local.size());
  for (std::size_t i = 0; i < closed_local.size(); ++i) {
    ASSERT_EQ(closed_local[i].pose.x, open_local[i].pose.x) << i;
    ASSERT_EQ(closed_local[i].pose.y, open_local[i].pose.y) << i;
    ASSERT_EQ(closed_local[i].pose.theta, open_local[i].pose.theta) << i;
  }
  const double closed_ate = EvaluateTrajectory(closed_slam.Trajectory(), run.truth, {}).ate_rmse_m;
  const double open_ate = EvaluateTrajectory(open_slam.Trajectory(), run.truth, {}).ate_rmse_m;
  EXPECT_LT(closed_ate, 0.05);
  EXPECT_LT(closed_ate, open_ate);
}

// The run with one odometry step after scan `at` turned by `glitch_rad` (every later odometry
// pose turns with it) and a wheel-base bias of `bias_rad_per_m`.
SimRun WithOdometryFaults(SimRun run, std::size_t at, double glitch_rad, double bias_rad_per_m) {
  Pose2 previous_raw = *run.scans[0].T_odom_robot, faulty = previous_raw;
  for (std::size_t i = 1; i < run.scans.size(); ++i) {
    const Pose2 raw = *run.scans[i].T_odom_robot;
    Pose2 step = previous_raw.Inverse() * raw;
    step.theta += bias_rad_per_m * step.Translation().norm();
    if (i == at + 1) step = Pose2(step.x, step.y, step.theta + glitch_rad);
    faulty = faulty * step;
    previous_raw = raw;
    run.scans[i].T_odom_robot = faulty;
  }
  return run;
}

struct FaultOutcome {
  double ate_m = 0.0;
  int overridden = 0;
};

FaultOutcome MapWithFaults(const SimRun& run, const ShapeSlamParams& params) {
  ShapeSlam slam(params);
  FaultOutcome outcome;
  for (const LaserScan& scan : run.scans) outcome.overridden += slam.Process(scan).odometry_overridden;
  slam.Finish();
  outcome.ate_m = EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m;
  return outcome;
}

// Odometry is a prior, not a gate: one 75 deg heading glitch is overridden by the scan match
// and costs nothing; with the check off the glitch bends the map.
TEST(PipelineSubmapTest, OdometryGlitchIsOverriddenByTheScans) {
  const SimRun clean = Simulate(1);
  const SimRun glitched = WithOdometryFaults(clean, clean.scans.size() / 3, 75.0 * M_PI / 180.0, 0.0);
  const FaultOutcome with_check = MapWithFaults(glitched, SubmapParamsWith(20));
  EXPECT_LT(with_check.ate_m, 0.05);
  EXPECT_GE(with_check.overridden, 1);
  ShapeSlamParams unchecked = SubmapParamsWith(20);
  unchecked.odometry_check_fit = 0.0;
  EXPECT_GT(MapWithFaults(glitched, unchecked).ate_m, 2.0 * with_check.ate_m);
}

// How far the mapped step into scan `at` is off the true one, metres.
double StepError(const SimRun& run, std::size_t at, const ShapeSlamParams& params) {
  const Outcome outcome = Map(run, params);
  const Pose2 estimated = outcome.trajectory[at - 1].pose.Inverse() * outcome.trajectory[at].pose;
  const Pose2 truth = run.truth[at - 1].pose.Inverse() * run.truth[at].pose;
  return (estimated.Translation() - truth.Translation()).norm();
}

// The other way round: one scan gone wrong (its ranges are those of a scan 1.2 m further on,
// 0.1 s later; the odometry is right). Matched without the odometry it would fit where it was
// really taken, but neither the odometry's step nor the robot's recent steps (0.15 m per scan)
// support the jump (odometry_override_within_step): the odometry is kept, and still with
// twice the recent steps allowed. With the bound off the scan drags the pose 1.2 m ahead and
// back.
TEST(PipelineTest, AScanGoneWrongDoesNotOverrideGoodOdometry) {
  SimRun run = Simulate(3);
  std::size_t at = 0;
  for (std::size_t i = 20; i + 8 < run.scans.size() && at == 0; ++i) {
    const Pose2 d = run.truth[i].pose.Inverse() * run.truth[i + 8].pose;
    if (std::abs(d.theta) < 1e-9 && std::abs(d.x - 1.2) < 0.05) at = i;
  }
  ASSERT_GT(at, 0u);
  run.scans[at].ranges_m = run.scans[at + 8].ranges_m;
  ShapeSlamParams recent_steps;
  recent_steps.odometry_override_step_ratio = 2.0;
  ShapeSlamParams off;
  off.odometry_override_within_step = false;
  EXPECT_LT(StepError(run, at, ShapeSlamParams{}), 0.2);  // the default
  EXPECT_LT(StepError(run, at, recent_steps), 0.2);
  EXPECT_GT(StepError(run, at, off), 0.5);
}

// One scan gone wrong by a turn: on a straight stretch its ranges are those the robot would
// see from where it is, turned 1.4 rad (the odometry is right). Matched without the odometry it
// fits that turned view, at the odometry's step but turned far beyond both the odometry's turn
// and the robot's recent turns (odometry_override_turn_slack_rad): the odometry is kept. With
// the turn bound off the override turns the robot by 80 deg.
TEST(PipelineTest, AMatchTurningFarBeyondTheOdometryDoesNotOverrideIt) {
  SimRun run = Simulate(3);
  std::size_t at = 0;
  for (std::size_t i = 20; i + 1 < run.scans.size() && at == 0; ++i) {
    const Pose2 d = run.truth[i - 4].pose.Inverse() * run.truth[i].pose;
    if (std::abs(d.theta) < 1e-9 && std::abs(d.x - 0.6) < 0.05) at = i;
  }
  ASSERT_GT(at, 0u);
  std::mt19937 prng(11);
  Pose2 turned = run.truth[at].pose;
  turned.theta = NormalizeAngle(turned.theta + 1.4);
  run.scans[at].ranges_m =
      testing::SimulateScan(testing::LoopWorld(), turned, testing::ScannerModel{}, prng).ranges_m;
  const auto turn_error = [&](const ShapeSlamParams& params) {
    const Outcome outcome = Map(run, params);
    const Pose2 estimated = outcome.trajectory[at - 1].pose.Inverse() * outcome.trajectory[at].pose;
    const Pose2 truth = run.truth[at - 1].pose.Inverse() * run.truth[at].pose;
    return std::abs(NormalizeAngle(estimated.theta - truth.theta));
  };
  ShapeSlamParams off;
  off.odometry_override_turn_slack_rad = 100.0;
  EXPECT_LT(turn_error(ShapeSlamParams{}), 0.05);
  EXPECT_GT(turn_error(off), 1.0);
}

// Every 4th scan of a simulated run (0.6 m apart) with its reference.
SimRun EveryFourthScan(const SimRun& full) {
  SimRun run;
  for (std::size_t i = 0; i < full.scans.size(); i += 4) {
    run.scans.push_back(full.scans[i]);
    run.truth.push_back(full.truth[i]);
  }
  return run;
}

// A scan gone wrong the other way: every 4th scan (0.6 m apart, the odometry right), one of
// them with the ranges of the scan two before it, 1.2 m back. Matched without the odometry it
// fits behind the robot, against the wheels' direction of travel
// (odometry_override_min_along): the odometry is kept. With that rule off the scan drags the
// pose back.
TEST(PipelineTest, AMatchAgainstTheWheelsDirectionDoesNotOverrideTheOdometry) {
  SimRun run = EveryFourthScan(Simulate(3));
  std::size_t at = 0;
  // Near the end of the block's first side (from scan 17 on), where the wall ahead fills much of
  // the scan: at the odometry's pose the scan from 1.2 m back fits poorly, and the check runs.
  for (std::size_t i = 17; i + 1 < run.scans.size() && at == 0; ++i) {
    const Pose2 d = run.truth[i - 2].pose.Inverse() * run.truth[i].pose;
    if (std::abs(d.theta) < 1e-9 && std::abs(d.x - 1.2) < 0.05) at = i;
  }
  ASSERT_GT(at, 0u);
  run.scans[at].ranges_m = run.scans[at - 2].ranges_m;
  ShapeSlamParams off;
  off.odometry_override_min_along = -100.0;
  EXPECT_LT(StepError(run, at, ShapeSlamParams{}), 0.2);
  EXPECT_GT(StepError(run, at, off), 0.5);
}

// A match that only shortens the wheels' step: every 8th scan (1.2 m apart, the odometry right),
// one of them with the ranges of the full log's scan 0.6 m back, half a step. At the odometry's
// pose the scan's far part meets the wall early and fits poorly; half a step back it fits, as
// at a corridor's open end, where the true pose sees past the map and a pose behind it does not
// (intel with every 2nd beam). Half the step along the wheels' direction is too short for an
// override (odometry_override_min_along 0.7); at 0.5 the scan drags the pose back.
TEST(PipelineTest, AMatchThatHalvesTheWheelsStepDoesNotOverrideTheOdometry) {
  const SimRun full = Simulate(3);
  SimRun run;
  std::vector<std::size_t> index;  // of each kept scan in `full`
  for (std::size_t i = 0; i < full.scans.size(); i += 8) {
    run.scans.push_back(full.scans[i]);
    run.truth.push_back(full.truth[i]);
    index.push_back(i);
  }
  std::size_t at = 0;
  for (std::size_t i = 9; i + 1 < run.scans.size() && at == 0; ++i) {
    const Pose2 d = run.truth[i - 1].pose.Inverse() * run.truth[i].pose;
    const Pose2 back = full.truth[index[i] - 4].pose.Inverse() * run.truth[i].pose;
    if (std::abs(d.theta) < 1e-9 && std::abs(d.x - 1.2) < 0.05 && std::abs(back.theta) < 1e-9 &&
        std::abs(back.x - 0.6) < 0.05) {
      at = i;
    }
  }
  ASSERT_GT(at, 0u);
  run.scans[at].ranges_m = full.scans[index[at] - 4].ranges_m;
  // Odometry trusted to 0.08 m over the step, so that the registration with its prior does not
  // reach 0.6 m back by itself: only the check without the odometry does.
  ShapeSlamParams params;
  params.odometry_noise.sigma_xy_m = 0.02;
  params.odometry_noise.sigma_xy_per_m = 0.05;
  ShapeSlamParams half = params;
  half.odometry_override_min_along = 0.5;
  EXPECT_LT(StepError(run, at, params), 0.2);
  EXPECT_GT(StepError(run, at, half), 0.4);
}

// Odometry that stalls: every 4th scan (0.6 m apart), and at every 7th of them from the 10th on
// the odometry pose is that of the scan before (a message late); the next scan's is right
// again. The stalled scans are matched without the odometry (stale_odometry_min_step_m) and
// the late motion is not counted twice; the largest error of a step into or out of a stalled
// scan stays small. With the check off, the prior holds the stalled scans back.
TEST(PipelineTest, StalledOdometryIsNotTakenForAStop) {
  SimRun run = EveryFourthScan(Simulate(3));
  std::vector<std::size_t> stalled;
  for (std::size_t i = 10; i + 1 < run.scans.size(); i += 7) {
    run.scans[i].T_odom_robot = run.scans[i - 1].T_odom_robot;
    stalled.push_back(i);
  }
  ASSERT_GE(stalled.size(), 3u);
  const auto worst_step_error = [&](const ShapeSlamParams& params, int* stale) {
    ShapeSlam slam(params);
    for (const LaserScan& scan : run.scans) slam.Process(scan);
    slam.Finish();
    *stale = slam.Odometry().scans_stale;
    const std::vector<StampedPose> trajectory = slam.Trajectory();
    double worst = 0.0;
    for (const std::size_t at : stalled) {
      for (const std::size_t i : {at, at + 1}) {
        const Pose2 estimated = trajectory[i - 1].pose.Inverse() * trajectory[i].pose;
        const Pose2 truth = run.truth[i - 1].pose.Inverse() * run.truth[i].pose;
        worst = std::max(worst, (estimated.Translation() - truth.Translation()).norm());
      }
    }
    return worst;
  };
  int stale = 0;
  const double with_check = worst_step_error(ShapeSlamParams{}, &stale);
  EXPECT_EQ(stale, static_cast<int>(stalled.size()));
  ShapeSlamParams off;
  off.stale_odometry_min_step_m = 1000.0;
  const double without = worst_step_error(off, &stale);
  EXPECT_EQ(stale, 0);
  EXPECT_LT(with_check, 0.1);
  EXPECT_GT(without, 0.3);
}

// A wheel-base bias of 2 deg per metre on top of the simulated odometry's own drift.
TEST(PipelineSubmapTest, BiasedOdometryIsCorrectedByTheScans) {
  const SimRun clean = Simulate(2);
  const SimRun biased = WithOdometryFaults(clean, 0, 0.0, 2.0 * M_PI / 180.0);
  ASSERT_GT(OdometryAte(biased), 1.0);
  EXPECT_LT(MapWithFaults(biased, SubmapParamsWith(20)).ate_m, 0.05);
}

// The mapper learns the odometry's heading error (OdometryCalibrator): 2 deg per metre more of
// wheel-base bias is 2 deg per metre more of learned correction, the other way; with the
// calibration off nothing is learned.
TEST(PipelineSubmapTest, TheOdometrysHeadingErrorIsLearned) {
  const SimRun clean = Simulate(2);
  const double bias = 2.0 * M_PI / 180.0;
  const SimRun biased = WithOdometryFaults(clean, 0, 0.0, bias);
  const auto learned = [](const SimRun& run, bool enabled) {
    ShapeSlamParams params = SubmapParamsWith(20);
    params.odometry_calibration.enabled = enabled;
    ShapeSlam slam(params);
    for (const LaserScan& scan : run.scans) slam.Process(scan);
    return slam.Odometry().heading_per_m;
  };
  EXPECT_NEAR(learned(biased, true) - learned(clean, true), -bias, 0.25 * bias);
  EXPECT_EQ(learned(biased, false), 0.0);
}

// Without odometry, a scan that no match places (here one of a round room of 1 m radius; at a
// 2 m radius a match fitting 31 % of it was trusted once the keyframe track without odometry
// had changed the scans before it) is a keyframe at the motion model's guess that starts new
// submaps, tied to the previous keyframe by a weak, guessed edge; the scans after it are
// tracked against what it saw and the closed loop is still right. With restart_when_lost off
// the scan is left out.
TEST(PipelineSubmapTest, AScanNoMatchPlacesStartsNewSubmapsWithAGuessedEdge) {
  SimRun run = Simulate(1);
  for (LaserScan& scan : run.scans) scan.T_odom_robot.reset();
  const std::size_t at = run.scans.size() / 3;
  for (double& r : run.scans[at].ranges_m) r = 1.0;
  const auto map_it = [&](const ShapeSlamParams& params, ScanReport& report_at, int& guessed,
                          std::size_t& finished_before, std::size_t& finished_after) {
    ShapeSlam slam(params);
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      if (i == at) finished_before = slam.FinishedSubmaps().size();
      const ScanReport report = slam.Process(run.scans[i]);
      if (i == at) {
        report_at = report;
        finished_after = slam.FinishedSubmaps().size();
      }
    }
    guessed = 0;
    for (const PoseGraphEdge& e : slam.Graph().Edges()) guessed += e.guessed ? 1 : 0;
    slam.Finish();
    return EvaluateTrajectory(slam.Trajectory(), run.truth, {}).ate_rmse_m;
  };
  ScanReport report;
  int guessed = 0;
  std::size_t before = 0, after = 0;
  const double ate = map_it(SubmapParamsWith(20), report, guessed, before, after);
  EXPECT_FALSE(report.matched);
  EXPECT_TRUE(report.keyframe);
  EXPECT_EQ(after, before + 2);  // both active submaps finished early
  EXPECT_GE(guessed, 1);
  EXPECT_LT(ate, 0.1);
  ShapeSlamParams off = SubmapParamsWith(20);
  off.submaps.restart_when_lost = false;
  map_it(off, report, guessed, before, after);
  EXPECT_FALSE(report.matched);
  EXPECT_FALSE(report.keyframe);
  EXPECT_EQ(guessed, 0);
}

TEST(PipelineSubmapTest, InvalidSubmapParamsAreRefused) {
  ShapeSlamParams params = SubmapParamsWith(1);
  EXPECT_THROW(ShapeSlam{params}, std::invalid_argument);
  params = SubmapParamsWith(20);
  params.odometry_check_fit = 1.5;
  EXPECT_THROW(ShapeSlam{params}, std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
