#include "shape_slam/alignment_refinement.h"

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>

#include "shape_slam/internal/model_segments.h"
#include "shape_slam/internal/point_to_segment_cost.h"
#include "shape_slam/internal/pose_prior_cost.h"

namespace shape_slam {
namespace {

using internal::ModelSegment;

// One sample associated with one model segment; the pair's weight scales its cost.
struct Association {
  Point2 sample_scan = Point2::Zero();
  int segment = -1;
  double weight = 1.0;

  bool operator==(const Association& other) const {
    return segment == other.segment && sample_scan == other.sample_scan && weight == other.weight;
  }
};

using Associator = std::function<std::vector<Association>(const Pose2& T_map_scan)>;

// The prior in the solver's frame (the map frame shifted by `origin`) with S^T S = Sigma^-1.
struct ShiftedPrior {
  Pose2 mean;
  Eigen::Matrix3d sqrt_information;
  double loss_sigmas = 0.0;  // PosePrior::loss_sigmas
};

// What one Ceres solve produced.
struct SolveOutcome {
  Pose2 T_map_scan;
  bool converged = false;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // J^T W J at the solution
  double rms_error_m = 0.0;
};

void RequirePositive(double value, const char* field) {
  if (!std::isfinite(value) || value <= 0.0) {
    throw std::invalid_argument(std::string("RefinementParams::") + field +
                                " must be finite and > 0");
  }
}

void RequireAtLeastOne(int value, const char* field) {
  if (value < 1)
    throw std::invalid_argument(std::string("RefinementParams::") + field + " must be >= 1");
}

// S with S^T S = covariance^-1, after checking that the covariance is a valid one.
Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& covariance) {
  const double scale = covariance.cwiseAbs().maxCoeff();
  const double asymmetry = (covariance - covariance.transpose()).cwiseAbs().maxCoeff();
  if (!covariance.allFinite() || !(scale > 0.0) || !(asymmetry <= 1e-9 * scale)) {
    throw std::invalid_argument("PosePrior::covariance must be finite and symmetric");
  }
  const Eigen::LLT<Eigen::Matrix3d> llt(covariance);
  if (llt.info() != Eigen::Success ||
      !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0.0)) {
    throw std::invalid_argument("PosePrior::covariance must be positive definite");
  }
  return llt.matrixL().solve(Eigen::Matrix3d::Identity());
}

std::optional<ShiftedPrior> ShiftPrior(const std::optional<PosePrior>& prior,
                                       const Point2& origin) {
  if (!prior) return std::nullopt;
  internal::CheckFinite(prior->T_map_scan, "PosePrior::T_map_scan");
  if (!(prior->loss_sigmas >= 0.0) || !std::isfinite(prior->loss_sigmas)) {
    throw std::invalid_argument("PosePrior::loss_sigmas must be >= 0 and finite");
  }
  const Point2 t = prior->T_map_scan.Translation() - origin;
  return ShiftedPrior{{t.x(), t.y(), prior->T_map_scan.theta}, SqrtInformation(prior->covariance),
                      prior->loss_sigmas};
}

std::unique_ptr<ceres::LossFunction> MakeLoss(const RefinementParams& params) {
  const double scale = params.loss_scale_m / params.point_sigma_m;  // residuals are whitened
  if (params.loss == RobustLoss::kHuber) return std::make_unique<ceres::HuberLoss>(scale);
  return std::make_unique<ceres::CauchyLoss>(scale);
}

ceres::Solver::Options SolverOptions(const RefinementParams& params) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = params.max_solver_iterations;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  options.minimizer_progress_to_stdout = false;
  options.function_tolerance = 1e-9;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-9;
  return options;
}

