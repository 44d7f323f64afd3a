// The localizer (localizer.h) in a known map built from the walls of a simulated scene: it
// tracks from a given pose, finds the robot without one, notices a kidnapping and recovers,
// never changes the map, and is deterministic.
#include "shape_slam/localizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <stdexcept>
#include <vector>

#include "pose_matchers.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

// The map: every wall of the scene as a polyline.
PolylineMap SceneMap(const testing::Scene& scene) {
  PolylineMap map;
  for (const testing::Wall& w : scene) map.Add({{w.a, w.b}, {1.0, 1.0}, 1, 0});
  return map;
}

struct SimRun {
  std::vector<LaserScan> scans;
  std::vector<Pose2> truth;
};

// Around the block at 1.5 m from it (counter-clockwise from `start_corner`), 0.15 m and up to
// 0.15 rad per scan, with odometry that has 2 % scale error and heading noise.
SimRun Simulate(int start_corner, int num_scans, unsigned seed) {
  const testing::Scene world = testing::LoopWorld();
  std::mt19937 prng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const std::vector<Point2> corners = {{1.5, 1.5}, {12.5, 1.5}, {12.5, 8.5}, {1.5, 8.5}};
  SimRun run;
  Pose2 odom;
  const Point2 c0 = corners[start_corner % 4], c1 = corners[(start_corner + 1) % 4];
  Pose2 previous(c0.x(), c0.y(), std::atan2(c1.y() - c0.y(), c1.x() - c0.x()));
  const auto record = [&](const Pose2& next) {
    const Pose2 d = previous.Inverse() * next;
    odom = odom * Pose2(d.x * 1.02 + 0.003 * n(prng), d.y + 0.003 * n(prng),
                        d.theta + 0.003 * n(prng));
    LaserScan scan = testing::SimulateScan(world, next, testing::ScannerModel{}, prng);
    scan.timestamp_s = 100.0 + 0.1 * static_cast<double>(run.scans.size());
    scan.T_odom_robot = odom;
    run.scans.push_back(scan);
    run.truth.push_back(next);
    previous = next;
  };
  for (int c = start_corner; static_cast<int>(run.scans.size()) < num_scans; ++c) {
    const Point2 a = corners[c % 4], b = corners[(c + 1) % 4];
    const double heading = std::atan2(b.y() - a.y(), b.x() - a.x());
    while (std::abs(NormalizeAngle(heading - previous.theta)) > 1e-9) {
      const double turn = std::clamp(NormalizeAngle(heading - previous.theta), -0.15, 0.15);
      record(Pose2(previous.x, previous.y, NormalizeAngle(previous.theta + turn)));
    }
    const int steps = static_cast<int>(std::ceil((b - a).norm() / 0.15));
    for (int k = 1; k <= steps; ++k) {
      const Point2 p = a + (b - a) * (static_cast<double>(k) / steps);
      record(Pose2(p.x(), p.y(), heading));
    }
  }
  run.scans.resize(num_scans);
  run.truth.resize(num_scans);
  return run;
}

// Tracks `run` in `map` from its first true pose and returns the lost events. With
// `expect_right`, every scan must be localized within 0.1 m and 0.05 rad of the truth.
int TrackFromTheStart(const PolylineMap& map, const LocalizerParams& params, const SimRun& run,
                      bool expect_right) {
  Localizer localizer(map, params);
  localizer.SetInitialPose(run.truth[0]);
  int lost = 0;
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    const LocalizerReport report = localizer.Process(run.scans[i]);
    lost += report.lost_event ? 1 : 0;
    if (expect_right) {
      EXPECT_TRUE(report.localized) << "scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05)) << "scan " << i;
    }
  }
  return lost;
}

// Tracking `run` in `map` holds with `with` (every pose right, no loss), and the robot is lost
// with `without` (the same parameters but the part under test).
void ExpectTrackingHoldsOnlyWith(const PolylineMap& map, const LocalizerParams& with,
                                 const LocalizerParams& without, const SimRun& run) {
  EXPECT_EQ(TrackFromTheStart(map, with, run, true), 0);
  EXPECT_GT(TrackFromTheStart(map, without, run, false), 0);
}

