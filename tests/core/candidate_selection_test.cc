// Candidate selection (candidate_selection.h): the order of fits and distances, the quick ICP
// that finishes candidates, a brute-force check of the choice on a small synthetic room, and
// the refinement loop.
#include "shape_slam/candidate_selection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "pose_matchers.h"
#include "shape_slam/alignment.h"
#include "shape_slam/polyline_extraction.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

std::vector<Polyline> SceneModel(const testing::Scene& scene) {
  std::vector<Polyline> model;
  for (const testing::Wall& w : scene) model.push_back({w.a, w.b});
  return model;
}

std::vector<Point2> ScanSamples(const testing::Scene& scene, const Pose2& T_world_sensor) {
  std::mt19937 prng(7);
  const LaserScan scan = testing::SimulateScan(scene, T_world_sensor, {}, prng);
  std::vector<Point2> samples;
  for (const Polyline& p : ExtractPolylines(scan, {})) {
    for (const Point2& s : SamplePolyline(p, 0.1)) samples.push_back(s);
  }
  return samples;
}

TEST(OrderByFitTest, BestFitFirstAndNearestAmongEqualFits) {
  // fits 0.9 and 0.88 are equally good (0.05): the nearer (index 1) first; 0.5 last.
  EXPECT_THAT(OrderByFit({0.9, 0.88, 0.5}, {2.0, 0.1, 0.0}, 0.05), ::testing::ElementsAre(1, 0, 2));
  // Without tolerance the fit alone decides.
  EXPECT_THAT(OrderByFit({0.9, 0.88, 0.5}, {2.0, 0.1, 0.0}, 0.0), ::testing::ElementsAre(0, 1, 2));
  // Ties in both: input order.
  EXPECT_THAT(OrderByFit({0.7, 0.7}, {1.0, 1.0}, 0.05), ::testing::ElementsAre(0, 1));
  EXPECT_TRUE(OrderByFit({}, {}, 0.05).empty());
  EXPECT_THROW(OrderByFit({1.0}, {}, 0.05), std::invalid_argument);
}

// Oracle: every output position holds, among the remaining, the nearest of those within the
// tolerance of the best remaining fit (checked against brute force on random inputs).
TEST(OrderByFitTest, MatchesItsDefinitionOnRandomInputs) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + trial % 7;
    std::vector<double> fits(n), distances(n);
    for (int i = 0; i < n; ++i) fits[i] = std::round(u(prng) * 20) / 20, distances[i] = u(prng);
    const std::vector<int> order = OrderByFit(fits, distances, 0.05);
    ASSERT_EQ(static_cast<int>(order.size()), n);
    std::vector<bool> used(n, false);
    for (const int picked : order) {
      double best = -1.0;
      for (int i = 0; i < n; ++i) if (!used[i]) best = std::max(best, fits[i]);
      ASSERT_FALSE(used[picked]);
      EXPECT_GE(fits[picked], best - 0.05 - 1e-12);
      for (int i = 0; i < n; ++i) {
        if (!used[i] && fits[i] >= best - 0.05) {
          EXPECT_LE(distances[picked], distances[i]);
        }
      }
      used[picked] = true;
    }
  }
}

TEST(CandidateSelectorTest, QuickIcpFinishesARoughCandidate) {
  const testing::Scene scene = testing::OfficeRoom();
  const Pose2 truth(2.5, 2.0, 0.3);
  const CandidateSelector selector(SceneModel(scene), {});
  const std::vector<Point2> samples = ScanSamples(scene, truth);
  const std::vector<RankedCandidate> ranked =
      selector.Rank(samples, {Pose2(2.7, 1.85, 0.36)}, Pose2());
  ASSERT_EQ(ranked.size(), 1u);
  EXPECT_THAT(ranked[0].T_model_scan, IsNearly(truth, 0.05, 0.035));  // rough: refinement follows
  EXPECT_GT(ranked[0].fit, 0.9);
}

