#include "shape_slam/alignment.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "core/alignment_scenes.h"
#include "core/pose_matchers.h"
#include "shape_slam/geometry.h"

namespace shape_slam {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr double kDeg = M_PI / 180.0;
const Pose2 kTruth(1.0, 0.5, 0.2);  // T_map_scan of the simulated scans

// Runs `call` and returns the message of the std::invalid_argument it must throw.
std::string InvalidArgumentMessage(const std::function<void()>& call) {
  try {
    call();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "no std::invalid_argument thrown";
  return "";
}

// ---------------------------------------------------------------------------------------------
// SamplePolyline

TEST(SamplePolylineTest, SamplesEverySpacingWithBothEnds) {
  const std::vector<Point2> samples = SamplePolyline({{0.0, 0.0}, {1.05, 0.0}}, 0.1);
  ASSERT_EQ(samples.size(), 12u);  // 0, 0.1, ..., 1.0 and the end 1.05
  for (int k = 0; k <= 10; ++k) {
    EXPECT_NEAR(samples[k].x(), 0.1 * k, 1e-12);
    EXPECT_EQ(samples[k].y(), 0.0);
  }
  EXPECT_EQ(samples.back(), Point2(1.05, 0.0));
}

TEST(SamplePolylineTest, EndFallingOnTheGridIsNotDuplicated) {
  const std::vector<Point2> samples = SamplePolyline({{0.0, 0.0}, {0.5, 0.0}, {0.5, 0.5}}, 0.1);
  ASSERT_EQ(samples.size(), 11u);
  EXPECT_EQ(samples.front(), Point2(0.0, 0.0));
  EXPECT_EQ(samples.back(), Point2(0.5, 0.5));
  for (std::size_t i = 1; i < samples.size(); ++i) {
    EXPECT_NEAR((samples[i] - samples[i - 1]).norm(), 0.1, 1e-12);  // straight runs here
  }
}

TEST(SamplePolylineTest, ShortSegmentGetsItsMidpoint) {
  // Regular samples at arc 1.0 (first segment) and 1.1 (third segment) skip the 3 cm segment.
  const Polyline polyline = {{0.0, 0.0}, {1.05, 0.0}, {1.05, 0.03}, {2.0, 0.03}};
  const std::vector<Point2> samples = SamplePolyline(polyline, 0.1);
  int on_short_segment = 0;
  for (const Point2& p : samples) {
    if (SquaredDistanceToSegment(p, polyline[1], polyline[2]) < 1e-20) ++on_short_segment;
  }
  EXPECT_EQ(on_short_segment, 1);
  EXPECT_THAT(samples, ::testing::Contains(Point2(1.05, 0.015)));
}

// Invariants on random polylines: on the polyline, in arc order, no gap longer than the
// spacing, ends included, and a sample on every segment.
TEST(SamplePolylineTest, InvariantsOnRandomPolylines) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> coordinate(-2.0, 2.0);
  std::uniform_int_distribution<int> size(2, 12);
  for (int trial = 0; trial < 200; ++trial) {
    Polyline polyline(size(prng));
    for (Point2& p : polyline) p = {coordinate(prng), coordinate(prng)};
    if (trial % 3 == 0) polyline[1] = polyline[0] + Point2(0.01, 0.0);  // a short segment
    const double spacing = 0.05 + 0.3 * (trial % 5);
    const std::vector<Point2> samples = SamplePolyline(polyline, spacing);
    ASSERT_GE(samples.size(), 2u);
    EXPECT_EQ(samples.front(), polyline.front());
    EXPECT_EQ(samples.back(), polyline.back());
    double previous_arc = -1.0;
    for (const Point2& p : samples) {
      const PolylineProjection projection = ProjectOntoPolyline(p, polyline);
      EXPECT_LT(projection.squared_distance, 1e-18);
      // Arc position of the sample (first segment it lies on).
      double arc = 0.0;
      for (std::size_t i = 0; i < projection.segment; ++i)
        arc += (polyline[i + 1] - polyline[i]).norm();
      arc +=
          projection.t * (polyline[projection.segment + 1] - polyline[projection.segment]).norm();
      EXPECT_GE(arc, previous_arc - 1e-9);
      if (previous_arc >= 0.0) {
        EXPECT_LE(arc - previous_arc, spacing + 1e-9);
      }
      previous_arc = arc;
    }
    for (std::size_t i = 0; i + 1 < polyline.size(); ++i) {
      int count = 0;
      for (const Point2& p : samples) {
        if (SquaredDistanceToSegment(p, polyline[i], polyline[i + 1]) < 1e-18) ++count;
      }
      EXPECT_GE(count, 1) << "segment " << i << " of trial " << trial;
    }
  }
}

TEST(SamplePolylineTest, DegeneratePolylines) {
  EXPECT_TRUE(SamplePolyline({}, 0.1).empty());
  EXPECT_THAT(SamplePolyline({{1.0, 2.0}}, 0.1), ::testing::ElementsAre(Point2(1.0, 2.0)));
  EXPECT_THAT(SamplePolyline({{1.0, 2.0}, {1.0, 2.0}, {1.0, 2.0}}, 0.1),
              ::testing::ElementsAre(Point2(1.0, 2.0)));
  // A zero-length segment adds no sample of its own: the same samples as without it.
  EXPECT_EQ(SamplePolyline({{0.0, 0.0}, {0.35, 0.0}, {0.35, 0.0}, {0.35, 0.42}}, 0.1),
            SamplePolyline({{0.0, 0.0}, {0.35, 0.0}, {0.35, 0.42}}, 0.1));
}

TEST(SamplePolylineTest, RejectsBadInput) {
  const Polyline line = {{0.0, 0.0}, {1.0, 0.0}};
  for (const double spacing : {0.0, -0.1, std::numeric_limits<double>::quiet_NaN(),
                               std::numeric_limits<double>::infinity()}) {
    EXPECT_THAT(InvalidArgumentMessage([&] { SamplePolyline(line, spacing); }),
                HasSubstr("spacing_m"));
  }
  EXPECT_THROW(SamplePolyline({{0.0, 0.0}, {std::nan(""), 1.0}}, 0.1), std::invalid_argument);
  EXPECT_THROW(SamplePolyline({{0.0, 0.0}, {1e6, 0.0}}, 1e-6), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// AlignShapes: pose recovery

// From random starts up to 0.5 m / 15 deg off, with correct pairs and 1 cm noise, the ICP
// recovers the pose within 1 cm / 0.2 deg.
void ExpectRecoveryFromPerturbedStarts(const std::vector<Polyline>& scene) {
  std::mt19937 prng(42);
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  for (int trial = 0; trial < 30; ++trial) {
    const Pose2 init = test::Perturb(kTruth, 0.5, 15.0 * kDeg, prng);
    const AlignmentResult result = AlignShapes(pairs, init);
    EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 0.01, 0.2 * kDeg))
        << "from " << init.x << ", " << init.y << ", " << init.theta;
    EXPECT_TRUE(result.converged);
    EXPECT_GT(result.num_correspondences, 0);
    EXPECT_LT(result.rms_error_m, 0.015);  // about the 1 cm noise
  }
}

TEST(AlignShapesTest, RecoversLCorner) { ExpectRecoveryFromPerturbedStarts(test::LCornerScene()); }

TEST(AlignShapesTest, RecoversRoomWithPillar) {
  ExpectRecoveryFromPerturbedStarts(test::RoomWithPillarScene());
}

TEST(AlignShapesTest, RecoversCorridorWithDoors) {
  ExpectRecoveryFromPerturbedStarts(test::CorridorWithDoorsScene());
}

TEST(AlignShapesTest, NoiseFreeDataAtTheTruthStaysThere) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(scene, kTruth, 0.0, prng), scene);
  const AlignmentResult result = AlignShapes(pairs, kTruth);
  EXPECT_TRUE(result.converged);
  EXPECT_LE(result.iterations, 3);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 1e-9, 1e-10));
  EXPECT_LT(result.rms_error_m, 1e-9);
}

