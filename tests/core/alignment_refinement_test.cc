#include "shape_slam/alignment_refinement.h"

#include <ceres/cost_function.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>

#include "core/alignment_scenes.h"
#include "core/pose_matchers.h"
#include "shape_slam/alignment.h"
#include "shape_slam/internal/point_to_segment_cost.h"
#include "shape_slam/internal/pose_prior_cost.h"

namespace shape_slam {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr double kDeg = M_PI / 180.0;
const Pose2 kTruth(1.0, 0.5, 0.2);  // T_map_scan of the simulated scans

// Samples of every perceived polyline, as the pipeline feeds the unrestricted refinement.
std::vector<Point2> AllSamples(const std::vector<ShapePair>& pairs) {
  std::vector<Point2> samples;
  for (const ShapePair& pair : pairs) {
    for (const Point2& p : SamplePolyline(pair.perceived, 0.1)) samples.push_back(p);
  }
  return samples;
}

void ExpectValidCovariance(const Eigen::Matrix3d& covariance) {
  ASSERT_TRUE(covariance.allFinite());
  EXPECT_LE((covariance - covariance.transpose()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance).eigenvalues().minCoeff(),
            0.0);
}

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
// Residual functors

// Residual and Jacobian of a cost function at `pose`.
struct Evaluation {
  Eigen::VectorXd residual;
  Eigen::MatrixXd jacobian;  // residuals x 3
};

Evaluation Evaluate(const ceres::CostFunction& cost, const Eigen::Vector3d& pose) {
  const int n = cost.num_residuals();
  Evaluation e{Eigen::VectorXd(n), Eigen::MatrixXd(n, 3)};
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> J(n, 3);
  const double* parameters[] = {pose.data()};
  double* jacobians[] = {J.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, e.residual.data(), jacobians));
  e.jacobian = J;
  return e;
}

// Central differences of the residual.
Eigen::MatrixXd NumericJacobian(const ceres::CostFunction& cost, const Eigen::Vector3d& pose) {
  Eigen::MatrixXd J(cost.num_residuals(), 3);
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = pose, minus = pose;
    plus[k] += 1e-6;
    minus[k] -= 1e-6;
    J.col(k) = (Evaluate(cost, plus).residual - Evaluate(cost, minus).residual) / 2e-6;
  }
  return J;
}

TEST(PointToSegmentCostTest, DistanceToLineBetweenEndsAndToEndPointsBeyond) {
  const Point2 a(1.0, 1.0), b(3.0, 1.0);
  const Eigen::Vector3d identity(0.0, 0.0, 0.0);
  const auto residual = [&](const Point2& sample, double sigma) {
    const std::unique_ptr<ceres::CostFunction> cost(
        internal::PointToSegmentCost::Create(sample, a, b, sigma));
    return Evaluate(*cost, identity).residual;
  };
  EXPECT_NEAR(residual({2.0, 1.3}, 1.0).norm(), 0.3, 1e-12);  // above the middle
  EXPECT_NEAR(residual({2.0, 1.3}, 0.1)[1], 0.0, 1e-12);      // no along component inside
  EXPECT_NEAR(residual({2.0, 0.7}, 0.1).norm(), 3.0, 1e-12);  // whitened by sigma
  EXPECT_NEAR(residual({4.0, 1.3}, 1.0).norm(), std::hypot(1.0, 0.3), 1e-12);  // beyond b
  EXPECT_NEAR(residual({0.0, 1.0}, 1.0).norm(), 1.0, 1e-12);  // beyond a, on the line
  // The pose moves the sample: rotate (1, 0) by 90 deg and shift by (1.5, 0) -> (1.5, 1).
  const std::unique_ptr<ceres::CostFunction> cost(
      internal::PointToSegmentCost::Create({1.0, 0.0}, a, b, 1.0));
  EXPECT_NEAR(Evaluate(*cost, {1.5, 0.0, M_PI / 2}).residual.norm(), 0.0, 1e-12);
  // A point segment measures the distance to the point.
  const std::unique_ptr<ceres::CostFunction> point(
      internal::PointToSegmentCost::Create({4.0, 5.0}, a, a, 1.0));
  EXPECT_NEAR(Evaluate(*point, identity).residual.norm(), 5.0, 1e-12);
}

