// The registration blocks (internal/registration.h) against brute force on small cases: for a
// scan simulated in a known scene, the refinement from an estimate off by decimetres and degrees
// lands on the pose that an exhaustive search over a pose grid finds best for the same robust
// point-to-line cost (§5.1), and that pose is the true one within the scan noise.
#include "shape_slam/internal/registration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "pose_matchers.h"
#include "shape_slam/candidate_selection.h"
#include "shape_slam/scan_shapes.h"
#include "test_scenes.h"

namespace shape_slam {
namespace {

using testing::Scene;

constexpr double kDeg = M_PI / 180.0;

double PointToSegment(const Point2& p, const Point2& a, const Point2& b) {
  const Point2 d = b - a;
  const double t = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (a + t * d - p).norm();
}

// The cost the brute force minimises: squared distance of each sample to the nearest wall,
// truncated at `gate` (samples farther away count as outliers, as the refinement's gate does).
double TruncatedCost(const std::vector<Point2>& samples, const Scene& scene, const Pose2& T,
                     double gate) {
  double cost = 0.0;
  const PointTransform transform(T);
  for (const Point2& s : samples) {
    const Point2 p = transform(s);
    double best = gate;
    for (const testing::Wall& w : scene) best = std::min(best, PointToSegment(p, w.a, w.b));
    cost += best * best;
  }
  return cost;
}

// Exhaustive search on a grid of `n` steps each side of `centre`, then twice more around the
// best with steps n times finer.
Pose2 BruteForce(const std::vector<Point2>& samples, const Scene& scene, Pose2 centre,
                 double step_m, double step_rad, int n, double gate) {
  for (int level = 0; level < 3; ++level) {
    Pose2 best = centre;
    double best_cost = std::numeric_limits<double>::infinity();
    for (int i = -n; i <= n; ++i) {
      for (int j = -n; j <= n; ++j) {
        for (int k = -n; k <= n; ++k) {
          const Pose2 T(centre.x + i * step_m, centre.y + j * step_m, centre.theta + k * step_rad);
          const double cost = TruncatedCost(samples, scene, T, gate);
          if (cost < best_cost) best_cost = cost, best = T;
        }
      }
    }
    centre = best;
    step_m /= n;
    step_rad /= n;
  }
  return centre;
}

struct Case {
  Scene scene;
  Pose2 T_world_sensor;
  Pose2 offset;  // the refinement starts at T_world_sensor * offset
};

TEST(RegistrationTest, RefinementFindsTheBruteForceOptimum) {
  Scene pillars = testing::Room(0.0, 0.0, 7.0, 5.0);
  testing::AddPillar(pillars, {2.0, 1.5}, 0.3);
  testing::AddPillar(pillars, {5.0, 3.2}, 0.2);
  const std::vector<Case> cases = {
      {testing::OfficeRoom(), Pose2(2.5, 2.0, 0.3), Pose2(0.20, -0.15, 6 * kDeg)},
      {testing::OfficeRoom(), Pose2(4.0, 3.5, -2.5), Pose2(-0.25, 0.10, -8 * kDeg)},
      {pillars, Pose2(3.5, 2.5, 1.2), Pose2(0.15, 0.20, 5 * kDeg)},
      {testing::LoopWorld(), Pose2(1.5, 1.5, 0.4), Pose2(-0.2, -0.2, -7 * kDeg)},
  };
  std::mt19937 prng(7);
  testing::ScannerModel scanner;
  scanner.beams = 361;
  scanner.fov_rad = 2.0 * M_PI;
  scanner.noise_sigma_m = 0.005;
  const RefinementParams refinement;
  for (std::size_t c = 0; c < cases.size(); ++c) {
    SCOPED_TRACE("case " + std::to_string(c));
    const Case& k = cases[c];
    const LaserScan scan = testing::SimulateScan(k.scene, k.T_world_sensor, scanner, prng);
    const std::vector<Point2> samples =
        internal::AlignmentSamples(ExtractScanShapes(scan, ScanShapesParams{}).fine, 0.10);
    ASSERT_GT(samples.size(), 50u);
    std::vector<Polyline> model;
    for (const testing::Wall& w : k.scene) model.push_back({w.a, w.b});

    const RefinementResult refined = internal::RefineAgainstMap(
        samples, model, k.T_world_sensor * k.offset, std::nullopt, refinement, 0.6);
    ASSERT_TRUE(refined.converged);
    // Brute force around the start, over a window larger than the offset (+-0.4 m, +-12 deg).
    const Pose2 brute =
        BruteForce(samples, k.scene, k.T_world_sensor * k.offset, 0.05, 1.5 * kDeg, 8,
                   refinement.max_correspondence_distance_m);
    EXPECT_THAT(refined.T_map_scan, IsNearly(brute, 0.002, 0.1 * kDeg));
    EXPECT_THAT(brute, IsNearly(k.T_world_sensor, 0.02, 0.5 * kDeg));
    // The inlier ratio against the true walls is high at the optimum and low at the start.
    const internal::SegmentGrid grid(internal::MakeModelSegments(model), 0.05);
    EXPECT_GT(internal::InlierRatio(samples, grid, refined.T_map_scan), 0.9);
    EXPECT_LT(internal::InlierRatio(samples, grid, k.T_world_sensor * k.offset), 0.6);
  }
}

// RegisterCandidates: the candidates ranked by fit (a far look-alike loses to the true pose),
// refined in that order until the stage's check accepts one; the result names the candidate
// that won, its fit and covariance. None accepted: not converged, at the reference.
TEST(RegistrationTest, RegisterCandidatesTakesTheFirstAcceptedInRankOrder) {
  std::mt19937 prng(3);
  const Scene scene = testing::OfficeRoom();
  const Pose2 truth(2.5, 2.0, 0.3);
  const LaserScan scan = testing::SimulateScan(scene, truth, testing::ScannerModel{}, prng);
  const std::vector<Point2> samples =
      internal::AlignmentSamples(ExtractScanShapes(scan, ScanShapesParams{}).fine, 0.10);
  std::vector<Polyline> model;
  for (const testing::Wall& w : scene) model.push_back({w.a, w.b});
  const CandidateSelector selector(model, CandidateSelectionParams{});
  const std::vector<Pose2> candidates = {Pose2(4.5, 0.5, 2.0), truth * Pose2(0.1, -0.1, 0.05)};
  int refinements = 0;
  const auto refine = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
    ++refinements;
    const RefinementResult r = internal::RefineAgainstMap(samples, model, c.T_model_scan,
                                                          std::nullopt, RefinementParams{}, 0.6);
    if (!r.converged) return std::nullopt;
    return r;
  };
  const internal::RegistrationResult best =
      internal::RegisterCandidates(samples, selector, candidates, Pose2(), 6, refine);
  ASSERT_TRUE(best.converged);
  EXPECT_EQ(best.candidate, 1);
  EXPECT_EQ(refinements, 1);
  EXPECT_THAT(best.T_model_scan, IsNearly(truth, 0.02, 0.5 * kDeg));
  EXPECT_DOUBLE_EQ(best.fit, selector.Fit(samples, best.T_model_scan));
  EXPECT_GT(best.fit, 0.9);
  EXPECT_LT(best.covariance(0, 0), 1e-3);
  EXPECT_EQ(best.reverse_fit, -1.0);