TEST(LocalizerTest, TracksFromAGivenInitialPose) {
  const SimRun run = Simulate(0, 80, 1);
  Localizer localizer(SceneMap(testing::LoopWorld()));
  localizer.SetInitialPose(run.truth[0]);
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    const LocalizerReport report = localizer.Process(run.scans[i]);
    ASSERT_TRUE(report.localized) << "scan " << i;
    EXPECT_EQ(report.status, LocalizerStatus::kTracking);
    EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05)) << "scan " << i;
    EXPECT_GT(report.inlier_ratio, 0.8) << "scan " << i;
  }
  EXPECT_EQ(localizer.Map().NumPolylines(), testing::LoopWorld().size());  // unchanged
}

// With and without the search's second attempts (search_retry).
TEST(LocalizerTest, FindsTheRobotWithoutAnInitialPoseWithinFiveScans) {
  for (const bool retry : {false, true}) {
    LocalizerParams params;
    params.search_retry = retry;
    for (const int corner : {0, 1, 2}) {
      const SimRun run = Simulate(corner, 40, 10 + corner);
      Localizer localizer(SceneMap(testing::LoopWorld()), params);
      int first = -1;
      for (std::size_t i = 0; i < run.scans.size(); ++i) {
        const LocalizerReport report = localizer.Process(run.scans[i]);
        if (report.localized && first < 0) first = static_cast<int>(i);
        if (first >= 0) {
          EXPECT_TRUE(report.localized)
              << "retry " << retry << " corner " << corner << " scan " << i;
          EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05))
              << "retry " << retry << " corner " << corner << " scan " << i;
        }
      }
      EXPECT_GE(first, 0) << "retry " << retry << " corner " << corner;
      EXPECT_LT(first, 5) << "retry " << retry << " corner " << corner;
    }
  }
}

// 30 scans from the first corner, then the robot is carried to the opposite side of the block
// for `after` scans; its odometry does not know (it continues smoothly from the last pose).
constexpr std::size_t kBeforeKidnapping = 30;
SimRun Kidnapped(int after_scans) {
  const SimRun before = Simulate(0, kBeforeKidnapping, 3);
  const SimRun after = Simulate(2, after_scans, 4);
  SimRun run = before;
  const Pose2 T_odom_join = *before.scans.back().T_odom_robot * after.scans.front().T_odom_robot->Inverse();
  for (std::size_t i = 0; i < after.scans.size(); ++i) {
    LaserScan scan = after.scans[i];
    scan.timestamp_s = before.scans.back().timestamp_s + 0.1 * static_cast<double>(i + 1);
    scan.T_odom_robot = T_odom_join * *scan.T_odom_robot;
    run.scans.push_back(scan);
    run.truth.push_back(after.truth[i]);
  }
  return run;
}

// With and without the search's second attempts (search_retry).
TEST(LocalizerTest, NoticesAKidnappingAndRecovers) {
  const SimRun run = Kidnapped(50);
  const std::vector<LaserScan>& scans = run.scans;
  const std::vector<Pose2>& truth = run.truth;
  for (const bool retry : {false, true}) {
    LocalizerParams params;
    params.search_retry = retry;
    Localizer localizer(SceneMap(testing::LoopWorld()), params);
    localizer.SetInitialPose(truth[0]);
    int lost_at = -1, recovered_at = -1;
    for (std::size_t i = 0; i < scans.size(); ++i) {
      const LocalizerReport report = localizer.Process(scans[i]);
      if (i < kBeforeKidnapping) {
        EXPECT_TRUE(report.localized) << "retry " << retry << " scan " << i;
        EXPECT_FALSE(report.lost_event) << "retry " << retry << " scan " << i;
      }
      if (report.lost_event && lost_at < 0) lost_at = static_cast<int>(i);
      if (report.recovered_event && recovered_at < 0) recovered_at = static_cast<int>(i);
      if (recovered_at >= 0) {
        EXPECT_THAT(report.T_map_robot, IsNearly(truth[i], 0.1, 0.05))
            << "retry " << retry << " scan " << i;
      }
    }
    const int kidnap = static_cast<int>(kBeforeKidnapping);
    EXPECT_GE(lost_at, kidnap) << "retry " << retry;
    EXPECT_LT(lost_at, kidnap + 5) << "retry " << retry;
    EXPECT_GT(recovered_at, lost_at) << "retry " << retry;
    EXPECT_LT(recovered_at, lost_at + 10) << "retry " << retry;
  }
}