TEST(PointToSegmentCostTest, JacobianMatchesFiniteDifferences) {
  std::mt19937 prng(42);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int trial = 0; trial < 50; ++trial) {
    const std::unique_ptr<ceres::CostFunction> cost(internal::PointToSegmentCost::Create(
        {u(prng), u(prng)}, {u(prng), u(prng)}, {u(prng), u(prng)}, 0.05));
    const Eigen::Vector3d pose(u(prng), u(prng), u(prng));
    EXPECT_TRUE(Evaluate(*cost, pose).jacobian.isApprox(NumericJacobian(*cost, pose), 1e-5));
  }
}

TEST(PosePriorCostTest, WhitenedErrorWithWrappedAngle) {
  const Eigen::Matrix3d sqrt_information = Eigen::Vector3d(10.0, 20.0, 100.0).asDiagonal();
  const std::unique_ptr<ceres::CostFunction> cost(
      internal::PosePriorCost::Create(Pose2(1.0, 2.0, M_PI - 0.01), sqrt_information));
  // theta = -pi + 0.01 is 0.02 rad from the prior across the wrap.
  const Evaluation e = Evaluate(*cost, {1.1, 1.9, -M_PI + 0.01});
  EXPECT_TRUE(e.residual.isApprox(Eigen::Vector3d(1.0, -2.0, 2.0), 1e-9));
  EXPECT_TRUE(e.jacobian.isApprox(sqrt_information, 1e-9));
}

// ---------------------------------------------------------------------------------------------
// Pose recovery after the ICP

// From the ICP's output (random starts up to 0.5 m / 15 deg, 1 cm noise) the refinement lands
// within 5 mm / 0.1 deg, both unrestricted (all samples against all model polylines) and
// restricted to the pairs, with a valid covariance.
void ExpectRefinementAfterIcp(const std::vector<Polyline>& scene) {
  std::mt19937 prng(42);
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  const std::vector<Point2> samples = AllSamples(pairs);
  for (int trial = 0; trial < 10; ++trial) {
    const AlignmentResult icp = AlignShapes(pairs, test::Perturb(kTruth, 0.5, 15.0 * kDeg, prng));
    for (const RefinementResult& result :
         {RefineAlignment(samples, scene, icp.T_map_scan, std::nullopt),
          RefineAlignment(pairs, icp.T_map_scan, std::nullopt)}) {
      EXPECT_TRUE(result.converged);
      EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 0.005, 0.1 * kDeg));
      EXPECT_GE(result.num_residuals, static_cast<int>(0.95 * samples.size()));
      EXPECT_LT(result.rms_error_m, 0.012);
      EXPECT_GE(result.iterations, 1);
      ExpectValidCovariance(result.covariance);
    }
  }
}

TEST(RefineAlignmentTest, LCorner) { ExpectRefinementAfterIcp(test::LCornerScene()); }
TEST(RefineAlignmentTest, RoomWithPillar) { ExpectRefinementAfterIcp(test::RoomWithPillarScene()); }
TEST(RefineAlignmentTest, CorridorWithDoors) {
  ExpectRefinementAfterIcp(test::CorridorWithDoorsScene());
}

TEST(RefineAlignmentTest, NoiseFreeDataGivesTheExactPose) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.0, prng), scene));
  const Pose2 init(kTruth.x + 0.05, kTruth.y - 0.04, kTruth.theta + 1.0 * kDeg);
  const RefinementResult result = RefineAlignment(samples, scene, init, std::nullopt);
  EXPECT_TRUE(result.converged);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 1e-7, 1e-8));
  EXPECT_LT(result.rms_error_m, 1e-7);
}

// ---------------------------------------------------------------------------------------------
// Covariance

