// Window search (window_search.h): the best poses of a window by branch and bound equal the
// best of an exhaustive search, known poses are recovered from the window's centre, and the
// motion prior decides between equally good fits.
#include "shape_slam/window_search.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

#include "pose_matchers.h"
#include "shape_slam/alignment.h"
#include "shape_slam/polyline_extraction.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

using testing::OfficeRoom;
using testing::Scene;

std::vector<Polyline> SceneModel(const Scene& scene) {
  std::vector<Polyline> model;
  for (const testing::Wall& w : scene) model.push_back({w.a, w.b});
  return model;
}

// Samples of a simulated scan, sensor frame, every 0.2 m.
std::vector<Point2> ScanSamples(const Scene& scene, const Pose2& T_world_sensor, std::mt19937& prng) {
  const LaserScan scan = testing::SimulateScan(scene, T_world_sensor, {}, prng);
  std::vector<Point2> samples;
  for (const Polyline& p : ExtractPolylines(scan, {})) {
    for (const Point2& s : SamplePolyline(p, 0.2)) samples.push_back(s);
  }
  return samples;
}

TEST(WindowSearchTest, FitIsOneOnTheModelAndZeroFarFromIt) {
  const WindowSearch search({{{0, 0}, {4, 0}}});
  // Cells are scored at their centres: a sample on the polyline scores at least exp(-1/8).
  EXPECT_GT(search.Fit({{1.0, 0.0}, {3.0, 0.0}}, Pose2()), 0.85);
  EXPECT_EQ(search.Fit({{1.0, 2.0}}, Pose2()), 0.0);
  EXPECT_EQ(search.Fit({}, Pose2()), 0.0);
}

TEST(WindowSearchTest, EmptyModelOrSamplesGiveNoHypothesis) {
  EXPECT_TRUE(WindowSearch({}).Search({{1, 1}}, Pose2()).empty());
  EXPECT_TRUE(WindowSearch({{{0, 0}, {1, 0}}}).Search({}, Pose2()).empty());
}

TEST(WindowSearchTest, InvalidParamsAreRejected) {
  WindowSearchParams params;
  params.resolution_m = 0.0;
  EXPECT_THROW(WindowSearch({}, params), std::invalid_argument);
  params = {};
  params.max_hypotheses = 0;
  EXPECT_THROW(WindowSearch({}, params), std::invalid_argument);
}

// The whole-map search (all translations, all turns, no centre) finds the scan's pose in a room
// it has never been told about, scoring as well as an exhaustive search over a pose grid of
// the room; its hypotheses are distinct and best first; a tiny work bound still returns at
// most max_hypotheses poses.
WindowSearchParams MapSearchParams() {
  WindowSearchParams params;
  params.resolution_m = params.hit_sigma_m = 0.2;
  params.half_window_m = 1.0;  // sets only the pyramid's top level here
  params.prior_weight = params.min_relative_score = 0.0;
  params.max_hypotheses = 4;
  params.max_node_evaluations = 1 << 30;
  return params;
}

