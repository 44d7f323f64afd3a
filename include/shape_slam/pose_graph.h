// A 2D pose graph over keyframes, optimised with Ceres: the "coupling with a state-of-the-art
// stochastic model" and the cycle detection that the paper leaves to future work (§7).
//
// Nodes are keyframe poses T_map_node; edges are measured relative poses T_i_j with a
// covariance: consecutive keyframes (the shape front end's scan-to-scan alignment and, beside it,
// the odometry's increment) and loop closures (a scan matched against an old keyframe). Loop
// edges get a robust loss so that a wrong closure cannot tear the map apart; an odometry edge
// its own, so that a glitch cannot either.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "shape_slam/types.h"

namespace shape_slam {

struct PoseGraphEdge {
  int from = 0;                 ///< node i
  int to = 0;                   ///< node j
  Pose2 T_from_to;              ///< measured pose of node j in the frame of node i
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  ///< of (x [m], y [m], theta [rad])
  bool loop = false;            ///< a loop closure (robust loss), not a consecutive edge
  /// A consecutive step that only the motion model gave (no match, no odometry): the loop
  /// search counts it as LoopClosureParams::guess_graph_m of driving.
  bool guessed = false;
  /// A non-loop edge's Cauchy loss scale in standard deviations (0: none, the default): an
  /// odometry edge's (OdometryEdgeParams::loss_sigmas). Loop edges take the graph's scales.
  double loss_sigmas = 0.0;
};

struct PoseGraphParams {
  /// Scale of the Cauchy loss on loop edges, in standard deviations (of the edge covariance).
  double loop_loss_scale = 3.0;
  /// Graduated: the graph is first solved with this wider scale (when larger), so that the
  /// loops closing a large drift pull it most of the way, then with loop_loss_scale.
  double initial_loop_loss_scale = 100.0;
  int max_iterations = 50;
  void Validate() const;
};

struct PoseGraphResult {
  bool converged = false;
  int iterations = 0;            ///< over both stages
  double initial_cost = 0.0;
  double final_cost = 0.0;
};

class PoseGraph {
 public:
  /// Adds a node with an initial estimate; returns its index (0, 1, 2, ...). Node 0 is held fixed.
  int AddNode(const Pose2& T_map_node);
  /// Adds an edge between existing nodes. Throws std::invalid_argument on bad indices or a
  /// covariance that is not symmetric positive definite.
  void AddEdge(const PoseGraphEdge& edge);

  /// Optimises all nodes (node 0 fixed) from the current estimates.
  PoseGraphResult Optimize(const PoseGraphParams& params = {});

  int NumNodes() const { return static_cast<int>(poses_.size()); }
  const std::vector<PoseGraphEdge>& Edges() const { return edges_; }
  const Pose2& Node(int index) const { return poses_.at(index); }
  void SetNode(int index, const Pose2& T_map_node) { poses_.at(index) = T_map_node; }

 private:
  std::vector<Pose2> poses_;
  std::vector<PoseGraphEdge> edges_;
};

}  // namespace shape_slam