// Only part of the model walls is seen: the perceived room polyline covers half of the model's
// (the right half of the room); the pillar is seen whole.
TEST(AlignShapesTest, PartialPerceptionOfTheModel) {
  std::mt19937 prng(42);
  const std::vector<Polyline> model = test::RoomWithPillarScene();
  const std::vector<Polyline> seen = {{{0.5, -3.0}, {5.0, -3.0}, {5.0, 4.0}, {0.5, 4.0}}, model[1]};
  ASSERT_LT(PolylineLength(seen[0]), 0.6 * PolylineLength(model[0]));
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(seen, kTruth, 0.01, prng), model);
  for (int trial = 0; trial < 10; ++trial) {
    const Pose2 init = test::Perturb(kTruth, 0.5, 15.0 * kDeg, prng);
    EXPECT_THAT(AlignShapes(pairs, init).T_map_scan, IsNearly(kTruth, 0.01, 0.2 * kDeg));
  }
}

// The map knows only part of what the scan sees: samples beyond the map polyline's ends are
// ignored; if they were used they would pull the scan back towards the known part (shown with
// a fixed 1 m gate; the shrinking gate alone would cut most of them at the end).
TEST(AlignShapesTest, SamplesBeyondTheModelsEndsDoNotPull) {
  std::mt19937 prng(42);
  const std::vector<Polyline> model = {{{6.0, 0.5}, {6.0, 3.0}, {3.5, 3.0}}};
  const std::vector<Polyline> seen = test::LCornerScene();
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(seen, kTruth, 0.01, prng), model);
  const Pose2 init(kTruth.x + 0.2, kTruth.y - 0.1, kTruth.theta + 3.0 * kDeg);
  AlignmentParams fixed_gate;
  fixed_gate.min_correspondence_distance_m = fixed_gate.max_correspondence_distance_m;
  EXPECT_THAT(AlignShapes(pairs, init, fixed_gate).T_map_scan, IsNearly(kTruth, 0.01, 0.2 * kDeg));
  AlignmentParams keep_ends = fixed_gate;
  keep_ends.reject_end_projections = false;
  EXPECT_THAT(AlignShapes(pairs, init, keep_ends).T_map_scan,
              Not(IsNearly(kTruth, 0.1, 1.0 * kDeg)));
}