// The corridor's axis (x) is held by the door jambs only: its variance is much larger than the
// variance across the corridor; with straight walls it is unconstrained.
TEST(RefineAlignmentTest, CovarianceShowsTheCorridorsWeakAxis) {
  std::mt19937 prng(42);
  for (const bool doors : {true, false}) {
    const std::vector<Polyline> scene =
        doors ? test::CorridorWithDoorsScene() : test::StraightCorridorScene();
    const std::vector<Point2> samples =
        AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
    const RefinementResult result = RefineAlignment(samples, scene, kTruth, std::nullopt);
    ExpectValidCovariance(result.covariance);
    EXPECT_GT(result.covariance(0, 0), 5.0 * result.covariance(1, 1));
    if (doors) {
      EXPECT_LT(result.covariance(0, 0), 1e-4);  // constrained: a few mm
    } else {
      EXPECT_NEAR(result.covariance(0, 0), kUnconstrainedVariance, 1e-3 * kUnconstrainedVariance);
    }
  }
}

// With point_sigma_m equal to the simulated noise, the reported covariance predicts the spread
// of the refined pose over noise realisations (Monte Carlo, within a factor of 2).
TEST(RefineAlignmentTest, CovarianceMatchesMonteCarloSpread) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::CorridorWithDoorsScene();
  RefinementParams params;
  params.point_sigma_m = 0.01;
  Eigen::Matrix3d empirical = Eigen::Matrix3d::Zero(), predicted = Eigen::Matrix3d::Zero();
  constexpr int kRuns = 60;
  for (int run = 0; run < kRuns; ++run) {
    const std::vector<Point2> samples =
        AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
    const RefinementResult result = RefineAlignment(samples, scene, kTruth, std::nullopt, params);
    const Eigen::Vector3d error(result.T_map_scan.x - kTruth.x, result.T_map_scan.y - kTruth.y,
                                NormalizeAngle(result.T_map_scan.theta - kTruth.theta));
    empirical += error * error.transpose() / kRuns;
    predicted += result.covariance / kRuns;
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(empirical(k, k), 0.5 * predicted(k, k)) << "axis " << k;
    EXPECT_LT(empirical(k, k), 2.0 * predicted(k, k)) << "axis " << k;
  }
}

// ---------------------------------------------------------------------------------------------
// Prior

// In a corridor of straight walls the data say nothing about x: the prior decides it, while y
// and theta follow the walls.
TEST(RefineAlignmentTest, PriorPullsTheUnconstrainedAxis) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::StraightCorridorScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  const Pose2 init(kTruth.x + 0.3, kTruth.y + 0.05, kTruth.theta + 1.0 * kDeg);
  const PosePrior prior{Pose2(kTruth.x + 0.1, kTruth.y - 0.1, kTruth.theta - 2.0 * kDeg),
                        Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal()};
  const RefinementResult with = RefineAlignment(samples, scene, init, prior);
  EXPECT_TRUE(with.converged);
  EXPECT_NEAR(with.T_map_scan.x, prior.T_map_scan.x, 1e-3);  // along the axis: the prior
  EXPECT_NEAR(with.T_map_scan.y, kTruth.y, 0.005);           // across: the walls
  EXPECT_NEAR(with.T_map_scan.theta, kTruth.theta, 0.1 * kDeg);
  EXPECT_NEAR(with.covariance(0, 0), 0.01, 1e-4);  // x variance: the prior's
  EXPECT_LT(with.covariance(1, 1), 1e-4);
  // Without the prior x does not move from the start.
  const RefinementResult without = RefineAlignment(samples, scene, init, std::nullopt);
  EXPECT_NEAR(without.T_map_scan.x, init.x, 1e-3);
  EXPECT_NEAR(without.T_map_scan.y, kTruth.y, 0.005);
}