// Brute force on a small synthetic room: the selector's first candidate explains the scan as
// well as the best of all candidates (each finished as the selector does), and of the equally
// good ones it is the nearest to the reference.
TEST(CandidateSelectorTest, ChoiceEqualsBruteForceOverCandidates) {
  const testing::Scene scene = testing::OfficeRoom();
  const Pose2 truth(3.0, 2.5, -0.4);
  const std::vector<Point2> samples = ScanSamples(scene, truth);
  CandidateSelectionParams params;
  const CandidateSelector selector(SceneModel(scene), params);
  std::vector<Pose2> candidates;
  for (double dx = -1.0; dx <= 1.0; dx += 0.5) {
    for (double dy = -1.0; dy <= 1.0; dy += 0.5) {
      for (double dt = -0.6; dt <= 0.6; dt += 0.3) {
        candidates.emplace_back(truth.x + dx, truth.y + dy, truth.theta + dt);
      }
    }
  }
  const Pose2 reference(2.0, 2.0, 0.0);
  const std::vector<RankedCandidate> ranked = selector.Rank(samples, candidates, reference);
  ASSERT_EQ(ranked.size(), candidates.size());
  double best_fit = 0.0;
  for (const Pose2& c : candidates) {
    best_fit = std::max(best_fit, selector.Fit(samples, selector.QuickAlign(samples, c, params.icp_iterations)));
  }
  EXPECT_GE(ranked.front().fit, best_fit - params.equally_good_fit);
  for (const Pose2& c : candidates) {
    const Pose2 aligned = selector.QuickAlign(samples, c, params.icp_iterations);
    if (selector.Fit(samples, aligned) >= best_fit - params.equally_good_fit) {
      EXPECT_LE(ranked.front().distance, PoseDistance(reference, aligned, params.turn_weight_m_per_rad) + 1e-12);
    }
  }
  EXPECT_THAT(ranked.front().T_model_scan, IsNearly(truth, 0.05, 0.035));
}

TEST(CandidateSelectorTest, AcceptFilterDropsCandidates) {
  const testing::Scene scene = testing::OfficeRoom();
  const CandidateSelector selector(SceneModel(scene), {});
  const std::vector<Point2> samples = ScanSamples(scene, Pose2(2.5, 2.0, 0.0));
  const auto ranked = selector.Rank(samples, {Pose2(2.5, 2.0, 0.0), Pose2(0.5, 0.5, 3.0)}, Pose2(),
                                    [](const Pose2& T) { return T.x > 1.5; });
  ASSERT_EQ(ranked.size(), 1u);
  EXPECT_EQ(ranked[0].index, 0);
}

// A plain corridor along x (walls at y = 0 and y = 2) seen by an 8 m scanner: the model is what
// the robot saw at x = 0, the scan is taken 1 m further on, so its far samples lie past the
// model's open ends. Counted as misses they make the scan fit best short of its pose; left out
// as unknown space (open_end_m) the true pose fits as well as any along the corridor.
TEST(CandidateSelectorTest, SamplesPastTheModelsOpenEndsAreUnknownNotMisses) {
  const testing::Scene corridor = {{{-5.0, 0.0}, {40.0, 0.0}}, {{40.0, 2.0}, {-5.0, 2.0}}};
  const testing::ScannerModel scanner{181, M_PI, 8.0, 0.005};
  std::mt19937 prng(3);
  std::vector<Polyline> model;
  for (const Polyline& p : ExtractPolylines(testing::SimulateScan(corridor, Pose2(0.0, 1.0, 0.0), scanner, prng), {})) {
    model.push_back(Transform(Pose2(0.0, 1.0, 0.0), p));
  }
  std::vector<Point2> samples;
  for (const Polyline& p : ExtractPolylines(testing::SimulateScan(corridor, Pose2(1.0, 1.0, 0.0), scanner, prng), {})) {
    for (const Point2& q : SamplePolyline(p, 0.1)) samples.push_back(q);
  }
  CandidateSelectionParams params;
  params.icp_iterations = 0;  // score the candidates where they are
  const Pose2 truth(1.0, 1.0, 0.0), short_of_it(0.4, 1.0, 0.0);
  const CandidateSelector misses(model, params);
  const auto counted = misses.Rank(samples, {truth, short_of_it}, Pose2());
  ASSERT_EQ(counted.size(), 2u);
  EXPECT_EQ(counted[0].index, 1);  // short of it fits best
  EXPECT_GT(counted[0].fit, counted[1].fit + 0.05);
  params.open_end_m = 1.5;
  const CandidateSelector unknown(model, params);
  const auto left_out = unknown.Rank(samples, {truth, short_of_it}, Pose2());
  ASSERT_EQ(left_out.size(), 2u);
  for (const RankedCandidate& c : left_out) EXPECT_GT(c.fit, 0.95);
  EXPECT_NEAR(left_out[0].fit, left_out[1].fit, 0.02);
  // Off the walls' lines nothing is unknown: a pose 0.5 m aside fits no better than before.
  const Pose2 aside(1.0, 1.5, 0.0);
  EXPECT_NEAR(unknown.Rank(samples, {aside}, Pose2())[0].fit, misses.Fit(samples, aside), 0.05);
}