// §5.1: samples only match their own pair's polylines, even when another polyline is nearer.
TEST(AlignShapesTest, CorrespondencesAreRestrictedToThePair) {
  std::mt19937 prng(42);
  const Polyline far_wall = {{6.0, -2.0}, {6.0, 3.0}, {1.0, 3.0}};
  const Polyline near_wall = {{5.6, -2.0}, {5.6, 2.6}, {1.0, 2.6}};  // 0.4 m closer
  const Polyline perceived = test::Perceive({far_wall}, kTruth, 0.01, prng)[0];
  const Pose2 init(kTruth.x - 0.35, kTruth.y - 0.35, kTruth.theta);  // next to the near wall
  EXPECT_THAT(AlignShapes({{perceived, {far_wall}, 1.0}}, init).T_map_scan,
              IsNearly(kTruth, 0.01, 0.2 * kDeg));
  // Offered both walls, proximity wins: the scan snaps to the near wall.
  EXPECT_THAT(AlignShapes({{perceived, {far_wall, near_wall}, 1.0}}, init).T_map_scan,
              IsNearly(Pose2(kTruth.x - 0.4, kTruth.y - 0.4, kTruth.theta), 0.01, 0.2 * kDeg));
}

// A wrongly matched pair whose model lies beyond the gate is ignored (trimming).
TEST(AlignShapesTest, PairsBeyondTheGateAreIgnored) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  std::vector<ShapePair> pairs = test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  const AlignmentResult clean = AlignShapes(pairs, kTruth);
  pairs.push_back({pairs[1].perceived, {{{-10.0, 8.0}, {-9.0, 8.0}}}, 1.0});
  const Pose2 init(kTruth.x + 0.3, kTruth.y - 0.2, kTruth.theta - 5.0 * kDeg);
  const AlignmentResult result = AlignShapes(pairs, init);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 0.01, 0.2 * kDeg));
  EXPECT_EQ(result.num_correspondences, clean.num_correspondences);
}