// A prior 10 standard deviations off (an odometry glitch) against a scan that fixes every
// axis: the Gaussian prior drags the pose centimetres away from the walls; the heavy-tailed one
// (Cauchy, 3 sigmas) barely moves it, and its information then counts little in the
// covariance. Within its scale the heavy-tailed prior acts as the Gaussian one does.
TEST(RefineAlignmentTest, HeavyTailedPriorYieldsToAClearScan) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::CorridorWithDoorsScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  const Eigen::Matrix3d covariance =
      Eigen::Vector3d(0.01 * 0.01, 0.01 * 0.01, std::pow(0.3 * kDeg, 2)).asDiagonal();
  const auto refine = [&](const Pose2& prior_mean, double loss_sigmas) {
    return RefineAlignment(samples, scene, kTruth, PosePrior{prior_mean, covariance, loss_sigmas});
  };
  const Pose2 glitch(kTruth.x + 0.1, kTruth.y - 0.1, kTruth.theta + 3.0 * kDeg);
  const RefinementResult gaussian = refine(glitch, 0.0);
  const RefinementResult heavy = refine(glitch, 3.0);
  const RefinementResult data_only = RefineAlignment(samples, scene, kTruth, std::nullopt);
  ASSERT_TRUE(gaussian.converged);
  ASSERT_TRUE(heavy.converged);
  ASSERT_TRUE(data_only.converged);
  EXPECT_THAT(gaussian.T_map_scan, ::testing::Not(IsNearly(data_only.T_map_scan, 0.004, 1.0 * kDeg)));
  EXPECT_THAT(heavy.T_map_scan, IsNearly(data_only.T_map_scan, 0.001, 0.02 * kDeg));
  EXPECT_THAT(heavy.T_map_scan, IsNearly(kTruth, 0.003, 0.05 * kDeg));
  EXPECT_NEAR(heavy.covariance(0, 0), data_only.covariance(0, 0), 0.2 * data_only.covariance(0, 0));
  // One standard deviation off: the two priors agree within a millimetre.
  const Pose2 near(kTruth.x + 0.01, kTruth.y, kTruth.theta + 0.3 * kDeg);
  EXPECT_THAT(refine(near, 3.0).T_map_scan, IsNearly(refine(near, 0.0).T_map_scan, 0.001, 0.02 * kDeg));
  EXPECT_THROW(refine(glitch, -1.0), std::invalid_argument);
  EXPECT_THROW(refine(glitch, std::nan("")), std::invalid_argument);
}

// Along a corridor of straight walls the scan says nothing, so there the heavy-tailed prior
// stays whole even when it is far off across the corridor (a heading glitch): x and its
// variance are the prior's, y and theta the walls'.
TEST(RefineAlignmentTest, HeavyTailedPriorHoldsWhereTheScanIsBlind) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::StraightCorridorScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  const PosePrior prior{Pose2(kTruth.x + 0.1, kTruth.y - 0.1, kTruth.theta - 3.0 * kDeg),
                        Eigen::Vector3d(0.01 * 0.01, 0.01 * 0.01, std::pow(0.3 * kDeg, 2)).asDiagonal(),
                        3.0};
  const RefinementResult heavy = RefineAlignment(samples, scene, kTruth, prior);
  ASSERT_TRUE(heavy.converged);
  EXPECT_NEAR(heavy.T_map_scan.x, prior.T_map_scan.x, 1e-3);
  EXPECT_NEAR(heavy.T_map_scan.y, kTruth.y, 0.003);
  EXPECT_NEAR(heavy.T_map_scan.theta, kTruth.theta, 0.05 * kDeg);
  EXPECT_NEAR(heavy.covariance(0, 0), 0.01 * 0.01, 0.1 * 0.01 * 0.01);
}

// ---------------------------------------------------------------------------------------------
// Robustness