TEST(WindowSearchTest, SearchMapFindsThePoseAnywhereAsAnExhaustiveSearchDoes) {
  const Scene scene = OfficeRoom();
  const std::vector<Polyline> model = SceneModel(scene);
  WindowSearchParams params = MapSearchParams();
  const WindowSearch search(model, params);
  std::mt19937 prng(42);
  const Pose2 truth(2.5, 2.0, 0.4);
  const std::vector<Point2> samples = ScanSamples(scene, truth, prng);
  const std::vector<WindowHypothesis> found = search.SearchMap(samples);
  ASSERT_FALSE(found.empty());
  EXPECT_LE(found.size(), 4u);
  EXPECT_THAT(found.front().T_model_scan, IsNearly(truth, 0.3, 0.1));
  for (std::size_t i = 1; i < found.size(); ++i) {
    EXPECT_LE(found[i].score, found[i - 1].score);
    for (std::size_t j = 0; j < i; ++j) {
      const bool near = (found[i].T_model_scan.Translation() - found[j].T_model_scan.Translation()).norm() <
                            params.distinct_m &&
                        std::abs(NormalizeAngle(found[i].T_model_scan.theta - found[j].T_model_scan.theta)) <
                            params.distinct_rad;
      EXPECT_FALSE(near) << i << " " << j;
    }
  }
  double range = 1.0;
  for (const Point2& p : samples) range = std::max(range, p.norm());
  const double step = search.ResolutionM() / std::min(range, params.max_step_range_m);
  double best = 0.0;
  for (double theta = -M_PI; theta < M_PI; theta += step) {
    for (double x = -1.0; x <= 9.0; x += search.ResolutionM()) {
      for (double y = -1.0; y <= 7.0; y += search.ResolutionM()) {
        best = std::max(best, search.Fit(samples, Pose2(x, y, theta)));
      }
    }
  }
  // The two grids are offset from each other by less than a cell: a small tolerance.
  EXPECT_NEAR(found.front().score, best, 0.05);

  params.max_node_evaluations = 50;
  const std::vector<WindowHypothesis> bounded = WindowSearch(model, params).SearchMap(samples);
  EXPECT_LE(bounded.size(), 4u);
}

// Oracle: the branch and bound returns the best score of the exhaustive search over the same
// grid of poses (every rotation step, every cell offset).
TEST(WindowSearchTest, BestScoreEqualsExhaustiveSearch) {
  std::mt19937 prng(42);
  const Scene scene = OfficeRoom();
  const std::vector<Polyline> model = SceneModel(scene);
  WindowSearchParams params;
  params.half_window_m = 0.5;
  params.half_window_rad = 0.2;
  params.max_node_evaluations = 1 << 30;
  params.prior_weight = 0.05;
  const WindowSearch search(model, params);
  const std::vector<Point2> samples = ScanSamples(scene, Pose2(2.5, 2.0, 0.4), prng);
  const Pose2 centre(2.8, 1.8, 0.5);
  const std::vector<WindowHypothesis> found = search.Search(samples, centre);
  ASSERT_FALSE(found.empty());

  double range = 1.0;
  for (const Point2& p : samples) range = std::max(range, p.norm());
  const double res = search.ResolutionM();
  const double step = res / std::min(range, params.max_step_range_m);
  const int half_rot = static_cast<int>(std::ceil(params.half_window_rad / step));
  const int c = static_cast<int>(std::ceil(params.half_window_m / res));
  double best = -1e9;
  for (int r = -half_rot; r <= half_rot; ++r) {
    for (int tx = -c; tx <= c; ++tx) {
      for (int ty = -c; ty <= c; ++ty) {
        // Cells of the rotated samples, then the offset: the search's own discretisation.
        const Pose2 rotated(centre.x, centre.y, centre.theta + r * step);
        const Pose2 pose(centre.x + tx * res, centre.y + ty * res, rotated.theta);
        const double fit = search.Fit(samples, pose);
        const double e = r * step / params.prior_sigma_rad;
        const double d2 = (tx * tx + ty * ty) * res * res / (params.prior_sigma_m * params.prior_sigma_m);
        best = std::max(best, fit - params.prior_weight * (e * e + d2));
      }
    }
  }
  // Cell assignment of "rotate then offset" and "offset the pose" can differ by rounding at
  // cell borders: a small tolerance.
  EXPECT_NEAR(found.front().score, best, 0.03);
}

TEST(WindowSearchTest, RecoversKnownPosesFromTheCentre) {
  std::mt19937 prng(42);
  const Scene scene = OfficeRoom();
  const WindowSearch search(SceneModel(scene));
  std::uniform_real_distribution<double> offset(-1.2, 1.2), turn(-1.0, 1.0);
  int recovered = 0;
  constexpr int kTrials = 20;
  for (int trial = 0; trial < kTrials; ++trial) {
    const Pose2 truth(3.0 + 0.5 * offset(prng), 2.5 + 0.5 * offset(prng), turn(prng) * M_PI);
    const Pose2 centre(truth.x + offset(prng), truth.y + offset(prng), truth.theta + turn(prng));
    const std::vector<WindowHypothesis> found = search.Search(ScanSamples(scene, truth, prng), centre);
    ASSERT_FALSE(found.empty());
    const Pose2 d = truth.Inverse() * found.front().T_model_scan;
    if (d.Translation().norm() < 0.2 && std::abs(d.theta) < 0.05) ++recovered;
  }
  EXPECT_GE(recovered, kTrials - 1);
}