// Weights: a pair of weight 0 has no influence; a wrong pair within the gate biases the fit less
// when its weight is small.
TEST(AlignShapesTest, PairWeights) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  std::vector<ShapePair> pairs = test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  const Pose2 init(kTruth.x + 0.1, kTruth.y + 0.1, kTruth.theta);
  const AlignmentResult clean = AlignShapes(pairs, init);
  // The pillar wrongly matched with a copy of itself 0.3 m away.
  pairs.push_back({pairs[1].perceived, {Transform(Pose2(0.3, 0.0, 0.0), scene[1])}, 0.0});
  const AlignmentResult ignored = AlignShapes(pairs, init);
  EXPECT_EQ(ignored.T_map_scan.x, clean.T_map_scan.x);
  EXPECT_EQ(ignored.T_map_scan.y, clean.T_map_scan.y);
  EXPECT_EQ(ignored.T_map_scan.theta, clean.T_map_scan.theta);
  pairs.back().weight = 20.0;
  const double heavy = std::abs(AlignShapes(pairs, init).T_map_scan.x - kTruth.x);
  pairs.back().weight = 0.5;
  const double light = std::abs(AlignShapes(pairs, init).T_map_scan.x - kTruth.x);
  EXPECT_GT(heavy, 2.0 * light);
}

// ---------------------------------------------------------------------------------------------
// AlignShapes: degenerate input

TEST(AlignShapesTest, NothingToAlignIsNotConverged) {
  const Pose2 init(1.0, 2.0, 0.3);
  for (const std::vector<ShapePair>& pairs :
       {std::vector<ShapePair>{}, std::vector<ShapePair>{{{{0.0, 0.0}, {1.0, 0.0}}, {}, 1.0}},
        std::vector<ShapePair>{{{}, {{{0.0, 0.0}, {1.0, 0.0}}}, 1.0}},
        std::vector<ShapePair>{{{{0.0, 0.0}, {1.0, 0.0}}, {{}}, 1.0}}}) {
    const AlignmentResult result = AlignShapes(pairs, init);
    EXPECT_FALSE(result.converged);
    EXPECT_EQ(result.iterations, 0);
    EXPECT_EQ(result.num_correspondences, 0);
    EXPECT_THAT(result.T_map_scan, IsNearly(init, 0.0, 0.0));
  }
}

// Single-vertex polylines are points: three matched points fix the pose exactly.
TEST(AlignShapesTest, OnePointPolylines) {
  const std::vector<Point2> model = {{3.0, 1.0}, {4.0, -2.0}, {-1.0, 2.5}};
  std::vector<ShapePair> pairs;
  for (const Point2& m : model) pairs.push_back({{kTruth.Inverse() * m}, {{m}}, 1.0});
  const AlignmentResult result = AlignShapes(pairs, Pose2(kTruth.x + 0.3, kTruth.y, 0.1));
  EXPECT_TRUE(result.converged);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 1e-6, 1e-6));
  // A single point only moves the translation.
  const AlignmentResult one = AlignShapes({pairs[0]}, Pose2(kTruth.x + 0.3, kTruth.y, 0.1));
  EXPECT_DOUBLE_EQ(one.T_map_scan.theta, 0.1);
  EXPECT_LT((one.T_map_scan * pairs[0].perceived[0] - model[0]).norm(), 1e-9);
}