// 20% of the samples displaced by 1 m in random directions. With a gate wide enough to let them
// in, the robust losses keep the pose within 1 cm where plain least squares does not.
TEST(RefineAlignmentTest, RobustLossResistsOutliers) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (Point2& p : samples) {
    if (unit(prng) < 0.2) {
      const double angle = 2.0 * M_PI * unit(prng);
      p += Point2(std::cos(angle), std::sin(angle));
    }
  }
  const Pose2 init(kTruth.x + 0.02, kTruth.y - 0.02, kTruth.theta + 0.5 * kDeg);
  for (const double gate_m : {0.3, 1.5}) {
    RefinementParams params;
    params.max_correspondence_distance_m = gate_m;
    for (const RobustLoss loss : {RobustLoss::kCauchy, RobustLoss::kHuber}) {
      params.loss = loss;
      EXPECT_THAT(RefineAlignment(samples, scene, init, std::nullopt, params).T_map_scan,
                  IsNearly(kTruth, 0.01, 0.1 * kDeg));
    }
  }
  RefinementParams quadratic;
  quadratic.max_correspondence_distance_m = 1.5;
  quadratic.loss_scale_m = 100.0;  // the loss is quadratic over the whole gate
  EXPECT_THAT(RefineAlignment(samples, scene, init, std::nullopt, quadratic).T_map_scan,
              Not(IsNearly(kTruth, 0.01, 0.1 * kDeg)));
}

// The restricted variant associates the samples of a pair with that pair's polylines only; the
// unrestricted one takes the nearest wall.
TEST(RefineAlignmentTest, RestrictedVariantKeepsThePairs) {
  std::mt19937 prng(42);
  const Polyline far_wall = {{6.0, -2.0}, {6.0, 3.0}, {1.0, 3.0}};
  const Polyline near_wall = {{5.8, -2.0}, {5.8, 2.8}, {1.0, 2.8}};  // 0.2 m closer
  const Polyline perceived = test::Perceive({far_wall}, kTruth, 0.01, prng)[0];
  const Pose2 init(kTruth.x - 0.15, kTruth.y - 0.15, kTruth.theta);
  EXPECT_THAT(RefineAlignment({{perceived, {far_wall}, 1.0}}, init, std::nullopt).T_map_scan,
              IsNearly(kTruth, 0.005, 0.1 * kDeg));
  EXPECT_THAT(
      RefineAlignment(SamplePolyline(perceived, 0.1), {far_wall, near_wall}, init, std::nullopt)
          .T_map_scan,
      IsNearly(Pose2(kTruth.x - 0.2, kTruth.y - 0.2, kTruth.theta), 0.005, 0.1 * kDeg));
}

TEST(RefineAlignmentTest, PairWeights) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::RoomWithPillarScene();
  std::vector<ShapePair> pairs = test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene);
  const Pose2 init(kTruth.x + 0.02, kTruth.y, kTruth.theta);
  const RefinementResult clean = RefineAlignment(pairs, init, std::nullopt);
  pairs.push_back({pairs[1].perceived, {Transform(Pose2(0.05, 0.0, 0.0), scene[1])}, 0.0});
  const RefinementResult ignored = RefineAlignment(pairs, init, std::nullopt);
  EXPECT_EQ(ignored.num_residuals, clean.num_residuals);
  EXPECT_THAT(ignored.T_map_scan, IsNearly(clean.T_map_scan, 1e-12, 1e-12));
  // Weighted in, the wrong copy pulls, the more so the heavier it is.
  const auto pull = [&](double weight) {
    pairs.back().weight = weight;
    return RefineAlignment(pairs, init, std::nullopt).T_map_scan.x - clean.T_map_scan.x;
  };
  const double light = pull(0.5), heavy = pull(10.0);
  EXPECT_GT(light, 0.0);
  EXPECT_GT(heavy, 2.0 * light);
  EXPECT_GT(heavy, 0.005);
}

// ---------------------------------------------------------------------------------------------
// Degenerate input

TEST(RefineAlignmentTest, NothingToAssociateIsNotConverged) {
  const Pose2 init(1.0, 2.0, 0.3);
  const Polyline wall = {{0.0, 0.0}, {1.0, 0.0}};
  const PosePrior prior{init, Eigen::Matrix3d::Identity()};
  for (const RefinementResult& result :
       {RefineAlignment(std::vector<Point2>{}, {wall}, init, std::nullopt),
        RefineAlignment(std::vector<Point2>{{0.0, 0.0}}, {}, init, prior),
        RefineAlignment(std::vector<Point2>{{50.0, 50.0}}, {wall}, init, std::nullopt),
        RefineAlignment(std::vector<ShapePair>{}, init, std::nullopt),
        RefineAlignment(std::vector<ShapePair>{{wall, {}, 1.0}}, init, prior)}) {
    EXPECT_FALSE(result.converged);
    EXPECT_EQ(result.iterations, 0);
    EXPECT_EQ(result.num_residuals, 0);
    EXPECT_THAT(result.T_map_scan, IsNearly(init, 0.0, 0.0));
    EXPECT_EQ(result.covariance, kUnconstrainedVariance * Eigen::Matrix3d::Identity());
  }
}