// A window given to Search replaces the params' own: the known pose is found from a centre
// 0.36 m and 0.1 rad off within a 0.6 m / 0.3 rad window, and a window too small to reach it
// returns only poses inside it (up to a cell, and an angular step: the cell over the samples'
// range, under 0.05 rad in this room).
TEST(WindowSearchTest, AGivenWindowBoundsTheSearch) {
  std::mt19937 prng(7);
  const Scene scene = OfficeRoom();
  const WindowSearch search(SceneModel(scene));
  const Pose2 truth(3.0, 2.5, 0.4);
  const std::vector<Point2> samples = ScanSamples(scene, truth, prng);
  const Pose2 centre = truth * Pose2(0.3, -0.2, 0.1);
  const std::vector<WindowHypothesis> wide = search.Search(samples, centre, 0.6, 0.3);
  ASSERT_FALSE(wide.empty());
  EXPECT_THAT(wide.front().T_model_scan, IsNearly(truth, 0.2, 0.05));
  const std::vector<WindowHypothesis> narrow = search.Search(samples, centre, 0.1, 0.02);
  ASSERT_FALSE(narrow.empty());
  for (const WindowHypothesis& h : narrow) {
    EXPECT_LE(std::abs(h.T_model_scan.x - centre.x), 0.1 + search.ResolutionM());
    EXPECT_LE(std::abs(h.T_model_scan.y - centre.y), 0.1 + search.ResolutionM());
    EXPECT_LE(std::abs(NormalizeAngle(h.T_model_scan.theta - centre.theta)), 0.02 + 0.05);
  }
}

// A featureless corridor fits anywhere along its axis: the prior takes the pose nearest the
// centre.
TEST(WindowSearchTest, PriorDecidesAlongAFeaturelessCorridor) {
  const std::vector<Polyline> model = {{{-20, 0}, {20, 0}}, {{-20, 2}, {20, 2}}};
  std::vector<Point2> samples;  // the walls seen from (0, 1), 4 m each way
  for (double x = -4; x <= 4; x += 0.2) samples.push_back({x, -1}), samples.push_back({x, 1});
  const WindowSearch search(model);
  for (const double along : {-0.8, 0.0, 0.9}) {
    const std::vector<WindowHypothesis> found = search.Search(samples, Pose2(along, 1.1, 0.05));
    ASSERT_FALSE(found.empty());
    EXPECT_THAT(found.front().T_model_scan, IsNearly(Pose2(along, 1.0, 0.0), 0.11, 0.02));
  }
}

TEST(WindowSearchTest, DistinctHypothesesForASymmetricRoom) {
  // A square room seen from its centre fits itself turned by 90 deg.
  const std::vector<Polyline> model = {{{-2, -2}, {2, -2}, {2, 2}, {-2, 2}, {-2, -2}}};
  std::vector<Point2> samples;
  for (const Polyline& wall : model) {
    for (const Point2& s : SamplePolyline(wall, 0.2)) samples.push_back(s);
  }
  WindowSearchParams params;
  params.half_window_rad = M_PI;
  params.prior_weight = 0.0;
  const std::vector<WindowHypothesis> found = WindowSearch(model, params).Search(samples, Pose2());
  ASSERT_GE(found.size(), 2u);
  for (const WindowHypothesis& h : found) {
    const double quarter = std::remainder(h.T_model_scan.theta, M_PI / 2);
    EXPECT_LT(std::abs(quarter), 0.06);  // the angular step here is 0.035 rad
    EXPECT_LT(h.T_model_scan.Translation().norm(), 0.11);
  }
  EXPECT_GT(std::abs(NormalizeAngle(found[0].T_model_scan.theta - found[1].T_model_scan.theta)), 1.0);
}

}  // namespace
}  // namespace shape_slam
