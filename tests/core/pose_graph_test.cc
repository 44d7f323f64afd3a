// The keyframe pose graph (pose_graph.h): a square loop with drifting odometry edges is pulled
// back into shape by one loop edge; a wrong loop edge is held off by the robust loss; bad edges
// are rejected.
#include "shape_slam/pose_graph.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace shape_slam {
namespace {

// 4 x 4 m square, a node every metre (16 nodes, back at the start).
std::vector<Pose2> SquareLoop() {
  std::vector<Pose2> poses;
  Pose2 T;
  for (int side = 0; side < 4; ++side) {
    for (int step = 0; step < 4; ++step) {
      poses.push_back(T);
      T = T * Pose2(1.0, 0.0, step == 3 ? M_PI / 2 : 0.0);
    }
  }
  return poses;
}

PoseGraph DriftingGraph(const std::vector<Pose2>& truth, unsigned seed) {
  std::mt19937 prng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  PoseGraph graph;
  Pose2 estimate = truth[0];
  graph.AddNode(estimate);
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.02 * 0.02).asDiagonal();
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Pose2 delta = truth[i - 1].Inverse() * truth[i];
    const Pose2 noisy(delta.x + 0.02 * n(prng), delta.y + 0.02 * n(prng),
                      delta.theta + 0.03 + 0.02 * n(prng));  // biased heading: drift
    estimate = estimate * noisy;
    graph.AddNode(estimate);
    graph.AddEdge({static_cast<int>(i - 1), static_cast<int>(i), noisy, cov, false});
  }
  return graph;
}

double MaxError(const PoseGraph& graph, const std::vector<Pose2>& truth) {
  double worst = 0.0;
  for (int i = 0; i < graph.NumNodes(); ++i) {
    worst = std::max(worst, (graph.Node(i).Translation() - truth[i].Translation()).norm());
  }
  return worst;
}

TEST(PoseGraphTest, LoopEdgeRemovesTheDrift) {
  const std::vector<Pose2> truth = SquareLoop();
  PoseGraph graph = DriftingGraph(truth, 1);
  const double before = MaxError(graph, truth);
  ASSERT_GT(before, 0.5);  // the drift is real
  const int last = graph.NumNodes() - 1;
  graph.AddEdge({last, 0, truth[last].Inverse() * truth[0],
                 Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal(), true});
  const PoseGraphResult result = graph.Optimize();
  EXPECT_TRUE(result.converged);
  EXPECT_LT(result.final_cost, result.initial_cost);
  EXPECT_LT(MaxError(graph, truth), 0.25 * before);
  EXPECT_EQ(graph.Node(0).x, truth[0].x);  // node 0 is fixed
}

TEST(PoseGraphTest, RobustLossLimitsAWrongLoopEdge) {
  const std::vector<Pose2> truth = SquareLoop();
  PoseGraph right = DriftingGraph(truth, 2);
  PoseGraph wrong = DriftingGraph(truth, 2);
  const int last = right.NumNodes() - 1;
  const Eigen::Matrix3d tight = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  right.AddEdge({last, 0, truth[last].Inverse() * truth[0], tight, true});
  // Two right closures and one claiming the robot ended 3 m away.
  wrong.AddEdge({last, 0, truth[last].Inverse() * truth[0], tight, true});
  wrong.AddEdge({last - 1, 0, truth[last - 1].Inverse() * truth[0], tight, true});
  wrong.AddEdge({8, 0, Pose2(3.0, 0.0, 0.0), tight, true});
  right.Optimize();
  wrong.Optimize();
  EXPECT_LT(MaxError(wrong, truth), MaxError(right, truth) + 0.3);
}

TEST(PoseGraphTest, BadEdgesAreRejected) {
  PoseGraph graph;
  graph.AddNode(Pose2());
  graph.AddNode(Pose2(1, 0, 0));
  EXPECT_THROW(graph.AddEdge({0, 2, Pose2(), Eigen::Matrix3d::Identity(), false}),
               std::invalid_argument);
  EXPECT_THROW(graph.AddEdge({-1, 1, Pose2(), Eigen::Matrix3d::Identity(), false}),
               std::invalid_argument);
  Eigen::Matrix3d not_pd = Eigen::Matrix3d::Identity();
  not_pd(2, 2) = -1.0;
  EXPECT_THROW(graph.AddEdge({0, 1, Pose2(), not_pd, false}), std::invalid_argument);
  Eigen::Matrix3d nan = Eigen::Matrix3d::Identity();
  nan(0, 0) = std::nan("");
  EXPECT_THROW(graph.AddEdge({0, 1, Pose2(), nan, false}), std::invalid_argument);
  PoseGraphEdge negative_loss{0, 1, Pose2(), Eigen::Matrix3d::Identity(), false};
  negative_loss.loss_sigmas = -1.0;
  EXPECT_THROW(graph.AddEdge(negative_loss), std::invalid_argument);
}

// Odometry edges beside the scan edges (OdometryEdgeParams): tight in heading, one of them a
// glitch of 80 deg. With its Cauchy loss the glitch bends the loop little; without, it bends it.
TEST(PoseGraphTest, RobustLossOnAnOdometryEdgeHoldsOffAGlitch) {
  const std::vector<Pose2> truth = SquareLoop();
  const auto solve = [&](double loss_sigmas) {
    PoseGraph graph = DriftingGraph(truth, 4);
    const int n = graph.NumNodes();
    for (int i = 1; i < n; ++i) {
      Pose2 odometry = truth[i - 1].Inverse() * truth[i];
      if (i == 6) odometry = odometry * Pose2(0.0, 0.0, 1.4);
      PoseGraphEdge edge{i - 1, i, odometry, Eigen::Vector3d(1.0, 1.0, 1e-4).asDiagonal(), false};
      edge.loss_sigmas = loss_sigmas;
      graph.AddEdge(edge);
    }
    graph.Optimize();
    return MaxError(graph, truth);
  };
  const double robust = solve(3.0), plain = solve(0.0);
  EXPECT_LT(robust, 0.3);
  EXPECT_GT(plain, 2.0 * robust);
}

TEST(PoseGraphTest, GraphWithoutEdgesStaysPut) {
  PoseGraph graph;
  graph.AddNode(Pose2());
  graph.AddNode(Pose2(1, 2, 0.3));
  graph.Optimize();
  EXPECT_EQ(graph.Node(1).x, 1.0);
  EXPECT_EQ(graph.Node(1).theta, 0.3);
  // An edge that does not touch the fixed node 0.
  graph.AddNode(Pose2(2, 2, 0.3));
  graph.AddEdge({1, 2, Pose2(0.5, 0, 0), Eigen::Matrix3d::Identity() * 1e-2, false});
  EXPECT_TRUE(graph.Optimize().converged);
  EXPECT_NEAR((graph.Node(1).Inverse() * graph.Node(2)).x, 0.5, 1e-6);
  EXPECT_EQ(graph.Node(0).x, 0.0);
}

}  // namespace
}  // namespace shape_slam