// The losses of the samples: the base loss, scaled by the pair's weight when it is not 1 (one
// ScaledLoss per distinct weight; pairs are few).
class LossBank {
 public:
  explicit LossBank(const RefinementParams& params) : base_(MakeLoss(params)) {}
  ceres::LossFunction* For(double weight) {
    if (weight == 1.0) return base_.get();
    for (const auto& [w, loss] : scaled_) {
      if (w == weight) return loss.get();
    }
    scaled_.emplace_back(weight, std::make_unique<ceres::ScaledLoss>(base_.get(), weight,
                                                                     ceres::DO_NOT_TAKE_OWNERSHIP));
    return scaled_.back().second.get();
  }

 private:
  std::unique_ptr<ceres::LossFunction> base_;
  std::vector<std::pair<double, std::unique_ptr<ceres::LossFunction>>> scaled_;
};

// Gauss-Newton information J^T W J of the samples at `pose` (W = rho'(s) of the robust loss,
// which includes the pair weight) and their RMS distance to the segments, metres.
std::pair<Eigen::Matrix3d, double> SampleInformation(
    const std::vector<ceres::CostFunction*>& costs, const std::vector<ceres::LossFunction*>& losses,
    const double* pose, double sigma_m) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  double sum_d2 = 0.0;
  Eigen::Matrix<double, 2, 3, Eigen::RowMajor> J;
  double* jacobians[] = {J.data()};
  for (std::size_t i = 0; i < costs.size(); ++i) {
    Eigen::Vector2d r;
    costs[i]->Evaluate(&pose, r.data(), jacobians);
    double rho[3];
    losses[i]->Evaluate(r.squaredNorm(), rho);
    information += rho[1] * J.transpose() * J;
    sum_d2 += r.squaredNorm() * sigma_m * sigma_m;
  }
  return {information, std::sqrt(sum_d2 / static_cast<double>(costs.size()))};
}

// The heavy-tailed prior (PosePrior::loss_sigmas) in two parts, as square roots of
// information: `held`, the directions in which the samples inform the pose less than the prior
// does (along a featureless corridor), stays Gaussian, since there the prior is all there is;
// `yielding`, the directions the samples constrain better, gets the Cauchy loss. In the prior's
// whitened coordinates u = S (pose - mean) the samples' information is S^-T H S^-1; its
// eigenvectors with eigenvalues below 1 span the held part. A Gaussian prior is held whole.
struct PriorParts {
  Eigen::Matrix3d held = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d yielding = Eigen::Matrix3d::Zero();
};

PriorParts SplitPrior(const ShiftedPrior& prior, const Eigen::Matrix3d& sample_information) {
  PriorParts parts;
  if (prior.loss_sigmas <= 0.0) {
    parts.held = prior.sqrt_information;
    return parts;
  }
  const Eigen::Matrix3d S_inv = prior.sqrt_information.inverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(S_inv.transpose() *
                                                            sample_information * S_inv);
  const Eigen::Matrix3d rotated = eigen.eigenvectors().transpose() * prior.sqrt_information;
  for (int i = 0; i < 3; ++i) {
    (eigen.eigenvalues()(i) < 1.0 ? parts.held : parts.yielding).row(i) = rotated.row(i);
  }
  return parts;
}

// The yielding part's weight rho'(s) in the covariance, as the samples' weights: the Cauchy
// loss's 1 / (1 + s / c^2) at its squared whitened distance s from the prior.
double YieldingWeight(const ShiftedPrior& prior, const PriorParts& parts, const double* pose) {
  if (prior.loss_sigmas <= 0.0) return 0.0;
  const Eigen::Vector3d d(pose[0] - prior.mean.x, pose[1] - prior.mean.y,
                          NormalizeAngle(pose[2] - prior.mean.theta));
  const double s = (parts.yielding * d).squaredNorm();
  return 1.0 / (1.0 + s / (prior.loss_sigmas * prior.loss_sigmas));
}