TEST(AlignShapesTest, ZeroLengthSegments) {
  std::mt19937 prng(42);
  std::vector<Polyline> scene = test::LCornerScene();
  std::vector<ShapePair> pairs = test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  // Repeat vertices in both the model and the perception.
  pairs[0].model[0] = {scene[0][0], scene[0][0], scene[0][1],
                       scene[0][1], scene[0][2], scene[0][2]};
  Polyline& perceived = pairs[0].perceived;
  perceived.insert(perceived.begin() + 10, perceived[10]);
  perceived.push_back(perceived.back());
  const AlignmentResult result = AlignShapes(pairs, test::Perturb(kTruth, 0.3, 0.1, prng));
  EXPECT_TRUE(result.converged);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 0.01, 0.2 * kDeg));
}

TEST(AlignShapesTest, HugeCoordinates) {
  std::mt19937 prng(42);
  const Pose2 far(1e6, -2e6, 0.0);
  std::vector<Polyline> scene;
  for (const Polyline& polyline : test::RoomWithPillarScene())
    scene.push_back(Transform(far, polyline));
  const Pose2 truth = far * kTruth;
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(scene, truth, 0.01, prng), scene);
  for (int trial = 0; trial < 5; ++trial) {
    const AlignmentResult result = AlignShapes(pairs, test::Perturb(truth, 0.5, 15.0 * kDeg, prng));
    EXPECT_TRUE(result.converged);
    EXPECT_THAT(result.T_map_scan, IsNearly(truth, 0.01, 0.2 * kDeg));
  }
}

// ---------------------------------------------------------------------------------------------
// Invalid input

TEST(AlignmentParamsTest, ValidateNamesTheField) {
  const auto message = [](const std::function<void(AlignmentParams&)>& change) {
    AlignmentParams params;
    change(params);
    return InvalidArgumentMessage([&] { params.Validate(); });
  };
  EXPECT_NO_THROW(AlignmentParams{}.Validate());
  EXPECT_THAT(message([](auto& p) { p.sample_spacing_m = 0.0; }), HasSubstr("sample_spacing_m"));
  EXPECT_THAT(message([](auto& p) { p.max_iterations = 0; }), HasSubstr("max_iterations"));
  EXPECT_THAT(message([](auto& p) { p.convergence_translation_m = -1.0; }),
              HasSubstr("convergence_translation_m"));
  EXPECT_THAT(message([](auto& p) { p.convergence_rotation_rad = std::nan(""); }),
              HasSubstr("convergence_rotation_rad"));
  EXPECT_THAT(message([](auto& p) { p.max_correspondence_distance_m = 0.0; }),
              HasSubstr("max_correspondence_distance_m"));
  EXPECT_THAT(message([](auto& p) { p.min_correspondence_distance_m = 2.0; }),
              HasSubstr("min_correspondence_distance_m"));
}

TEST(AlignShapesTest, RejectsInvalidInput) {
  const Polyline line = {{0.0, 0.0}, {1.0, 0.0}};
  EXPECT_THAT(InvalidArgumentMessage([&] {
                AlignShapes({{line, {line}, -1.0}}, Pose2());
              }),
              HasSubstr("weight"));
  EXPECT_THAT(InvalidArgumentMessage([&] {
                AlignShapes({{line, {line}, std::nan("")}}, Pose2());
              }),
              HasSubstr("weight"));
  EXPECT_THROW(AlignShapes({{line, {{{0.0, std::nan("")}}}, 1.0}}, Pose2()), std::invalid_argument);
  EXPECT_THROW(AlignShapes({{line, {line}, 1.0}}, Pose2(0.0, std::nan(""), 0.0)),
               std::invalid_argument);
  AlignmentParams params;
  params.max_iterations = 0;
  EXPECT_THROW(AlignShapes({}, Pose2(), params), std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
