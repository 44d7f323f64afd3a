#include "shape_slam/pose_graph.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "shape_slam/internal/relative_pose_cost.h"

namespace shape_slam {
namespace {

// S with S^T S = covariance^-1.
Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& covariance) {
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance.inverse());
  return llt.matrixU();
}

bool SymmetricPositiveDefinite(const Eigen::Matrix3d& m) {
  if (!m.allFinite() || !m.isApprox(m.transpose(), 1e-9)) return false;
  const Eigen::LLT<Eigen::Matrix3d> llt(m);
  return llt.info() == Eigen::Success;
}

}  // namespace

void PoseGraphParams::Validate() const {
  if (!(loop_loss_scale > 0.0) || !std::isfinite(loop_loss_scale)) {
    throw std::invalid_argument("PoseGraphParams::loop_loss_scale must be > 0");
  }
  if (!(initial_loop_loss_scale >= 0.0) || !std::isfinite(initial_loop_loss_scale)) {
    throw std::invalid_argument("PoseGraphParams::initial_loop_loss_scale must be >= 0");
  }
  if (max_iterations < 1) throw std::invalid_argument("PoseGraphParams::max_iterations must be >= 1");
}

int PoseGraph::AddNode(const Pose2& T_map_node) {
  poses_.push_back(T_map_node);
  return static_cast<int>(poses_.size()) - 1;
}

void PoseGraph::AddEdge(const PoseGraphEdge& edge) {
  const int n = NumNodes();
  if (edge.from < 0 || edge.from >= n || edge.to < 0 || edge.to >= n || edge.from == edge.to) {
    throw std::invalid_argument("PoseGraph::AddEdge: bad node indices " + std::to_string(edge.from) +
                                " -> " + std::to_string(edge.to));
  }
  if (!SymmetricPositiveDefinite(edge.covariance)) {
    throw std::invalid_argument("PoseGraph::AddEdge: covariance is not symmetric positive definite");
  }
  if (!(edge.loss_sigmas >= 0.0) || !std::isfinite(edge.loss_sigmas)) {
    throw std::invalid_argument("PoseGraph::AddEdge: loss_sigmas must be >= 0 and finite");
  }
  edges_.push_back(edge);
}

PoseGraphResult PoseGraph::Optimize(const PoseGraphParams& params) {
  params.Validate();
  PoseGraphResult result;
  if (poses_.size() < 2 || edges_.empty()) {  // nothing to optimise: the estimates stand
    result.converged = true;
    return result;
  }
  std::vector<std::array<double, 3>> x(poses_.size());
  for (std::size_t i = 0; i < poses_.size(); ++i) x[i] = {poses_[i].x, poses_[i].y, poses_[i].theta};
  // Graduated: a wide loss first, so that loop edges far from the estimate (the drift around a
  // large loop) pull the graph most of the way, then the robust one, so that a wrong closure
  // that slipped through stays down-weighted.
  std::vector<double> scales;
  if (params.initial_loop_loss_scale > params.loop_loss_scale) scales.push_back(params.initial_loop_loss_scale);
  scales.push_back(params.loop_loss_scale);
  ceres::Solver::Summary summary;
  bool first = true;
  for (const double scale : scales) {
    ceres::Problem problem;
    for (const PoseGraphEdge& e : edges_) {
      ceres::LossFunction* loss = e.loop                ? new ceres::CauchyLoss(scale)
                                  : e.loss_sigmas > 0.0 ? new ceres::CauchyLoss(e.loss_sigmas)
                                                        : nullptr;
      problem.AddResidualBlock(
          internal::RelativePoseCost::Create(e.T_from_to, SqrtInformation(e.covariance)), loss,
          x[e.from].data(), x[e.to].data());
    }
    problem.AddParameterBlock(x[0].data(), 3);  // node 0 may have no edge of its own
    problem.SetParameterBlockConstant(x[0].data());
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.max_num_iterations = params.max_iterations;
    options.num_threads = 1;
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    ceres::Solver::Summary stage;
    ceres::Solve(options, &problem, &stage);
    if (first) result.initial_cost = stage.initial_cost;
    first = false;
    result.iterations += static_cast<int>(stage.iterations.size());
    summary = stage;
  }
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    poses_[i] = Pose2(x[i][0], x[i][1], NormalizeAngle(x[i][2]));
  }
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.final_cost = summary.final_cost;
  return result;
}

}  // namespace shape_slam