// The motion prior's penalty is w * ((|t| / sigma_m)^2 + (theta / sigma_rad)^2), at most
// prior_max_penalty: far from the reference a candidate pays the bound, not more.
TEST(CandidateSelectorTest, MotionPriorPenaltyIsBounded) {
  const testing::Scene scene = testing::OfficeRoom();
  const Pose2 truth(2.5, 2.0, 0.3);
  const std::vector<Point2> samples = ScanSamples(scene, truth);
  CandidateSelectionParams params;
  params.icp_iterations = 0;
  params.prior_weight = 0.03;
  params.prior_max_penalty = 0.08;
  const CandidateSelector selector(SceneModel(scene), params);
  const Pose2 reference(2.3, 2.0, 0.3);  // 0.2 m away: 0.03 * 0.16 = 0.0048
  const auto ranked = selector.Rank(samples, {truth, Pose2(4.0, 3.0, 0.3)}, reference);
  ASSERT_EQ(ranked.size(), 2u);
  for (const RankedCandidate& c : ranked) {
    const Pose2 motion = reference.Inverse() * c.T_model_scan;
    const double e2 = motion.Translation().squaredNorm() / 0.25 + motion.theta * motion.theta / 0.25;
    EXPECT_NEAR(c.fit - c.score, std::min(0.03 * e2, 0.08), 1e-12);
  }
  EXPECT_EQ(ranked[0].index, 0);
  EXPECT_NEAR(ranked[1].fit - ranked[1].score, 0.08, 1e-12);  // 1.8 m away: bounded
}

TEST(SelectRefinedTest, TakesTheFirstAcceptedWithinTheBudget) {
  const std::vector<RankedCandidate> ranked = {{Pose2(0, 0, 0), 0.9, 0.9, 0.0, 0},
                                               {Pose2(1, 0, 0), 0.8, 0.8, 0.0, 1},
                                               {Pose2(2, 0, 0), 0.7, 0.7, 0.0, 2}};
  const auto only_x2 = [](const RankedCandidate& c) -> std::optional<double> {
    if (c.T_model_scan.x < 1.5) return std::nullopt;
    return c.T_model_scan.x;
  };
  const auto selected = SelectRefined<double>(ranked, 3, only_x2);
  ASSERT_TRUE(selected);
  EXPECT_EQ(selected->first.index, 2);
  EXPECT_FALSE(SelectRefined<double>(ranked, 2, only_x2));
}

TEST(CandidateSelectionParamsTest, InvalidFieldsAreNamed) {
  CandidateSelectionParams params;
  params.max_refinements = 0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.equally_good_fit = 2.0;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.prior_max_penalty = -0.1;
  EXPECT_THROW(params.Validate(), std::invalid_argument);
  params = {};
  params.open_end_m = std::nan("");
  EXPECT_THROW(params.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