// The kidnapping above, with the loss detection off (as where the last matched scan carries the
// tracking through a place the map does not hold): the tracked pose goes on by the odometry where
// the map explains little of the scans. The off-map search (off_map_fit) finds the robot again
// and, once its pose has stayed better for off_map_confirm_scans scans, tracks from there;
// without it the robot is never found.
int ScansUntilFoundAfterAKidnapping(const LocalizerParams& params) {
  const SimRun run = Kidnapped(60);
  Localizer localizer(SceneMap(testing::LoopWorld()), params);
  localizer.SetInitialPose(run.truth[0]);
  int found_at = -1;
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    const LocalizerReport report = localizer.Process(run.scans[i]);
    EXPECT_FALSE(report.lost_event) << "scan " << i;
    const bool right =
        report.localized && PosesWithin(report.T_map_robot, run.truth[i], 0.1, 0.05);
    if (i >= kBeforeKidnapping && right && found_at < 0) found_at = static_cast<int>(i);
    if (found_at >= 0) {
      EXPECT_TRUE(right) << "scan " << i;
    }
  }
  return found_at < 0 ? -1 : found_at - static_cast<int>(kBeforeKidnapping);
}

TEST(LocalizerTest, TheOffMapSearchFindsTheRobotWhereTheTrackedPoseLostTheMap) {
  LocalizerParams with;
  with.lost_after_scans = 1000;  // never lost: the tracked pose goes on
  with.fit_drop_ratio = 0.0;
  with.off_map_fit = 0.6;  // the loop world is nearly symmetric: the wrong side fits in part
  with.off_map_search_every = 5;
  with.off_map_confirm_scans = 3;
  LocalizerParams without = with;
  without.off_map_fit = 0.0;
  const int found = ScansUntilFoundAfterAKidnapping(with);
  EXPECT_GE(found, 0);
  EXPECT_LE(found, 20);
  EXPECT_EQ(ScansUntilFoundAfterAKidnapping(without), -1);
}

TEST(LocalizerTest, KeepsItsPoseThroughABlackoutAndWinsAtOnceAfterIt) {
  // 30 scans tracked, then 2 scans blinded by clutter close around the robot (every range
  // 0.5 m): the fit drops, so the robot is lost; the pose tracked until then stays a
  // hypothesis, moved on by the odometry, and is accepted again at the first clear scan.
  SimRun run = Simulate(1, 45, 6);
  constexpr std::size_t kBlind = 30, kClear = 32;
  for (std::size_t i = kBlind; i < kClear; ++i) {
    std::fill(run.scans[i].ranges_m.begin(), run.scans[i].ranges_m.end(), 0.5);
  }
  Localizer localizer(SceneMap(testing::LoopWorld()));
  localizer.SetInitialPose(run.truth[0]);
  int lost_at = -1;
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    const LocalizerReport report = localizer.Process(run.scans[i]);
    if (report.lost_event && lost_at < 0) lost_at = static_cast<int>(i);
    if (i < kBlind || i >= kClear) {
      EXPECT_TRUE(report.localized) << "scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05)) << "scan " << i;
    } else if (report.lost_event) {  // the tracked pose is still the best hypothesis
      EXPECT_EQ(report.hypotheses, 1) << "scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.3, 0.1)) << "scan " << i;
    }
    if (i == kClear) {
      EXPECT_TRUE(report.recovered_event);
    }
  }
  EXPECT_GE(lost_at, static_cast<int>(kBlind));
  EXPECT_LT(lost_at, static_cast<int>(kClear));
}

TEST(LocalizerTest, ARightPoseStaysLocalizedWhereTheFixedFitThresholdIsTooStrict) {
  // A place where no scan reaches min_inlier_ratio (here set above any fit, as in a cluttered
  // place the map does not hold): with relative_inlier_ratio the fit is judged against its own
  // running mean, so tracking holds; without it the robot is declared lost.
  SimRun run = Simulate(0, 40, 7);
  for (LaserScan& scan : run.scans) {  // a quarter of the beams see clutter at 1 m
    for (std::size_t b = 0; b < scan.ranges_m.size(); b += 4) scan.ranges_m[b] = 1.0;
  }
  LocalizerParams with;
  with.min_inlier_ratio = 0.999;
  with.relative_inlier_ratio = 0.8;
  LocalizerParams without = with;
  without.relative_inlier_ratio = 0.0;
  ExpectTrackingHoldsOnlyWith(SceneMap(testing::LoopWorld()), with, without, run);
}

