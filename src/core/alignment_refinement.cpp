#include "shape_slam/alignment_refinement.h"

#include <ceres/loss_function.h>
#include <ceres/tiny_solver.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

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
};

// What one Ceres (TinySolver) solve produced.
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
  const Point2 t = prior->T_map_scan.Translation() - origin;
  return ShiftedPrior{{t.x(), t.y(), prior->T_map_scan.theta}, SqrtInformation(prior->covariance)};
}

std::unique_ptr<ceres::LossFunction> MakeLoss(const RefinementParams& params) {
  const double scale = params.loss_scale_m / params.point_sigma_m;  // residuals are whitened
  if (params.loss == RobustLoss::kHuber) return std::make_unique<ceres::HuberLoss>(scale);
  return std::make_unique<ceres::CauchyLoss>(scale);
}

// Ceres's correction of a residual block for its robust loss (internal/corrector.cc), so that
// the TinySolver's Gauss-Newton model is the one ceres::Solve builds: with s = |r|^2 and
// rho = (rho(s), rho'(s), rho''(s)),
//   r~ = sqrt(rho') / (1 - alpha) r,   J~ = sqrt(rho') (I - alpha r r^T / s) J,
// alpha the smaller root of alpha^2 / 2 - alpha - s rho'' / rho' = 0 where rho'' > 0, else 0
// (always 0 for Huber and Cauchy): J~^T r~ is the gradient of rho / 2, J~^T J~ its Hessian.
class LossCorrection {
 public:
  LossCorrection(double sq_norm, const double rho[3]) : sqrt_rho1_(std::sqrt(rho[1])) {
    if (sq_norm == 0.0 || rho[2] <= 0.0) {
      residual_scaling_ = sqrt_rho1_;
      return;
    }
    const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * sq_norm * rho[2] / rho[1]);
    residual_scaling_ = sqrt_rho1_ / (1.0 - alpha);
    alpha_sq_norm_ = alpha / sq_norm;
  }

  // J (2 x 3) from the uncorrected r, before CorrectResidual.
  void CorrectJacobian(const Eigen::Vector2d& r, Eigen::Matrix<double, 2, 3>& J) const {
    if (alpha_sq_norm_ != 0.0) J -= alpha_sq_norm_ * r * (r.transpose() * J);
    J *= sqrt_rho1_;
  }
  void CorrectResidual(Eigen::Vector2d& r) const { r *= residual_scaling_; }

 private:
  double sqrt_rho1_;
  double residual_scaling_ = 0.0;
  double alpha_sq_norm_ = 0.0;
};

