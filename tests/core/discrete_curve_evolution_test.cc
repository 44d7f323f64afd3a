#include "shape_slam/discrete_curve_evolution.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/test_scenes.h"
#include "shape_slam/geometry.h"
#include "shape_slam/polyline_extraction.h"

namespace shape_slam {
namespace {

TEST(RelevanceTest, HandValues) {
  EXPECT_DOUBLE_EQ(Relevance({0, 0}, {1, 0}, {2, 0}), 0.0);  // collinear vertex
  EXPECT_NEAR(Relevance({0, 0}, {1, 0}, {1, 1}), 2.0 - std::sqrt(2.0), 1e-15);  // right angle
  EXPECT_NEAR(Relevance({0, 0}, {1, 1}, {2, 0}), 2.0 * std::sqrt(2.0) - 2.0, 1e-15);
  EXPECT_DOUBLE_EQ(Relevance({0, 0}, {0, 0}, {1, 0}), 0.0);  // duplicate point
}

Polyline RandomPolyline(std::mt19937& prng, int n, bool on_grid) {
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::uniform_int_distribution<int> g(-3, 3);
  Polyline p;
  for (int i = 0; i < n; ++i) {
    if (on_grid) {
      p.emplace_back(g(prng), g(prng));  // many ties and duplicates
    } else {
      p.emplace_back(i * 0.2 + 0.05 * u(prng), 0.05 * u(prng));
    }
  }
  return p;
}

TEST(DiscreteCurveEvolutionTest, FastEqualsNaiveOracle) {
  std::mt19937 prng(42);
  for (int trial = 0; trial < 400; ++trial) {
    const Polyline p = RandomPolyline(prng, 2 + trial % 40, trial % 3 == 0);
    for (const double threshold : {0.0, 0.01, 0.05, 0.5, 100.0}) {
      const Polyline fast = SimplifyDce(p, threshold);
      const Polyline naive = SimplifyDceNaive(p, threshold);
      ASSERT_EQ(fast.size(), naive.size()) << "trial " << trial << " threshold " << threshold;
      for (std::size_t i = 0; i < fast.size(); ++i) ASSERT_EQ(fast[i], naive[i]);
    }
  }
}

TEST(DiscreteCurveEvolutionTest, KeepsEndPointsAndNeverAddsVertices) {
  std::mt19937 prng(42);
  for (int trial = 0; trial < 200; ++trial) {
    const Polyline p = RandomPolyline(prng, 2 + trial % 30, trial % 2 == 0);
    const Polyline q = SimplifyDce(p, 0.05);
    ASSERT_LE(q.size(), p.size());
    ASSERT_GE(q.size(), 2u);
    EXPECT_EQ(q.front(), p.front());
    EXPECT_EQ(q.back(), p.back());
    // Every kept vertex is an original vertex, in order.
    std::size_t j = 0;
    for (const Point2& v : q) {
      while (j < p.size() && p[j] != v) ++j;
      ASSERT_LT(j, p.size());
    }
  }
  EXPECT_TRUE(SimplifyDce({}, 0.1).empty());
  EXPECT_EQ(SimplifyDce({{1, 1}}, 0.1).size(), 1u);
  EXPECT_THROW(SimplifyDce({{0, 0}, {1, 0}}, -1.0), std::invalid_argument);
}

TEST(DiscreteCurveEvolutionTest, BoundedVersionStaysNearTheOriginal) {
  // A gentle 0.2 m bow over 6 m: plain DCE flattens it, the bounded one keeps it within 3 cm.
  Polyline bow;
  for (int i = 0; i <= 60; ++i) {
    const double x = 0.1 * i;
    bow.emplace_back(x, 0.2 * std::sin(M_PI * x / 6.0));
  }
  EXPECT_EQ(SimplifyDce(bow, 0.03).size(), 2u);
  const Polyline bounded = SimplifyDceBounded(bow, 0.03, 0.03);
  EXPECT_GT(bounded.size(), 2u);
  for (const Point2& p : bow) {
    EXPECT_LE(std::sqrt(ProjectOntoPolyline(p, bounded).squared_distance), 0.03 + 1e-12);
  }
}

TEST(DiscreteCurveEvolutionTest, IncrementalEvolutionFollowsTheRemovalOrder) {
  const Polyline p = {{0, 0}, {1, 0.001}, {2, 0}, {3, 1}, {4, 1}};
  CurveEvolution evolution(p);
  EXPECT_EQ(evolution.NumVertices(), 5);
  EXPECT_NEAR(evolution.NextRelevance(), Relevance(p[0], p[1], p[2]), 1e-15);
  evolution.RemoveNext();
  EXPECT_EQ(evolution.Current(), Polyline({{0, 0}, {2, 0}, {3, 1}, {4, 1}}));
  EXPECT_EQ(evolution.CurrentIndices(), std::vector<int>({0, 2, 3, 4}));
  while (evolution.CanRemove()) evolution.RemoveNext();
  EXPECT_EQ(evolution.Current(), Polyline({{0, 0}, {4, 1}}));
  EXPECT_THROW(evolution.RemoveNext(), std::logic_error);
}

// The acceptance test of the issue: a room scanned with 1 cm range noise keeps one vertex at
// each visible corner (an original scan point next to it) and none on straight walls, at the
// default threshold.
void ExpectCornersOnly(const testing::ScannerModel& model, const Pose2& T_world_sensor,
                       unsigned seed) {
  std::mt19937 prng(seed);
  const testing::Scene room = testing::Room(0, 0, 6, 4);
  const std::vector<Point2> corners = {{0, 0}, {6, 0}, {6, 4}, {0, 4}};
  const LaserScan scan = testing::SimulateScan(room, T_world_sensor, model, prng);
  const std::vector<Polyline> raw = ExtractPolylines(scan, ExtractionParams{});
  ASSERT_FALSE(raw.empty());
  std::vector<int> hits(corners.size(), 0);
  for (const Polyline& polyline : raw) {
    const Polyline simplified = SimplifyDce(polyline, DceParams{}.threshold_m);
    for (std::size_t i = 1; i + 1 < simplified.size(); ++i) {
      const Point2 w = T_world_sensor * simplified[i];
      int nearest = -1;
      for (std::size_t c = 0; c < corners.size(); ++c) {
        // Within two beam spacings of the corner (at its range).
        const double spacing = 2.0 * (corners[c] - T_world_sensor.Translation()).norm() *
                               model.fov_rad / model.beams;
        if ((w - corners[c]).norm() <= spacing + 0.03) nearest = static_cast<int>(c);
      }
      ASSERT_GE(nearest, 0) << "vertex on a straight wall at (" << w.x() << ", " << w.y() << ")";
      ++hits[nearest];
      // It is an original scan point.
      EXPECT_NE(std::find(polyline.begin(), polyline.end(), simplified[i]), polyline.end());
    }
  }
  // Every corner seen inside one polyline (scan points on both of its walls; at a grazing
  // angle the points can be split apart at the corner) keeps exactly one vertex.
  for (std::size_t c = 0; c < corners.size(); ++c) {
    bool inside = false;
    for (const Polyline& polyline : raw) {
      for (std::size_t i = 3; i + 3 < polyline.size(); ++i) {
        inside |= ((T_world_sensor * polyline[i]) - corners[c]).norm() < 0.05;
      }
    }
    if (inside) {
      EXPECT_EQ(hits[c], 1) << "corner " << c << " seed " << seed;
    }
  }
}

TEST(DiscreteCurveEvolutionTest, NoisyRoomKeepsExactlyTheCorners) {
  for (unsigned seed = 1; seed <= 8; ++seed) {
    testing::ScannerModel full{361, 2.0 * M_PI, 30.0, 0.01};
    ExpectCornersOnly(full, Pose2(2.2, 1.6, 0.3), seed);
    testing::ScannerModel half{181, M_PI, 30.0, 0.01};
    ExpectCornersOnly(half, Pose2(1.5, 1.2, 0.6), seed);
  }
}

}  // namespace
}  // namespace shape_slam
