#include "shape_slam/shape_similarity.h"

#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <random>

#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/internal/prepared_shape.h"
#include "shape_slam/tangent_space.h"

namespace shape_slam {
namespace {

Polyline Sub(const Polyline& p, int first, int last) {
  return Polyline(p.begin() + first, p.begin() + last + 1);
}

TEST(ArcSimilarityTest, IdenticalAndRigidlyMovedArcsAreSimilar) {
  const Polyline c = {{0, 0}, {1, 0}, {1.5, 0.8}, {1.4, 2}};
  EXPECT_DOUBLE_EQ(ArcSimilarity(c, c), 0.0);
  EXPECT_NEAR(ArcSimilarity(c, Transform(Pose2(3, -2, 1.1), c)), 0.0, 1e-12);
  EXPECT_NEAR(ArcSimilarity(Transform(Pose2(-7, 5, -2.9), c), c), 0.0, 1e-12);
}

TEST(ArcSimilarityTest, HandValueOfEquation2) {
  // C: an L with legs 1, 1 (step of pi/2 at s = 0.5); D: straight, length 3. T_C - T_D is 0
  // then pi/2: its variance is (pi/2)^2 / 4; the length term is 1 + (2 - 3)^2 = 2.
  const double expected = 2.0 * (M_PI / 2) * (M_PI / 2) / 4.0;
  EXPECT_NEAR(ArcSimilarity({{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {3, 0}}), expected, 1e-12);
  // Theta of eq. (3) absorbs any constant difference: a turned straight line costs nothing.
  EXPECT_NEAR(ArcSimilarity({{0, 0}, {1, 1}}, {{0, 0}, {0, 1.414213562373095}}), 0.0, 1e-12);
}

// Brute force of S: every way to cover both arc sequences in order by steps pairing one arc with
// one or more arcs of the other side.
double BruteForceS(const Polyline& c, const Polyline& d) {
  const std::vector<Arc> ac = MaximalArcs(c), ad = MaximalArcs(d);
  const int m = static_cast<int>(ac.size()), n = static_cast<int>(ad.size());
  std::function<double(int, int)> best = [&](int i, int j) -> double {
    if (i == m && j == n) return 0.0;
    if (i == m || j == n) return std::numeric_limits<double>::infinity();
    double r = std::numeric_limits<double>::infinity();
    for (int k = j; k < n; ++k) {
      r = std::min(r, ArcSimilarity(Sub(c, ac[i].first_vertex, ac[i].last_vertex),
                                    Sub(d, ad[j].first_vertex, ad[k].last_vertex)) + best(i + 1, k + 1));
    }
    for (int k = i + 1; k < m; ++k) {
      r = std::min(r, ArcSimilarity(Sub(c, ac[i].first_vertex, ac[k].last_vertex),
                                    Sub(d, ad[j].first_vertex, ad[j].last_vertex)) + best(k + 1, j + 1));
    }
    return r;
  };
  return best(0, 0);
}

Polyline RandomZigzag(std::mt19937& prng, int vertices) {
  std::uniform_real_distribution<double> turn(-1.2, 1.2), len(0.3, 1.5);
  Polyline p = {{0, 0}};
  double heading = 0.0;
  for (int i = 1; i < vertices; ++i) {
    heading += turn(prng);
    const double l = len(prng);
    p.push_back(p.back() + Point2(l * std::cos(heading), l * std::sin(heading)));
  }
  return p;
}

TEST(PolylineSimilarityTest, DynamicProgrammingEqualsBruteForce) {
  std::mt19937 prng(42);
  for (int trial = 0; trial < 150; ++trial) {
    const Polyline c = RandomZigzag(prng, 3 + trial % 5), d = RandomZigzag(prng, 3 + (trial / 5) % 5);
    if (MaximalArcs(c).size() > 4 || MaximalArcs(d).size() > 4) continue;
    const SimilarityResult s = PolylineSimilarity(c, d);
    ASSERT_NEAR(s.value, BruteForceS(c, d), 1e-9 * (1.0 + s.value)) << "trial " << trial;
    double sum = 0.0;
    for (const ArcGroupMatch& m : s.matches) sum += m.cost;
    EXPECT_NEAR(sum, s.value, 1e-9 * (1.0 + s.value));
  }
}

TEST(PolylineSimilarityTest, InvariantToRigidMotionsOfEitherPolyline) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> u(-10, 10);
  for (int trial = 0; trial < 50; ++trial) {
    const Polyline c = RandomZigzag(prng, 6), d = RandomZigzag(prng, 5);
    const Pose2 T(u(prng), u(prng), u(prng));
    const double s = PolylineSimilarity(c, d).value;
    EXPECT_NEAR(PolylineSimilarity(Transform(T, c), d).value, s, 1e-9 * (1 + s));
    EXPECT_NEAR(PolylineSimilarity(c, Transform(T, d)).value, s, 1e-9 * (1 + s));
    const double s_star = ComputeEvolvedSimilarity(c, d).value;
    EXPECT_NEAR(ComputeEvolvedSimilarity(Transform(T, c), d).value, s_star, 1e-9 * (1 + s_star));
    EXPECT_NEAR(ComputeEvolvedSimilarity(c, Transform(T, d)).value, s_star, 1e-9 * (1 + s_star));
  }
}

Polyline NoisyCopy(const Polyline& model, std::mt19937& prng, double sigma, double spacing) {
  std::normal_distribution<double> noise(0.0, sigma);
  Polyline out;
  for (std::size_t i = 0; i + 1 < model.size(); ++i) {
    const Point2 d = model[i + 1] - model[i];
    const int n = std::max(1, static_cast<int>(d.norm() / spacing));
    for (int k = 0; k < n; ++k) {
      out.push_back(model[i] + d * (static_cast<double>(k) / n) + Point2(noise(prng), noise(prng)));
    }
  }
  out.push_back(model.back());
  return out;
}

TEST(EvolvedSimilarityTest, ContinuedEvolutionRemovesNoise) {
  std::mt19937 prng(42);
  const Polyline model = {{0, 0}, {2, 0}, {2, 1}, {3, 1}, {3, 3}};
  const Polyline noisy = SimplifyDce(NoisyCopy(model, prng, 0.01, 0.05), 0.005);
  const double s = PolylineSimilarity(noisy, model).value;
  const EvolvedSimilarity e = ComputeEvolvedSimilarity(noisy, model);
  EXPECT_LE(e.value, s);
  EXPECT_LT(e.value, 0.5 * s);
  EXPECT_GT(e.removed_vertices, 0);
  EXPECT_EQ(e.evolved_c.size() + e.removed_vertices, noisy.size());
  EXPECT_NEAR(PolylineSimilarity(e.evolved_c, model).value, e.value, 1e-12);
  // An unrelated shape stays dissimilar.
  const Polyline other = {{0, 0}, {1, 1}, {2, 0}, {3, 1}, {4, 0}};
  EXPECT_GT(ComputeEvolvedSimilarity(other, model).value, 5.0 * e.value);
}

TEST(EvolvedSimilarityTest, LookaheadCrossesALocalMinimum) {
  // Evolution steps where one removal makes S worse but the next one better: a lookahead of 1
  // stops early, 3 continues (§4.1).
  std::mt19937 prng(7);
  std::normal_distribution<double> noise(0.0, 0.08);
  const Polyline model = {{0, 0}, {2, 0}, {2, 1}, {3, 1}};
  int differing = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Polyline noisy;  // 12 points along the model, with 8 cm noise
    for (int i = 0; i < 12; ++i) {
      const double s = 4.0 * i / 11.0;
      const Point2 q = s < 2 ? Point2(s, 0) : (s < 3 ? Point2(2, s - 2) : Point2(s - 1, 1));
      noisy.push_back(q + Point2(noise(prng), noise(prng)));
    }
    const double one = ComputeEvolvedSimilarity(noisy, model, {1}).value;
    const double three = ComputeEvolvedSimilarity(noisy, model, {3}).value;
    EXPECT_LE(three, one + 1e-12);
    differing += three < one - 1e-12 ? 1 : 0;
  }
  EXPECT_GT(differing, 10);
  EXPECT_THROW(ComputeEvolvedSimilarity(model, model, {0}), std::invalid_argument);
}

// S* as §4.1 states it, the evolution copied and continued for each lookahead: the reference the
// prepared stages' walk is checked against.
EvolvedSimilarity ReferenceEvolvedSimilarity(const Polyline& perceived, const Polyline& model,
                                             int lookahead) {
  EvolvedSimilarity best;
  best.value = PolylineSimilarity(perceived, model).value;
  best.evolved_c = perceived;
  CurveEvolution evolution(perceived);
  for (bool improved = true; improved;) {
    improved = false;
    CurveEvolution trial = evolution;
    for (int k = 1; k <= lookahead && trial.CanRemove(); ++k) {
      trial.RemoveNext();
      const Polyline candidate = trial.Current();
      const double value = PolylineSimilarity(candidate, model).value;
      if (value < best.value) {
        best.value = value;
        best.evolved_c = candidate;
        best.removed_vertices += k;
        evolution = trial;
        improved = true;
        break;
      }
    }
  }
  return best;
}

// The matcher's prepared path (internal/prepared_shape.h: each polyline's arcs and DCE stages
// made once), which ComputeEvolvedSimilarity walks too, gives S and S* of the reference to the
// bit, whatever the lookahead, and one prepared perceived polyline serves several models in any
// order.
TEST(EvolvedSimilarityTest, PreparedShapesGiveTheSameValuesToTheBit) {
  std::mt19937 prng(11);
  std::uniform_int_distribution<int> length(1, 18);
  std::normal_distribution<double> step(0.0, 0.6), noise(0.0, 0.05);
  const auto walk = [&](int n) {
    Polyline p = {{0.0, 0.0}};
    for (int i = 1; i < n; ++i) p.push_back(p.back() + Point2(0.5 + std::abs(step(prng)), step(prng)));
    for (Point2& q : p) q += Point2(noise(prng), noise(prng));
    return p;
  };
  std::vector<double> dp;
  int evolved = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const Polyline perceived = walk(length(prng));
    internal::EvolutionStages stages(perceived);
    for (int m = 0; m < 3; ++m) {
      const Polyline model = walk(length(prng));
      const internal::PreparedShape prepared(model);
      EXPECT_EQ(internal::SimilarityValue(*stages.Stage(0), prepared, dp),
                PolylineSimilarity(perceived, model).value);
      for (int lookahead : {1, 2, 3}) {
        const EvolvedSimilarity expected = ComputeEvolvedSimilarity(perceived, model, {lookahead});
        EXPECT_EQ(internal::EvolvedSimilarityValue(stages, prepared, {lookahead}, dp), expected.value)
            << "trial " << trial << " model " << m << " lookahead " << lookahead;
        const EvolvedSimilarity reference = ReferenceEvolvedSimilarity(perceived, model, lookahead);
        EXPECT_EQ(expected.value, reference.value);
        EXPECT_EQ(expected.removed_vertices, reference.removed_vertices);
        EXPECT_EQ(expected.evolved_c, reference.evolved_c);
        EXPECT_EQ(expected.best.value, expected.value);
        evolved += expected.removed_vertices > 0 ? 1 : 0;
      }
    }
  }
  EXPECT_GT(evolved, 20);  // the walk over the stages was exercised
  EXPECT_THROW(internal::EvolutionStages(Polyline{}), std::invalid_argument);
}