// The whole problem of one solve as the single cost function of a ceres::TinySolver: with only
// 3 parameters and a few hundred samples, ceres::Solve's per-residual-block machinery cost more
// than the arithmetic. Residuals: 2 per sample (loss-corrected as above), 3 of the prior, and a
// last one, constant in the linear model, that carries the rest of the robust cost,
// sqrt(sum(rho - |r~|^2)): the squared norm of the vector is then twice Ceres's cost
// sum(rho) / 2 + |r_prior|^2 / 2, on which the solver accepts or rejects its steps as
// ceres::Solve does (rho >= |r~|^2 for losses that are concave in s, as Huber and Cauchy are).
class RefinementFunction {
 public:
  using Scalar = double;
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 3 };

  RefinementFunction(const std::vector<Association>& associations,
                     const std::vector<ModelSegment>& segments, const Point2& origin,
                     const std::optional<ShiftedPrior>& prior, const RefinementParams& params)
      : loss_(MakeLoss(params)) {
    weights_.reserve(associations.size());
    for (const Association& a : associations) {
      const ModelSegment& s = segments[static_cast<std::size_t>(a.segment)];
      costs_.emplace_back(a.sample_scan, s.a - origin, s.b() - origin, params.point_sigma_m);
      weights_.push_back(a.weight);
    }
    if (prior) prior_.reset(internal::PosePriorCost::Create(prior->mean, prior->sqrt_information));
  }

  int NumResiduals() const { return 2 * NumSamples() + (prior_ ? 3 : 0) + 1; }

  // |f|^2 at `pose`: twice Ceres's cost.
  double SquaredNorm(const double* pose) const {
    Eigen::VectorXd f(NumResiduals());
    (*this)(pose, f.data(), nullptr);
    return f.squaredNorm();
  }

  // Residuals and (when `jacobian` is not null) their column-major Jacobian at `pose`.
  bool operator()(const double* pose, double* residuals, double* jacobian) const {
    const int rows = NumResiduals();
    Eigen::Map<Eigen::VectorXd> f(residuals, rows);
    JacobianMap J(jacobian, rows, 3);  // not touched when null
    double rest = 0.0;                 // sum(rho - |r~|^2)
    for (int i = 0; i < NumSamples(); ++i) {
      Sample sample = EvaluateSample(i, pose);
      const LossCorrection correction(sample.r.squaredNorm(), sample.rho);
      if (jacobian) {
        correction.CorrectJacobian(sample.r, sample.J);
        J.middleRows<2>(2 * i) = sample.J;
      }
      correction.CorrectResidual(sample.r);
      f.segment<2>(2 * i) = sample.r;
      rest += sample.rho[0] - sample.r.squaredNorm();
    }
    if (prior_) EvaluatePrior(pose, residuals + 2 * NumSamples(), jacobian ? &J : nullptr);
    f[rows - 1] = std::sqrt(std::max(rest, 0.0));
    if (jacobian) J.row(rows - 1).setZero();
    return true;
  }

  // Gauss-Newton information J^T W J of the samples at `pose` (W = rho'(s) of the robust loss,
  // which includes the pair weight) and their RMS distance to the segments, metres.
  std::pair<Eigen::Matrix3d, double> SampleInformation(const double* pose, double sigma_m) const {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    double sum_d2 = 0.0;
    for (int i = 0; i < NumSamples(); ++i) {
      const Sample sample = EvaluateSample(i, pose);
      information += sample.rho[1] * sample.J.transpose() * sample.J;
      sum_d2 += sample.r.squaredNorm() * sigma_m * sigma_m;
    }
    return {information, std::sqrt(sum_d2 / static_cast<double>(NumSamples()))};
  }

 private:
  // One sample's residual, Jacobian and loss (scaled by the pair's weight, as ceres::ScaledLoss).
  struct Sample {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 3> J;
    double rho[3];
  };

  using JacobianMap = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3>>;

  int NumSamples() const { return static_cast<int>(costs_.size()); }

  Sample EvaluateSample(int i, const double* pose) const {
    Sample sample;
    Eigen::Matrix<double, 2, 3, Eigen::RowMajor> J;
    double* jacobians[] = {J.data()};
    costs_[static_cast<std::size_t>(i)].Evaluate(&pose, sample.r.data(), jacobians);
    sample.J = J;
    loss_->Evaluate(sample.r.squaredNorm(), sample.rho);
    for (double& rho_k : sample.rho) rho_k *= weights_[static_cast<std::size_t>(i)];
    return sample;
  }

  void EvaluatePrior(const double* pose, double* residuals, JacobianMap* J) const {
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> J_prior;
    double* jacobians[] = {J_prior.data()};
    prior_->Evaluate(&pose, residuals, J ? jacobians : nullptr);
    if (J) J->middleRows<3>(2 * NumSamples()) = J_prior;
  }

  std::deque<internal::PointToSegmentCost> costs_;  // not copyable: no vector
  std::vector<double> weights_;
  std::unique_ptr<ceres::LossFunction> loss_;
  std::unique_ptr<ceres::CostFunction> prior_;
};

using RefinementSolver = ceres::TinySolver<RefinementFunction>;

// Today's ceres::Solve tolerances. TinySolver counts its first evaluation as an iteration, hence
// the + 1 for the same number of steps. Its function tolerance is absolute, on the change of
// |f|^2 = 2 cost, where Ceres's is relative to the cost: hence 1e-9 times |f|^2 at the start
// (Ceres takes the current cost, a little lower). An absolute 1e-9 took more iterations than
// ceres::Solve and ran out of them on many slowly converging problems that Ceres had solved.
RefinementSolver::Options SolverOptions(const RefinementParams& params, double initial_norm2) {
  RefinementSolver::Options options;
  options.max_num_iterations = params.max_solver_iterations + 1;
  options.function_tolerance = 1e-9 * initial_norm2;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-9;
  return options;
}

// Only running out of iterations is ceres::Solve's NO_CONVERGENCE; the other stops are its
// CONVERGENCE (a cost below machine epsilon is an exact fit).
bool Converged(RefinementSolver::Status status) {
  return status != RefinementSolver::HIT_MAX_ITERATIONS;
}

// One Ceres (TinySolver) solve of the associated samples (and the prior) starting at
// T_map_scan. The pose parameters are relative to `origin` so that the solver's relative
// tolerances and the residuals stay accurate far from the map origin.
SolveOutcome Solve(const std::vector<Association>& associations,
                   const std::vector<ModelSegment>& segments, const Pose2& T_map_scan,
                   const Point2& origin, const std::optional<ShiftedPrior>& prior,
                   const RefinementParams& params) {
  const RefinementFunction function(associations, segments, origin, prior, params);
  Eigen::Vector3d pose(T_map_scan.x - origin.x(), T_map_scan.y - origin.y(), T_map_scan.theta);
  RefinementSolver solver;
  solver.options = SolverOptions(params, function.SquaredNorm(pose.data()));
  const RefinementSolver::Summary& summary = solver.Solve(function, &pose);
  SolveOutcome outcome;
  outcome.T_map_scan = {pose[0] + origin.x(), pose[1] + origin.y(), NormalizeAngle(pose[2])};
  outcome.converged = Converged(summary.status);
  std::tie(outcome.information, outcome.rms_error_m) =
      function.SampleInformation(pose.data(), params.point_sigma_m);
  if (prior) outcome.information += prior->sqrt_information.transpose() * prior->sqrt_information;
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