TEST(LocalizerTest, TheLastMatchedScanCarriesTrackingWhereTheMapHoldsTooLittle) {
  // A map of the outer walls alone: the inner block the robot drives around is missing, so the
  // map alone explains 0.44-0.83 of each scan, below a min_inlier_ratio of 0.6 along the first
  // side, and the robot is declared lost. The last matched scan (as the mapper's last keyframe)
  // sees the block too (0.94-1.0 explained): with it tracking holds, and the poses stay right.
  const SimRun run = Simulate(0, 60, 8);
  const testing::Scene world = testing::LoopWorld();
  const testing::Scene outer(world.begin(), world.begin() + 4);
  LocalizerParams with;
  with.min_inlier_ratio = 0.6;
  with.relative_inlier_ratio = 0.0;
  with.stages.use_last_keyframe = true;
  LocalizerParams without = with;
  without.stages.use_last_keyframe = false;
  ExpectTrackingHoldsOnlyWith(SceneMap(outer), with, without, run);
}

TEST(LocalizerTest, AWallInFrontOfTheRealOneDoesNotHideItWhileTracking) {
  // The map holds a copy of the south wall 0.15 m in front of it (as a wrong closure leaves
  // one), which from the robot hides the real wall its scans see (beyond the matcher's 0.1 m
  // inlier distance): at a strict min_inlier_ratio the robot is lost. Tracking with odometry, a
  // scan without a match is matched again with the occlusion tolerance widened
  // (retry_depth_tolerance_m): the real wall is then in the model too and the pose holds.
  const SimRun run = Simulate(0, 60, 9);
  testing::Scene world = testing::LoopWorld();
  world.push_back({{2.0, 0.15}, {12.0, 0.15}});
  LocalizerParams with;
  with.min_inlier_ratio = 0.9;
  with.relative_inlier_ratio = 0.0;
  with.retry_depth_tolerance_m = 0.5;
  LocalizerParams without = with;
  without.retry_depth_tolerance_m = 0.0;
  ExpectTrackingHoldsOnlyWith(SceneMap(world), with, without, run);
}

TEST(LocalizerTest, AWallTheScansSeeThroughHidesNothingWhileTracking) {
  // The map holds a wall across the corridor that is not there (as a wrong loop closure or a
  // person leaves one): from the robot it hides the corridor beyond it, then the robot drives
  // through it. Tracking with odometry, the scans' beams that go past it leave it out of the
  // visible map (see_through_margin_m), so the corridor behind it is matched and the pose
  // holds; without, at a strict min_inlier_ratio, the robot is lost.
  const SimRun run = Simulate(0, 60, 10);
  testing::Scene world = testing::LoopWorld();
  world.push_back({{8.0, 0.3}, {8.0, 2.7}});
  LocalizerParams with;
  with.min_inlier_ratio = 0.9;
  with.relative_inlier_ratio = 0.0;
  with.retry_depth_tolerance_m = 0.0;
  with.see_through_margin_m = 1.0;
  LocalizerParams without = with;
  without.see_through_margin_m = 0.0;
  ExpectTrackingHoldsOnlyWith(SceneMap(world), with, without, run);
}

// The localizer learns the odometry's heading error as the mapper does (OdometryCalibrator):
// 2 deg per metre more of wheel-base bias is 2 deg per metre more of learned correction, the
// other way; with the calibration off nothing is learned.
TEST(LocalizerTest, TheOdometrysHeadingErrorIsLearned) {
  const SimRun clean = Simulate(0, 250, 7);
  const double bias = 2.0 * M_PI / 180.0;
  SimRun biased = clean;
  Pose2 previous_raw = *clean.scans[0].T_odom_robot, faulty = previous_raw;
  for (std::size_t i = 1; i < biased.scans.size(); ++i) {
    const Pose2 raw = *clean.scans[i].T_odom_robot;
    Pose2 step = previous_raw.Inverse() * raw;
    step.theta += bias * step.Translation().norm();
    faulty = faulty * step;
    previous_raw = raw;
    biased.scans[i].T_odom_robot = faulty;
  }
  const auto learned = [](const SimRun& run, bool enabled) {
    LocalizerParams params;
    params.stages.odometry_calibration.enabled = enabled;
    Localizer localizer(SceneMap(testing::LoopWorld()), params);
    localizer.SetInitialPose(run.truth[0]);
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const LocalizerReport report = localizer.Process(run.scans[i]);
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05)) << "scan " << i;
    }
    return localizer.OdometryCalibration().HeadingPerMetre();
  };
  EXPECT_NEAR(learned(biased, true) - learned(clean, true), -bias, 0.25 * bias);
  EXPECT_EQ(learned(biased, false), 0.0);
}