TEST(RefineAlignmentTest, FewCorrespondencesAreNotConverged) {
  const Polyline wall = {{0.0, 0.0}, {10.0, 0.0}};
  const std::vector<Point2> samples = {{1.0, 0.01}, {2.0, -0.01}, {3.0, 0.0}};
  const RefinementResult result = RefineAlignment(samples, {wall}, Pose2(), std::nullopt);
  EXPECT_EQ(result.num_residuals, 3);
  EXPECT_FALSE(result.converged);  // below min_correspondences
  ExpectValidCovariance(result.covariance);
}

// One-vertex model polylines are points; samples fix the pose against three of them.
TEST(RefineAlignmentTest, OnePointPolylines) {
  const std::vector<Polyline> model = {{{3.0, 1.0}}, {{4.0, -2.0}}, {{-1.0, 2.5}}};
  std::vector<Point2> samples;
  for (const Polyline& m : model) samples.push_back(kTruth.Inverse() * m[0]);
  RefinementParams params;
  params.min_correspondences = 3;
  const Pose2 init(kTruth.x + 0.05, kTruth.y - 0.05, kTruth.theta + 1.0 * kDeg);
  const RefinementResult result = RefineAlignment(samples, model, init, std::nullopt, params);
  EXPECT_TRUE(result.converged);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 1e-6, 1e-6));
}

TEST(RefineAlignmentTest, ZeroLengthSegments) {
  std::mt19937 prng(42);
  std::vector<Polyline> scene = test::LCornerScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  const Polyline& l = scene[0];
  scene[0] = {l[0], l[0], l[1], l[1], l[1], l[2], l[2]};
  const Pose2 init(kTruth.x + 0.03, kTruth.y - 0.03, kTruth.theta + 0.5 * kDeg);
  const RefinementResult result = RefineAlignment(samples, scene, init, std::nullopt);
  EXPECT_TRUE(result.converged);
  EXPECT_THAT(result.T_map_scan, IsNearly(kTruth, 0.005, 0.1 * kDeg));
}

TEST(RefineAlignmentTest, HugeCoordinates) {
  std::mt19937 prng(42);
  const Pose2 far(1e6, -2e6, 0.0);
  std::vector<Polyline> scene;
  for (const Polyline& p : test::RoomWithPillarScene()) scene.push_back(Transform(far, p));
  const Pose2 truth = far * kTruth;
  const std::vector<ShapePair> pairs =
      test::MakePairs(test::Perceive(scene, truth, 0.01, prng), scene);
  const Pose2 init(truth.x + 0.05, truth.y - 0.05, truth.theta + 1.0 * kDeg);
  const PosePrior prior{truth, Eigen::Vector3d(1.0, 1.0, 0.1).asDiagonal()};
  for (const RefinementResult& result : {RefineAlignment(AllSamples(pairs), scene, init, prior),
                                         RefineAlignment(pairs, init, std::nullopt)}) {
    EXPECT_TRUE(result.converged);
    EXPECT_THAT(result.T_map_scan, IsNearly(truth, 0.005, 0.1 * kDeg));
    ExpectValidCovariance(result.covariance);
  }
}

