#include "shape_slam/polyline_correspondence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <tuple>

namespace shape_slam {
namespace {

// A random cost table over all group pairs; some pairs forbidden.
struct RandomCosts {
  std::map<std::tuple<int, int, int, int>, std::optional<double>> table;
  std::mt19937* prng;
  double offset = 0.0;  // subtracted from every cost (below 0: some costs negative)
  std::optional<double> operator()(int i, int gs, int j, int gm) {
    auto key = std::make_tuple(i, gs, j, gm);
    auto it = table.find(key);
    if (it != table.end()) return it->second;
    std::uniform_real_distribution<double> u(0.0, 2.0);
    std::optional<double> value;
    if (u(*prng) > 0.3) value = u(*prng) - offset;
    table[key] = value;
    return value;
  }
};

// Brute force: minimum of eq. (4) over every order-preserving correspondence, by recursion over
// the same elementary steps but without memoisation or pruning.
double BruteForce(const CorrespondenceProblem& p, int rotation, int i, int k) {
  const int a = static_cast<int>(p.scan_skip_penalty.size());
  const int b = static_cast<int>(p.model_skip_penalty.size());
  if (i == a && k == b) return 0.0;
  double best = std::numeric_limits<double>::infinity();
  if (i < a) best = std::min(best, p.scan_skip_penalty[i] + BruteForce(p, rotation, i + 1, k));
  if (k < b) {
    best = std::min(best, p.model_skip_penalty[(rotation + k) % b] + BruteForce(p, rotation, i, k + 1));
  }
  for (int gs = 1; gs <= p.max_group_size && i + gs <= a; ++gs) {
    for (int gm = 1; gm <= p.max_group_size && k + gm <= b; ++gm) {
      if (gs > 1 && gm > 1) continue;
      const std::optional<double> c = p.group_cost(i, gs, (rotation + k) % b, gm);
      if (c) best = std::min(best, *c + BruteForce(p, rotation, i + gs, k + gm));
    }
  }
  return best;
}

// The cost that a solution claims, recomputed from its matches and the skipped polylines.
double CostOf(const CorrespondenceProblem& p, const CorrespondenceSolution& s) {
  const int a = static_cast<int>(p.scan_skip_penalty.size());
  const int b = static_cast<int>(p.model_skip_penalty.size());
  std::vector<bool> scan_used(a, false), model_used(b, false);
  double total = 0.0;
  for (const GroupMatch& m : s.matches) {
    total += *p.group_cost(m.scan_first, m.scan_count, m.model_first, m.model_count);
    for (int t = 0; t < m.scan_count; ++t) {
      EXPECT_FALSE(scan_used[m.scan_first + t]);
      scan_used[m.scan_first + t] = true;
    }
    for (int t = 0; t < m.model_count; ++t) {
      EXPECT_FALSE(model_used[m.ModelIndex(t, b)]);
      model_used[m.ModelIndex(t, b)] = true;
    }
    EXPECT_TRUE(m.scan_count == 1 || m.model_count == 1);
  }
  for (int i = 0; i < a; ++i) total += scan_used[i] ? 0.0 : p.scan_skip_penalty[i];
  for (int j = 0; j < b; ++j) total += model_used[j] ? 0.0 : p.model_skip_penalty[j];
  return total;
}

// Order preservation: scan groups increase, and model groups increase along the rotated order.
void ExpectOrderPreserved(const CorrespondenceSolution& s, int num_model) {
  int last_scan = -1, last_model = -1;
  for (const GroupMatch& m : s.matches) {
    EXPECT_GT(m.scan_first, last_scan);
    const int rotated = (m.model_first - s.model_rotation + num_model) % num_model;
    EXPECT_GT(rotated, last_model);
    last_scan = m.scan_first + m.scan_count - 1;
    last_model = rotated + m.model_count - 1;
  }
}

// Every rotation of a cyclic model is solved, those that cannot beat the best abandoned early;
// with some negative costs no bound holds and none is: the brute force agrees either way.
class PolylineCorrespondenceBruteForceTest : public ::testing::TestWithParam<double> {};

TEST_P(PolylineCorrespondenceBruteForceTest, EqualsBruteForceOnTinyInputs) {
  std::mt19937 prng(42);
  for (int trial = 0; trial < 300; ++trial) {
    std::uniform_int_distribution<int> size(0, 4);
    std::uniform_real_distribution<double> penalty(0.1, 1.5);
    CorrespondenceProblem p;
    p.scan_skip_penalty.resize(size(prng));
    p.model_skip_penalty.resize(size(prng));
    for (double& v : p.scan_skip_penalty) v = penalty(prng);
    for (double& v : p.model_skip_penalty) v = penalty(prng);
    auto costs = std::make_shared<RandomCosts>();
    costs->prng = &prng;
    costs->offset = GetParam();
    p.group_cost = [costs](int i, int gs, int j, int gm) { return (*costs)(i, gs, j, gm); };
    p.max_group_size = 1 + trial % 3;
    p.model_cyclic = trial % 2 == 1;
    const CorrespondenceSolution solution = SolveCorrespondence(p);
    const int b = static_cast<int>(p.model_skip_penalty.size());
    double expected = BruteForce(p, 0, 0, 0);
    if (p.model_cyclic) {
      for (int r = 1; r < b; ++r) expected = std::min(expected, BruteForce(p, r, 0, 0));
    }
    ASSERT_NEAR(solution.total_cost, expected, 1e-12) << "trial " << trial;
    EXPECT_NEAR(CostOf(p, solution), solution.total_cost, 1e-12) << "trial " << trial;
    if (b > 0) ExpectOrderPreserved(solution, b);
  }
}

INSTANTIATE_TEST_SUITE_P(Costs, PolylineCorrespondenceBruteForceTest,
                         ::testing::Values(0.0, 0.5));

TEST(PolylineCorrespondenceTest, PrefersGroupingWhenCheaperThanSkipping) {
  // Scan polyline 0 is a wall the map holds as two pieces: the 1-to-2 group is cheapest.
  CorrespondenceProblem p;
  p.scan_skip_penalty = {1.0};
  p.model_skip_penalty = {0.5, 0.5};
  p.group_cost = [](int, int, int j, int gm) -> std::optional<double> {
    if (j == 0 && gm == 2) return 0.1;
    return 0.8;
  };
  const CorrespondenceSolution s = SolveCorrespondence(p);
  ASSERT_EQ(s.matches.size(), 1u);
  EXPECT_EQ(s.matches[0].model_first, 0);
  EXPECT_EQ(s.matches[0].model_count, 2);
  EXPECT_DOUBLE_EQ(s.total_cost, 0.1);

  p.max_group_size = 1;  // without groupings: match one piece, skip the other
  const CorrespondenceSolution no_groups = SolveCorrespondence(p);
  EXPECT_DOUBLE_EQ(no_groups.total_cost, 0.8 + 0.5);
}

TEST(PolylineCorrespondenceTest, CyclicModelFindsRotatedOrder) {
  // Scan i corresponds to model (i + 2) % 4; a linear order cannot match all four.
  CorrespondenceProblem p;
  p.scan_skip_penalty = {1, 1, 1, 1};
  p.model_skip_penalty = {1, 1, 1, 1};
  p.max_group_size = 1;
  p.group_cost = [](int i, int, int j, int) -> std::optional<double> {
    if (j == (i + 2) % 4) return 0.0;
    return std::nullopt;
  };
  const CorrespondenceSolution linear = SolveCorrespondence(p);
  EXPECT_EQ(linear.matches.size(), 2u);
  p.model_cyclic = true;
  const CorrespondenceSolution cyclic = SolveCorrespondence(p);
  ASSERT_EQ(cyclic.matches.size(), 4u);
  EXPECT_EQ(cyclic.model_rotation, 2);
  EXPECT_DOUBLE_EQ(cyclic.total_cost, 0.0);
}

TEST(PolylineCorrespondenceTest, EmptySidesSkipEverything) {
  CorrespondenceProblem p;
  p.scan_skip_penalty = {0.5, 0.25};
  p.group_cost = [](int, int, int, int) -> std::optional<double> { return 0.0; };
  const CorrespondenceSolution s = SolveCorrespondence(p);
  EXPECT_TRUE(s.matches.empty());
  EXPECT_DOUBLE_EQ(s.total_cost, 0.75);
}

TEST(PolylineCorrespondenceTest, RejectsBadProblems) {
  CorrespondenceProblem p;
  p.scan_skip_penalty = {1.0};
  p.model_skip_penalty = {1.0};
  EXPECT_THROW(SolveCorrespondence(p), std::invalid_argument);
  p.group_cost = [](int, int, int, int) -> std::optional<double> { return 0.0; };
  p.max_group_size = 0;
  EXPECT_THROW(SolveCorrespondence(p), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