// Odometry that stalls (as in the mapper, ShapeSlamParams::stale_odometry_min_step_m): every
// 4th scan (0.6 m apart), and at every 7th of them from the 5th on the odometry pose is that of
// the scan before; the next scan's is right again. The stalled scans are tracked without the
// odometry and the late motion is not counted twice: every pose stays right. With the check
// off the prior holds the stalled scans back.
TEST(LocalizerTest, StalledOdometryIsNotTakenForAStop) {
  const SimRun full = Simulate(0, 240, 3);
  SimRun run;
  for (std::size_t i = 0; i < full.scans.size(); i += 4) {
    run.scans.push_back(full.scans[i]);
    run.truth.push_back(full.truth[i]);
  }
  std::vector<std::size_t> stalled;
  for (std::size_t i = 5; i + 1 < run.scans.size(); i += 7) {
    run.scans[i].T_odom_robot = run.scans[i - 1].T_odom_robot;
    stalled.push_back(i);
  }
  ASSERT_GE(stalled.size(), 4u);
  const auto worst_error = [&](const LocalizerParams& params) {
    Localizer localizer(SceneMap(testing::LoopWorld()), params);
    localizer.SetInitialPose(run.truth[0]);
    double worst = 0.0;
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const Pose2 pose = localizer.Process(run.scans[i]).T_map_robot;
      worst = std::max(worst, (pose.Translation() - run.truth[i].Translation()).norm());
    }
    return worst;
  };
  LocalizerParams off;
  off.stages.stale_odometry_min_step_m = 1000.0;
  const double with_check = worst_error(LocalizerParams{}), without = worst_error(off);
  EXPECT_LT(with_check, 0.1);
  EXPECT_GT(without, 0.3);
}

TEST(LocalizerTest, IsDeterministic) {
  const SimRun run = Simulate(1, 15, 5);
  Localizer a(SceneMap(testing::LoopWorld())), b(SceneMap(testing::LoopWorld()));
  for (const LaserScan& scan : run.scans) {
    const LocalizerReport ra = a.Process(scan), rb = b.Process(scan);
    EXPECT_EQ(ra.status, rb.status);
    EXPECT_EQ(ra.T_map_robot.x, rb.T_map_robot.x);
    EXPECT_EQ(ra.T_map_robot.y, rb.T_map_robot.y);
    EXPECT_EQ(ra.T_map_robot.theta, rb.T_map_robot.theta);
  }
}

TEST(LocalizerTest, RejectsInvalidParamsAndAnEmptyMap) {
  LocalizerParams params;
  params.max_hypotheses = 0;
  EXPECT_THROW(Localizer(SceneMap(testing::LoopWorld()), params), std::invalid_argument);
  EXPECT_THROW(Localizer{PolylineMap{}}, std::invalid_argument);
  // One value out of range each.
  const std::vector<std::function<void(LocalizerParams&)>> broken = {
      [](LocalizerParams& p) { p.min_inlier_ratio = 1.5; },
      [](LocalizerParams& p) { p.fast_track_min_fit = -0.1; },
      [](LocalizerParams& p) { p.recheck_every = -1; },
      [](LocalizerParams& p) { p.recheck_half_window_rad = 4.0; },
      [](LocalizerParams& p) { p.recheck_margin = -0.1; },
      [](LocalizerParams& p) { p.recheck_poor_fit = 1.5; },
      [](LocalizerParams& p) { p.recheck_poor_half_window_rad = 4.0; },
      [](LocalizerParams& p) { p.field_track_min_fit = 1.5; },
      [](LocalizerParams& p) { p.field_track_half_window_rad = 4.0; },
      [](LocalizerParams& p) { p.field_track_prior_sigma_m = 0.0; },
      [](LocalizerParams& p) { p.field_track_check_ratio = -0.5; },
  };
  for (std::size_t i = 0; i < broken.size(); ++i) {
    LocalizerParams p;
    broken[i](p);
    EXPECT_THROW(p.Validate(), std::invalid_argument) << "case " << i;
  }
}