// One Ceres solve of the associated samples (and the prior) starting at T_map_scan. The pose
// parameters are relative to `origin` so that the solver's relative tolerances and the
// residuals stay accurate far from the map origin.
SolveOutcome Solve(const std::vector<Association>& associations,
                   const std::vector<ModelSegment>& segments, const Pose2& T_map_scan,
                   const Point2& origin, const std::optional<ShiftedPrior>& prior,
                   const RefinementParams& params) {
  double pose[3] = {T_map_scan.x - origin.x(), T_map_scan.y - origin.y(), T_map_scan.theta};
  LossBank loss_bank(params);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.disable_all_safety_checks = true;
  // The costs outlive the problem, which does not own them.
  std::deque<internal::PointToSegmentCost> sample_costs;  // stable addresses, few allocations
  std::unique_ptr<ceres::CostFunction> held_cost, yielding_cost;
  std::optional<ceres::CauchyLoss> prior_loss;  // heavy-tailed prior (PosePrior::loss_sigmas)
  PriorParts parts;
  ceres::Problem problem(problem_options);
  std::vector<ceres::CostFunction*> costs;
  std::vector<ceres::LossFunction*> losses;
  costs.reserve(associations.size());
  losses.reserve(associations.size());
  for (const Association& a : associations) {
    const ModelSegment& s = segments[static_cast<std::size_t>(a.segment)];
    costs.push_back(&sample_costs.emplace_back(a.sample_scan, s.a - origin, s.b() - origin,
                                               params.point_sigma_m));
    losses.push_back(loss_bank.For(a.weight));
    problem.AddResidualBlock(costs.back(), losses.back(), pose);
  }
  if (prior) {
    parts = SplitPrior(*prior, prior->loss_sigmas > 0.0
                                   ? SampleInformation(costs, losses, pose, params.point_sigma_m).first
                                   : Eigen::Matrix3d::Zero());
    held_cost.reset(internal::PosePriorCost::Create(prior->mean, parts.held));
    problem.AddResidualBlock(held_cost.get(), nullptr, pose);
    if (prior->loss_sigmas > 0.0) {
      prior_loss.emplace(prior->loss_sigmas);
      yielding_cost.reset(internal::PosePriorCost::Create(prior->mean, parts.yielding));
      problem.AddResidualBlock(yielding_cost.get(), &*prior_loss, pose);
    }
  }
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(params), &problem, &summary);
  SolveOutcome outcome;
  outcome.T_map_scan = {pose[0] + origin.x(), pose[1] + origin.y(), NormalizeAngle(pose[2])};
  outcome.converged = summary.termination_type == ceres::CONVERGENCE;
  std::tie(outcome.information, outcome.rms_error_m) =
      SampleInformation(costs, losses, pose, params.point_sigma_m);
  if (prior) {
    outcome.information += parts.held.transpose() * parts.held +
                           YieldingWeight(*prior, parts, pose) * parts.yielding.transpose() *
                               parts.yielding;
  }
  return outcome;
}

// Inverse of the information with its eigenvalues floored at 1 / kUnconstrainedVariance.
Eigen::Matrix3d Covariance(const Eigen::Matrix3d& information) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(information);
  const Eigen::Vector3d variances =
      eigen.eigenvalues().cwiseMax(1.0 / kUnconstrainedVariance).cwiseInverse();
  const Eigen::Matrix3d covariance =
      eigen.eigenvectors() * variances.asDiagonal() * eigen.eigenvectors().transpose();
  return 0.5 * (covariance + covariance.transpose());
}

// The outer loop: associate at the current pose, solve, repeat until the association is stable.
RefinementResult Refine(const Associator& associate, const std::vector<ModelSegment>& segments,
                        const Pose2& T_map_scan_init, const std::optional<PosePrior>& prior,
                        const RefinementParams& params) {
  const Point2 origin = T_map_scan_init.Translation();
  const std::optional<ShiftedPrior> shifted_prior = ShiftPrior(prior, origin);
  RefinementResult result;
  result.T_map_scan = T_map_scan_init;
  std::vector<Association> used;
  SolveOutcome last;
  for (int outer = 0; outer < params.outer_iterations; ++outer) {
    std::vector<Association> current = associate(result.T_map_scan);
    if (current.empty() || (result.iterations > 0 && current == used)) break;
    last = Solve(current, segments, result.T_map_scan, origin, shifted_prior, params);
    result.T_map_scan = last.T_map_scan;
    used = std::move(current);
    ++result.iterations;
  }
  if (result.iterations == 0) return result;  // nothing associated: initial pose, unconstrained
  result.num_residuals = static_cast<int>(used.size());
  result.rms_error_m = last.rms_error_m;
  result.covariance = Covariance(last.information);
  result.converged = last.converged && result.num_residuals >= params.min_correspondences;
  return result;
}

}  // namespace