  // The stage refuses the better candidate: the other one is refined next and, with a check
  // that accepts anything else, wins.
  const auto refuse_first = [&](const RankedCandidate& c) -> std::optional<RefinementResult> {
    if (c.index == 1) return std::nullopt;
    return internal::RefineAgainstMap(samples, model, c.T_model_scan, std::nullopt,
                                      RefinementParams{}, 0.6);
  };
  const internal::RegistrationResult second =
      internal::RegisterCandidates(samples, selector, candidates, Pose2(), 6, refuse_first);
  EXPECT_EQ(second.candidate, 0);
  EXPECT_LT(second.fit, best.fit);

  // At most max_refinements are refined; none accepted: not converged, at the reference.
  const Pose2 reference(1.0, 1.0, 0.0);
  const internal::RegistrationResult none =
      internal::RegisterCandidates(samples, selector, candidates, reference, 1, refuse_first);
  EXPECT_FALSE(none.converged);
  EXPECT_EQ(none.candidate, -1);
  EXPECT_THAT(none.T_model_scan, IsNearly(reference, 1e-12, 1e-12));
  // `accept` drops candidates before ranking.
  const internal::RegistrationResult only_far = internal::RegisterCandidates(
      samples, selector, candidates, Pose2(), 6, refine,
      [&](const Pose2& T) { return (T.Translation() - truth.Translation()).norm() > 1.0; });
  EXPECT_NE(only_far.candidate, 1);
}

TEST(RegistrationTest, ThinnedKeepsEveryKthSample) {
  std::vector<Point2> samples;
  for (int i = 0; i < 10; ++i) samples.emplace_back(i, 0.0);
  const std::vector<Point2> thinned = internal::Thinned(samples, 0.1, 0.3);
  ASSERT_EQ(thinned.size(), 4u);
  EXPECT_EQ(thinned[1].x(), 3.0);
  EXPECT_EQ(internal::Thinned(samples, 0.1, 0.05).size(), samples.size());
}

TEST(RegistrationTest, MedianShiftIsTheMedianSampleMotion) {
  const std::vector<Point2> samples = {Point2(1.0, 0.0), Point2(2.0, 0.0), Point2(4.0, 0.0)};
  EXPECT_DOUBLE_EQ(internal::MedianShift(samples, Pose2(), Pose2(0.0, 0.3, 0.0)), 0.3);
  // Turned by 90 deg about the origin, the samples move by sqrt(2) times their range.
  const Pose2 quarter_turn(0.0, 0.0, M_PI / 2);
  EXPECT_NEAR(internal::MedianShift(samples, Pose2(), quarter_turn), 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_EQ(internal::MedianShift({}, Pose2(), Pose2(5.0, 0.0, 1.0)), 0.0);
}

// A refinement may move the scan's median sample by at most outer_iterations times the gate (3 x
// 0.3 m by default): a correction of centimetres and degrees stays, a turn of 75 deg (a corner
// seen by a narrow scan) does not.
TEST(RegistrationTest, RefinementThatJumpedDidNotStayNear) {
  RefinementParams params;
  params.outer_iterations = 3;
  params.max_correspondence_distance_m = 0.3;
  std::vector<Point2> samples;
  for (double r = 1.0; r <= 6.0; r += 0.1) samples.emplace_back(r, 0.3 * r);
  const Pose2 start(2.0, 1.0, 0.4);
  const auto stayed = [&](const Pose2& correction) {
    return internal::RefinementStayedNear(samples, start, start * correction, params);
  };
  EXPECT_TRUE(stayed(Pose2()));
  EXPECT_TRUE(stayed(Pose2(0.05, -0.03, 0.05)));
  EXPECT_TRUE(stayed(Pose2(0.85, 0.0, 0.0)));
  EXPECT_FALSE(stayed(Pose2(0.95, 0.0, 0.0)));
  EXPECT_FALSE(stayed(Pose2(0.0, 0.0, 75.0 * M_PI / 180.0)));
  params.outer_iterations = 4;  // one more round may carry the scan one gate farther
  EXPECT_TRUE(stayed(Pose2(0.95, 0.0, 0.0)));
}

// A corridor: two parallel walls 2 m apart along x, seen by the scan over 5 m each.
std::vector<Polyline> CorridorWalls(double x0, double x1) {
  return {{Point2(x0, -1.0), Point2(x1, -1.0)}, {Point2(x1, 1.0), Point2(x0, 1.0)}};
}

TEST(RegistrationTest, WidenedAlongRidgeWidensAlongAFeaturelessCorridorOnly) {
  const double inlier_m = 0.1;
  // Along x the refinement reports 1 cm, as it does where the two views overlap better short.
  const Eigen::Matrix3d tight = Eigen::Vector3d(1e-4, 4e-6, 1e-6).asDiagonal();
  const std::vector<Point2> corridor_samples =
      internal::AlignmentSamples(CorridorWalls(10, 15), 0.1);
  const auto model = [&](const std::vector<Polyline>& walls) {
    return internal::ModelIcp(walls, inlier_m, inlier_m, internal::RidgeOpenEndM(1.0));
  };
  const internal::ModelIcp corridor_model = model(CorridorWalls(0, 20));
  const Eigen::Matrix3d widened =
      internal::WidenedAlongRidge(corridor_samples, corridor_model, Pose2(), tight, 1.0, 0.05);
  EXPECT_NEAR(widened(0, 0), 1.0, 1e-9);  // the full shift tried: 1 m
  EXPECT_NEAR(widened(1, 1), tight(1, 1), 1e-12);
  EXPECT_NEAR(widened(2, 2), tight(2, 2), 1e-12);
  EXPECT_NEAR(widened(0, 1), 0.0, 1e-12);

  // Off: unchanged.
  EXPECT_TRUE(internal::WidenedAlongRidge(corridor_samples, corridor_model, Pose2(), tight, 0.0,
                                          0.05)
                  .isApprox(tight));

  // The corridor's end wall in view fixes x: shifted, its samples leave the model.
  std::vector<Polyline> dead_end_walls = CorridorWalls(10, 15);
  dead_end_walls.push_back({Point2(15, -1.0), Point2(15, 1.0)});
  const std::vector<Point2> dead_end_samples = internal::AlignmentSamples(dead_end_walls, 0.1);
  std::vector<Polyline> dead_end_model = CorridorWalls(0, 15);
  dead_end_model.push_back({Point2(15, -1.0), Point2(15, 1.0)});
  EXPECT_TRUE(internal::WidenedAlongRidge(dead_end_samples, model(dead_end_model), Pose2(), tight,
                                          1.0, 0.05)
                  .isApprox(tight));

  // Only the weakest direction is tried: across the corridor the walls leave the model at once.
  const Eigen::Matrix3d across = Eigen::Vector3d(4e-6, 1e-4, 1e-6).asDiagonal();
  EXPECT_TRUE(internal::WidenedAlongRidge(corridor_samples, corridor_model, Pose2(), across, 1.0,
                                          0.05)
                  .isApprox(across));
}

}  // namespace
}  // namespace shape_slam