// The map's check (recheck_*) at every scan leaves a right tracking right: around the block
// with odometry and without, every pose stays within 0.1 m and 0.05 rad of the truth. (What it
// mends, a pose the tracking and its recent scan hold a few degrees off, comes from real logs:
// docs/notebook.md, 2026-12-06.)
TEST(LocalizerTest, TheMapsCheckLeavesARightPoseRight) {
  const SimRun run = Simulate(0, 80, 5);
  for (const bool odometry : {true, false}) {
    LocalizerParams params;
    params.recheck_every = 1;
    params.stages.use_odometry = odometry;
    EXPECT_EQ(TrackFromTheStart(SceneMap(testing::LoopWorld()), params, run, true), 0)
        << "odometry " << odometry;
  }
}

// Without odometry, a tracked pose the map's field scores below recheck_poor_fit is checked at
// once in the wider window (recheck_poor_*). Here the robot is carried 1.35 m along its way
// (9 scans left out), further than the tracking's motion bound (0.5 m) and the scheduled check's
// window (0.6 m) reach; the loss detection and the search off the map are off, so that only
// the map's check can find it. With the poor-fit check the pose comes right and stays right; without
// it, it never does. (On real logs, a slid pose: docs/notebook.md, 2026-12-07.)
TEST(LocalizerTest, WithoutOdometryAPoorlyFittingPoseIsCheckedInAWiderWindow) {
  const SimRun full = Simulate(0, 60, 7);
  constexpr std::size_t kJumpAt = 20, kLeftOut = 9;
  SimRun run;
  for (std::size_t i = 0; i < full.scans.size(); ++i) {
    if (i >= kJumpAt && i < kJumpAt + kLeftOut) continue;
    run.scans.push_back(full.scans[i]);
    run.truth.push_back(full.truth[i]);
  }
  for (const double poor_fit : {0.5, 0.0}) {
    LocalizerParams params;
    params.stages.use_odometry = false;
    params.stages.max_motion_per_scan_m = 0.5;
    params.recheck_poor_fit = poor_fit;
    params.lost_after_scans = 1000;
    params.fit_drop_ratio = 0.0;
    params.off_map_fit = 0.0;
    Localizer localizer(SceneMap(testing::LoopWorld()), params);
    localizer.SetInitialPose(run.truth[0]);
    int right_from = -1;
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const LocalizerReport report = localizer.Process(run.scans[i]);
      const bool right =
          report.localized && PosesWithin(report.T_map_robot, run.truth[i], 0.1, 0.05);
      if (i < kJumpAt) {
        EXPECT_TRUE(right) << "poor_fit " << poor_fit << ", scan " << i;
      } else if (right_from >= 0) {
        EXPECT_TRUE(right) << "poor_fit " << poor_fit << ", scan " << i;
      } else if (right) {
        right_from = static_cast<int>(i);
      }
    }
    if (poor_fit > 0.0) {
      EXPECT_GE(right_from, static_cast<int>(kJumpAt));
      EXPECT_LT(right_from, static_cast<int>(run.scans.size()) - 5);
    } else {
      EXPECT_EQ(right_from, -1);
    }
  }
}

// Without odometry the map's field predicts the scans (field_track_*): around the block, most
// scans are tracked so and every pose is right; with it off, no scan is, and the poses are as
// right. (Its speed and its accuracy on real logs: docs/notebook.md, 2026-12-06.)
TEST(LocalizerTest, WithoutOdometryTheMapsFieldPredictsTheScans) {
  const SimRun run = Simulate(0, 80, 5);
  for (const double min_fit : {0.8, 0.0}) {
    LocalizerParams params;
    params.stages.use_odometry = false;
    params.field_track_min_fit = min_fit;
    Localizer localizer(SceneMap(testing::LoopWorld()), params);
    localizer.SetInitialPose(run.truth[0]);
    int field_tracked = 0;
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const LocalizerReport report = localizer.Process(run.scans[i]);
      ASSERT_TRUE(report.localized) << "min_fit " << min_fit << ", scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05))
          << "min_fit " << min_fit << ", scan " << i;
      field_tracked += report.field_tracked ? 1 : 0;
    }
    if (min_fit > 0.0) {
      EXPECT_GE(field_tracked, 70) << "of " << run.scans.size();
    } else {
      EXPECT_EQ(field_tracked, 0);
    }
  }
}