TEST(ShapeComplexityTest, HandValuesAndReliability) {
  EXPECT_DOUBLE_EQ(ShapeComplexity({{0, 0}, {4, 0}}), 2.0);  // half the end-point distance
  EXPECT_NEAR(ShapeComplexity({{0, 0}, {1, 0}, {1, 1}}), 2.0 - std::sqrt(2.0), 1e-15);
  EXPECT_DOUBLE_EQ(ShapeComplexity({{1, 1}}), 0.0);
  EXPECT_NEAR(Reliability({{0, 0}, {4, 0}}, {{0, 0}, {1, 0}, {1, 1}}, 0.25),
              2.0 + 2.0 - std::sqrt(2.0) - 0.25, 1e-12);
}

TEST(PolylineSimilarityTest, DegenerateInput) {
  EXPECT_THROW(PolylineSimilarity({}, {{0, 0}, {1, 0}}), std::invalid_argument);
  EXPECT_THROW(ComputeEvolvedSimilarity({{0, 0}}, {}), std::invalid_argument);
  const double point = PolylineSimilarity({{1, 1}}, {{0, 0}, {1, 0}}).value;
  EXPECT_TRUE(std::isfinite(point));
  const Polyline dup = {{0, 0}, {0, 0}, {1, 0}, {1, 0}, {1, 1}};
  EXPECT_TRUE(std::isfinite(ComputeEvolvedSimilarity(dup, dup).value));
  const Polyline far = Transform(Pose2(1e6, -1e6, 0.3), {{0, 0}, {1, 0}, {1, 1}});
  EXPECT_NEAR(PolylineSimilarity(far, {{0, 0}, {1, 0}, {1, 1}}).value, 0.0, 1e-6);
}

}  // namespace
}  // namespace shape_slam