// The library never prints: Ceres runs silently, even when it stops on the iteration limit.
TEST(RefineAlignmentTest, PrintsNothing) {
  std::mt19937 prng(42);
  const std::vector<Polyline> scene = test::CorridorWithDoorsScene();
  const std::vector<Point2> samples =
      AllSamples(test::MakePairs(test::Perceive(scene, kTruth, 0.01, prng), scene));
  RefinementParams params;
  params.max_solver_iterations = 1;
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  RefineAlignment(samples, scene, Pose2(kTruth.x + 0.1, kTruth.y, kTruth.theta), std::nullopt,
                  params);
  RefineAlignment(samples, scene, kTruth, std::nullopt);
  RefineAlignment(std::vector<Point2>{{0.0, 0.0}}, scene, kTruth, std::nullopt);
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(::testing::internal::GetCapturedStdout(), "");
}

// ---------------------------------------------------------------------------------------------
// Invalid input

TEST(RefinementParamsTest, ValidateNamesTheField) {
  const auto message = [](const std::function<void(RefinementParams&)>& change) {
    RefinementParams params;
    change(params);
    return InvalidArgumentMessage([&] { params.Validate(); });
  };
  EXPECT_NO_THROW(RefinementParams{}.Validate());
  EXPECT_THAT(message([](auto& p) { p.loss_scale_m = 0.0; }), HasSubstr("loss_scale_m"));
  EXPECT_THAT(message([](auto& p) { p.loss = static_cast<RobustLoss>(7); }), HasSubstr("loss"));
  EXPECT_THAT(message([](auto& p) { p.point_sigma_m = -1.0; }), HasSubstr("point_sigma_m"));
  EXPECT_THAT(message([](auto& p) { p.max_correspondence_distance_m = std::nan(""); }),
              HasSubstr("max_correspondence_distance_m"));
  EXPECT_THAT(message([](auto& p) { p.outer_iterations = 0; }), HasSubstr("outer_iterations"));
  EXPECT_THAT(message([](auto& p) { p.max_solver_iterations = 0; }),
              HasSubstr("max_solver_iterations"));
  EXPECT_THAT(message([](auto& p) { p.min_correspondences = 0; }),
              HasSubstr("min_correspondences"));
  EXPECT_THAT(message([](auto& p) { p.sample_spacing_m = 0.0; }), HasSubstr("sample_spacing_m"));
}

TEST(RefineAlignmentTest, RejectsInvalidInput) {
  const std::vector<Point2> samples = {{1.0, 0.0}};
  const std::vector<Polyline> model = {{{0.0, 0.0}, {1.0, 0.0}}};
  const auto refine_with_covariance = [&](const Eigen::Matrix3d& covariance) {
    return InvalidArgumentMessage([&] {
      RefineAlignment(samples, model, Pose2(), PosePrior{Pose2(), covariance});
    });
  };
  Eigen::Matrix3d asymmetric = Eigen::Matrix3d::Identity();
  asymmetric(0, 1) = 0.5;
  EXPECT_THAT(refine_with_covariance(asymmetric), HasSubstr("covariance"));
  EXPECT_THAT(refine_with_covariance(Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal()),
              HasSubstr("covariance"));
  EXPECT_THAT(refine_with_covariance(Eigen::Matrix3d::Zero()), HasSubstr("covariance"));
  Eigen::Matrix3d not_finite = Eigen::Matrix3d::Identity();
  not_finite(2, 2) = std::nan("");
  EXPECT_THAT(refine_with_covariance(not_finite), HasSubstr("covariance"));
  EXPECT_THROW(RefineAlignment({{std::nan(""), 0.0}}, model, Pose2(), std::nullopt),
               std::invalid_argument);
  EXPECT_THROW(RefineAlignment(samples, {{{0.0, std::nan("")}}}, Pose2(), std::nullopt),
               std::invalid_argument);
  EXPECT_THROW(RefineAlignment(samples, model, Pose2(std::nan(""), 0.0, 0.0), std::nullopt),
               std::invalid_argument);
  EXPECT_THROW(RefineAlignment({{model[0], model, -1.0}}, Pose2(), std::nullopt),
               std::invalid_argument);
  EXPECT_THROW(
      RefineAlignment(samples, model, Pose2(),
                      PosePrior{Pose2(0.0, 0.0, std::nan("")), Eigen::Matrix3d::Identity()}),
      std::invalid_argument);
}

}  // namespace
}  // namespace shape_slam
