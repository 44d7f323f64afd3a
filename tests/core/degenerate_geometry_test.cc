// Degenerate geometry through every core stage: duplicate points, zero-length segments, all
// points collinear, one- and two-point polylines, huge coordinates. Each stage must return a
// finite, sensible result or throw its documented std::invalid_argument; never crash, hang or
// produce NaN.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "shape_slam/alignment.h"
#include "shape_slam/alignment_refinement.h"
#include "shape_slam/discrete_curve_evolution.h"
#include "shape_slam/map_update.h"
#include "shape_slam/pipeline.h"
#include "shape_slam/polyline_extraction.h"
#include "shape_slam/polyline_map.h"
#include "shape_slam/scan_matcher.h"
#include "shape_slam/shape_matcher.h"
#include "shape_slam/shape_similarity.h"
#include "shape_slam/tangent_space.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

std::vector<Polyline> DegeneratePolylines() {
  const double big = 1e7;  // 10 000 km from the origin
  return {
      {{1.0, 2.0}},                                           // one point
      {{1.0, 2.0}, {1.0, 2.0}},                               // two equal points
      {{0.0, 0.0}, {0.0, 0.0}, {0.0, 0.0}, {0.0, 0.0}},       // all the same
      {{0.0, 0.0}, {1.0, 0.0}, {1.0, 0.0}, {2.0, 0.0}},       // zero-length segment
      {{0.0, 0.0}, {1.0, 0.0}, {2.0, 0.0}, {3.0, 0.0}},       // collinear
      {{0.0, 0.0}, {2.0, 0.0}, {1.0, 0.0}, {3.0, 0.0}},       // collinear, doubling back
      {{big, big}, {big + 1.0, big}, {big + 1.0, big + 1.0}}, // huge coordinates
      {{0.0, 0.0}, {1e-12, 0.0}, {1.0, 1e-12}},               // nearly zero lengths
  };
}

bool Finite(const Polyline& p) {
  for (const Point2& v : p) {
    if (!v.allFinite()) return false;
  }
  return true;
}

TEST(DegenerateGeometryTest, DceKeepsEndPointsAndStaysFinite) {
  for (const Polyline& p : DegeneratePolylines()) {
    for (const Polyline& s : {SimplifyDce(p, 0.05), SimplifyDceBounded(p, 0.05, 0.02)}) {
      EXPECT_TRUE(Finite(s));
      EXPECT_LE(s.size(), p.size());
      ASSERT_FALSE(s.empty());
      EXPECT_EQ(s.front(), p.front());
      EXPECT_EQ(s.back(), p.back());
    }
  }
}

TEST(DegenerateGeometryTest, TangentSpaceAndSimilarityStayFinite) {
  const std::vector<Polyline> all = DegeneratePolylines();
  for (const Polyline& p : all) {
    EXPECT_NO_FATAL_FAILURE(ComputeTurningFunction(p));
    EXPECT_NO_FATAL_FAILURE(MaximalArcs(p));
    EXPECT_TRUE(std::isfinite(ShapeComplexity(p)));
    for (const Polyline& q : all) {
      const double s = PolylineSimilarity(p, q).value;
      EXPECT_TRUE(std::isfinite(s)) << p.size() << " vs " << q.size();
      EXPECT_GE(s, 0.0);
      const EvolvedSimilarity e = ComputeEvolvedSimilarity(p, q);
      EXPECT_TRUE(std::isfinite(e.value));
      EXPECT_LE(e.value, s + 1e-12);  // S* is never worse than S
      EXPECT_TRUE(std::isfinite(Reliability(p, q, e.value)));
    }
  }
  EXPECT_THROW(ComputeEvolvedSimilarity({}, {{0, 0}, {1, 0}}), std::invalid_argument);
}

TEST(DegenerateGeometryTest, MatchingAndAlignmentOfDegenerateShapes) {
  const std::vector<Polyline> all = DegeneratePolylines();
  ShapeMatchInput input;
  input.scan = all;
  input.model = all;
  for (const std::optional<Pose2>& guess : {std::optional<Pose2>(), std::optional<Pose2>(Pose2())}) {
    const ShapeMatchResult m = MatchShapes(input, guess);
    EXPECT_TRUE(std::isfinite(m.T_model_scan.x) && std::isfinite(m.T_model_scan.theta));
  }
  std::vector<ShapePair> pairs;
  for (const Polyline& p : all) pairs.push_back({p, {p}, 1.0});
  const AlignmentResult a = AlignShapes(pairs, Pose2(0.1, 0.0, 0.05));
  EXPECT_TRUE(std::isfinite(a.T_map_scan.x) && std::isfinite(a.T_map_scan.theta));
  std::vector<Point2> samples;
  for (const Polyline& p : all) {
    for (const Point2& s : SamplePolyline(p, 0.1)) samples.push_back(s);
  }
  const RefinementResult r = RefineAlignment(samples, all, Pose2(), std::nullopt);
  EXPECT_TRUE(std::isfinite(r.T_map_scan.x) && r.covariance.allFinite());
}

TEST(DegenerateGeometryTest, MapUpdateWithDegeneratePolylines) {
  PolylineMap map;
  std::mt19937 prng(1);
  const LaserScan scan =
      testing::SimulateScan(testing::OfficeRoom(), Pose2(2, 2, 0), testing::ScannerModel{}, prng);
  for (int round = 0; round < 3; ++round) {
    const std::vector<VisiblePolyline> visible = map.Visible(Pose2(), VisibilityParams{});
    UpdateMap(map, DegeneratePolylines(), Pose2(), visible, scan, true, MapUpdateParams{});
  }
  for (const PolylineId id : map.Ids()) {
    EXPECT_TRUE(Finite(map.Get(id).points));
    EXPECT_GE(map.Get(id).points.size(), 2u);
  }
}

TEST(DegenerateGeometryTest, ScansOfOnePointLineOrFarAway) {
  LaserScan scan;
  scan.max_range_m = 80.0;
  for (int i = 0; i < 181; ++i) {
    scan.angles_rad.push_back(-M_PI / 2 + i * M_PI / 180);
    scan.ranges_m.push_back(std::nan(""));
  }
  LaserScan one = scan;
  one.ranges_m[90] = 2.0;  // a single valid reading
  LaserScan line = scan;   // a single straight wall: collinear points only
  for (int i = 60; i < 120; ++i) line.ranges_m[i] = 2.0 / std::cos(line.angles_rad[i]);
  LaserScan same = scan;  // every reading identical (a scanner looking at a circle)
  for (double& r : same.ranges_m) r = 3.0;
  for (const LaserScan* s : {&scan, &one, &line, &same}) {
    for (const Polyline& p : ExtractPolylines(*s, ExtractionParams{})) EXPECT_TRUE(Finite(p));
    const ScanMatchResult m = MatchScans(*s, *s, std::nullopt);
    EXPECT_TRUE(std::isfinite(m.T_i_j.x) && std::isfinite(m.T_i_j.theta));
  }
  // The mapper with far-away odometry poses (huge coordinates).
  ShapeSlam slam;
  for (int k = 0; k < 5; ++k) {
    LaserScan s = line;
    s.timestamp_s = k;
    s.T_odom_robot = Pose2(1e7 + 0.1 * k, -1e7, 0.0);
    const ScanReport report = slam.Process(s);
    EXPECT_TRUE(std::isfinite(report.T_map_robot.x) && std::isfinite(report.T_map_robot.theta));
  }
}

}  // namespace
}  // namespace shape_slam