void RefinementParams::Validate() const {
  RequirePositive(loss_scale_m, "loss_scale_m");
  if (loss != RobustLoss::kHuber && loss != RobustLoss::kCauchy) {
    throw std::invalid_argument("RefinementParams::loss is not a RobustLoss value");
  }
  RequirePositive(point_sigma_m, "point_sigma_m");
  RequirePositive(max_correspondence_distance_m, "max_correspondence_distance_m");
  RequireAtLeastOne(outer_iterations, "outer_iterations");
  RequireAtLeastOne(max_solver_iterations, "max_solver_iterations");
  RequireAtLeastOne(min_correspondences, "min_correspondences");
  RequirePositive(sample_spacing_m, "sample_spacing_m");
}

RefinementResult RefineAlignment(const std::vector<Point2>& samples_scan,
                                 const std::vector<Polyline>& model_map,
                                 const Pose2& T_map_scan_init,
                                 const std::optional<PosePrior>& prior,
                                 const RefinementParams& params) {
  params.Validate();
  internal::CheckFinite(T_map_scan_init, "RefineAlignment: T_map_scan_init");
  internal::CheckFinite(samples_scan, "RefineAlignment: samples_scan");
  for (const Polyline& polyline : model_map)
    internal::CheckFinite(polyline, "RefineAlignment: model_map");
  const std::vector<ModelSegment> segments = internal::MakeModelSegments(model_map);
  const internal::SegmentGrid grid(segments, params.max_correspondence_distance_m);
  const bool reject_ends = params.reject_end_projections;
  const Associator associate = [&](const Pose2& T_map_scan) {
    std::vector<Association> associations;
    associations.reserve(samples_scan.size());
    const Eigen::Matrix2d R = T_map_scan.Rotation();
    const Point2 t = T_map_scan.Translation();
    for (const Point2& p : samples_scan) {
      const internal::SegmentMatch m = grid.Nearest(R * p + t);
      if (m.segment < 0 || (reject_ends && m.beyond_end)) continue;
      associations.push_back({p, m.segment, 1.0});
    }
    return associations;
  };
  return Refine(associate, segments, T_map_scan_init, prior, params);
}

RefinementResult RefineAlignment(const std::vector<ShapePair>& pairs, const Pose2& T_map_scan_init,
                                 const std::optional<PosePrior>& prior,
                                 const RefinementParams& params) {
  params.Validate();
  internal::CheckFinite(T_map_scan_init, "RefineAlignment: T_map_scan_init");
  const internal::RestrictedProblem problem =
      internal::MakeRestrictedProblem(pairs, params.sample_spacing_m);
  const double gate2 = params.max_correspondence_distance_m * params.max_correspondence_distance_m;
  const bool reject_ends = params.reject_end_projections;
  const Associator associate = [&](const Pose2& T_map_scan) {
    std::vector<Association> associations;
    associations.reserve(problem.samples.size());
    const Eigen::Matrix2d R = T_map_scan.Rotation();
    const Point2 t = T_map_scan.Translation();
    for (const internal::RestrictedSample& s : problem.samples) {
      const internal::SegmentMatch m = internal::NearestSegment(
          R * s.point + t, problem.segments, s.segments_begin, s.segments_end, gate2);
      if (m.segment < 0 || (reject_ends && m.beyond_end)) continue;
      associations.push_back({s.point, m.segment, s.weight});
    }
    return associations;
  };
  return Refine(associate, problem.segments, T_map_scan_init, prior, params);
}

}  // namespace shape_slam