// Without odometry, a robot that drives along the hall, turns on the spot at its corner by
// 0.52 rad a scan and drives on: the constant velocity predicts the first turning scan straight
// on and the first scan after the turn still turning, both beyond the field track's 0.1 rad.
// The scans' orientation histograms give the turn (field_track_turn_below): every scan of the
// turn and after it is field-tracked and right; without them those two are not field-tracked.
TEST(LocalizerTest, WithoutOdometryTheScansTurnCentresTheFieldTrack) {
  const testing::Scene world = testing::LoopWorld();
  std::mt19937 prng(3);
  SimRun run;
  const auto record = [&](const Pose2& pose) {
    LaserScan scan = testing::SimulateScan(world, pose, testing::ScannerModel{}, prng);
    scan.timestamp_s = 100.0 + 0.1 * static_cast<double>(run.scans.size());
    run.scans.push_back(scan);
    run.truth.push_back(pose);
  };
  for (int k = 0; k <= 10; ++k) record(Pose2(11.0 + 0.15 * k, 1.5, 0.0));
  constexpr int kTurnAt = 11;
  for (int k = 1; k <= 3; ++k) record(Pose2(12.5, 1.5, k * M_PI / 6.0));
  for (int k = 1; k <= 8; ++k) record(Pose2(12.5, 1.5 + 0.15 * k, M_PI / 2.0));
  for (const double turn_below : {0.7, 0.0}) {
    LocalizerParams params;
    params.stages.use_odometry = false;
    params.field_track_turn_below = turn_below;
    Localizer localizer(SceneMap(world), params);
    localizer.SetInitialPose(run.truth[0]);
    std::vector<bool> field_tracked;
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const LocalizerReport report = localizer.Process(run.scans[i]);
      ASSERT_TRUE(report.localized) << "turn_below " << turn_below << ", scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05))
          << "turn_below " << turn_below << ", scan " << i;
      field_tracked.push_back(report.field_tracked);
    }
    for (const int i : {kTurnAt, kTurnAt + 3}) {
      EXPECT_EQ(field_tracked[i], turn_below > 0.0) << "turn_below " << turn_below << ", scan " << i;
    }
    if (turn_below > 0.0) {
      for (std::size_t i = kTurnAt; i < field_tracked.size(); ++i) {
        EXPECT_TRUE(field_tracked[i]) << "scan " << i;
      }
    }
  }
}

// The fast track's fit in the map is the localizer's own, not the mapper's; the rest of the
// stages are as given. With the fast track off the tracking holds as well.
TEST(LocalizerTest, TheFastTrackFitIsTheLocalizersOwn) {
  LocalizerParams params;
  params.stages.fast_track_min_fit = 0.95;
  params.fast_track_min_fit = 0.7;
  const Localizer localizer(SceneMap(testing::LoopWorld()), params);
  EXPECT_EQ(localizer.Params().stages.fast_track_min_fit, 0.7);
  EXPECT_EQ(localizer.Params().stages.min_inlier_ratio, params.stages.min_inlier_ratio);
  const SimRun run = Simulate(0, 40, 1);
  for (const double fit : {0.85, 2.0}) {
    params.fast_track_min_fit = fit;
    Localizer tracked(SceneMap(testing::LoopWorld()), params);
    tracked.SetInitialPose(run.truth[0]);
    for (std::size_t i = 0; i < run.scans.size(); ++i) {
      const LocalizerReport report = tracked.Process(run.scans[i]);
      ASSERT_TRUE(report.localized) << "fit " << fit << ", scan " << i;
      EXPECT_THAT(report.T_map_robot, IsNearly(run.truth[i], 0.1, 0.05)) << "fit " << fit << ", scan " << i;
    }
  }
}

}  // namespace
}  // namespace shape_slam
