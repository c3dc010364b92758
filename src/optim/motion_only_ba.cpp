#include "sitepose/optim/motion_only_ba.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "sitepose/optim/pose_parameterization.hpp"
#include "sitepose/optim/reprojection_costs.hpp"

namespace sitepose::optim {
namespace {

// H is treated as rank deficient when its smallest eigenvalue is below this
// fraction of its largest (relative to double precision, with margin).
constexpr double kMinRelativeEigenvalue = 1e-12;

// Levenberg-Marquardt settings: Ceres's defaults for its trust-region LM with
// Jacobi scaling, so that the solver stops where the Ceres one it replaced
// did (motion_only_ba_test compares the two).
constexpr double kInitialTrustRegionRadius = 1e4;
constexpr double kMaxTrustRegionRadius = 1e16;
constexpr double kMinLmDiagonal = 1e-6;
constexpr double kMaxLmDiagonal = 1e32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kFunctionTolerance = 1e-6;
constexpr double kGradientTolerance = 1e-10;
constexpr double kParameterTolerance = 1e-8;

using Vector6 = Eigen::Matrix<double, 6, 1>;
using Jacobian3x6 = Eigen::Matrix<double, 3, 6>;

bool all_finite(const PoseObservation& o) {
  return o.p_world.allFinite() && o.uv_left_px.allFinite() && std::isfinite(o.u_right_px) &&
         std::isfinite(o.sigma2_px2);
}

Status validate(std::span<const PoseObservation> observations) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const PoseObservation& o = observations[i];
    if (!all_finite(o)) {
      return make_error(ErrorCode::kInvalidArgument,
                        "motion-only BA: observation " + std::to_string(i) +
                            " has a non-finite value; expected finite p_world, uv, u_right, sigma2");
    }
    if (!(o.sigma2_px2 > 0.0)) {
      return make_error(ErrorCode::kInvalidArgument, "motion-only BA: observation " + std::to_string(i) +
                                                         " has sigma2_px2 = " + std::to_string(o.sigma2_px2) +
                                                         "; expected > 0");
    }
  }
  return ok_status();
}

// Whitened residual of one observation at T_cam_world (rows 0-1 mono, 0-2
// stereo) and, when J is not null, its Jacobian for a left perturbation of
// T_cam_world (pose_parameterization.hpp). Returns the number of rows, 0 when
// the point is not in front of the camera.
int evaluate(const StereoCamera& camera, const PoseObservation& o, const SE3& T_cam_world,
             Eigen::Vector3d& residual, Jacobian3x6* J) {
  const Eigen::Vector3d p_cam = T_cam_world * o.p_world;
  const double sqrt_information = 1.0 / std::sqrt(o.sigma2_px2);
  if (o.is_stereo()) {
    Eigen::Matrix3d d_r_d_p;
    const Eigen::Vector3d observed(o.uv_left_px.x(), o.uv_left_px.y(), o.u_right_px);
    if (!whitened_reprojection<3>(camera, p_cam, observed, sqrt_information, &residual,
                                  J != nullptr ? &d_r_d_p : nullptr)) {
      return 0;
    }
    if (J != nullptr) {
      J->leftCols<3>() = d_r_d_p;
      J->rightCols<3>() = -d_r_d_p * hat(p_cam);
    }
    return 3;
  }
  Eigen::Vector2d r;
  Eigen::Matrix<double, 2, 3> d_r_d_p;
  if (!whitened_reprojection<2>(camera, p_cam, o.uv_left_px, sqrt_information, &r,
                                J != nullptr ? &d_r_d_p : nullptr)) {
    return 0;
  }
  residual << r, 0.0;
  if (J != nullptr) {
    J->topLeftCorner<2, 3>() = d_r_d_p;
    J->topRightCorner<2, 3>() = -d_r_d_p * hat(p_cam);
    J->row(2).setZero();
  }
  return 2;
}

// Whitened chi^2 of one observation at the pose; +inf when behind the camera.
double chi2_at(const StereoCamera& camera, const PoseObservation& o, const SE3& T_cam_world) {
  Eigen::Vector3d r;
  if (evaluate(camera, o, T_cam_world, r, nullptr) == 0) return std::numeric_limits<double>::infinity();
  return r.squaredNorm();
}

// The rounds of optimise -> re-label outliers (ORB-SLAM2's PoseOptimization).
struct Rounds {
  int rounds = 0;
  int iterations_per_round = 0;
  double chi2_mono = 0.0;
  double chi2_stereo = 0.0;
};

// Huber kernel on chi^2 = s with threshold delta^2 = gate (Ceres's HuberLoss
// with a = sqrt(gate)): rho(s) = s inside, 2 delta sqrt(s) - delta^2 outside;
// `weight` is rho'(s), the IRLS weight of the residual.
struct Robustified {
  double rho = 0.0;
  double weight = 1.0;
};

Robustified huber(double s, double gate) {
  if (s <= gate) return {s, 1.0};
  const double root = std::sqrt(s);
  const double delta = std::sqrt(gate);
  return {2.0 * delta * root - gate, delta / root};
}

// One round's problem: the active observations, optionally Huber-robust.
class RoundProblem {
 public:
  RoundProblem(const StereoCamera& camera, std::span<const PoseObservation> observations,
               const std::vector<std::uint8_t>& active, const Rounds& settings, bool robust)
      : camera_(camera), observations_(observations), active_(active), settings_(settings), robust_(robust) {}

  // 1/2 sum rho(chi^2) over the active observations (Ceres's cost); nullopt
  // when one of them is behind the camera at this pose.
  std::optional<double> cost(const SE3& T_cam_world) const {
    double sum = 0.0;
    Eigen::Vector3d r;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
      if (!active_[i]) continue;
      if (evaluate(camera_, observations_[i], T_cam_world, r, nullptr) == 0) return std::nullopt;
      sum += kernel(observations_[i], r.squaredNorm()).rho;
    }
    return 0.5 * sum;
  }

  // Normal equations of the IRLS-weighted residuals: H = sum w J^T J,
  // g = sum w J^T r (the gradient of the cost). False when an active
  // observation is behind the camera.
  bool linearise(const SE3& T_cam_world, Matrix6d& H, Vector6& g) const {
    H.setZero();
    g.setZero();
    Eigen::Vector3d r;
    Jacobian3x6 J;
    for (std::size_t i = 0; i < observations_.size(); ++i) {
      if (!active_[i]) continue;
      if (evaluate(camera_, observations_[i], T_cam_world, r, &J) == 0) return false;
      const double w = kernel(observations_[i], r.squaredNorm()).weight;
      H.noalias() += w * J.transpose() * J;
      g.noalias() += w * J.transpose() * r;
    }
    return true;
  }

 private:
  Robustified kernel(const PoseObservation& o, double chi2) const {
    if (!robust_) return {chi2, 1.0};
    return huber(chi2, o.is_stereo() ? settings_.chi2_stereo : settings_.chi2_mono);
  }

  const StereoCamera& camera_;
  std::span<const PoseObservation> observations_;
  const std::vector<std::uint8_t>& active_;
  const Rounds& settings_;
  bool robust_;
};

double ambient_norm(const SE3& T) {
  return std::sqrt(T.rotation().coeffs().squaredNorm() + T.translation().squaredNorm());
}

// Levenberg-Marquardt on the left-perturbed pose, at most `max_iterations`
// steps (rejected steps count, as in Ceres). Returns the steps taken.
int levenberg_marquardt(const RoundProblem& problem, int max_iterations, SE3& T_cam_world) {
  std::optional<double> cost = problem.cost(T_cam_world);
  if (!cost) return 0;  // the caller only activates observations in front
  Matrix6d H;
  Vector6 g;
  if (!problem.linearise(T_cam_world, H, g)) return 0;
  // Jacobi scaling of the columns, fixed from the first linearisation.
  const Vector6 scale = (Vector6::Ones().array() + H.diagonal().array().sqrt()).inverse().matrix();
  double radius = kInitialTrustRegionRadius;
  double decrease_factor = 2.0;
  int iterations = 0;
  while (iterations < max_iterations && g.lpNorm<Eigen::Infinity>() > kGradientTolerance) {
    ++iterations;
    // Damping diag(J^T J) / radius, clamped in the scaled columns.
    const Vector6 scaled_diagonal =
        (H.diagonal().array() * scale.array().square()).max(kMinLmDiagonal).min(kMaxLmDiagonal).matrix();
    Matrix6d damped = H;
    damped.diagonal().array() += scaled_diagonal.array() / scale.array().square() / radius;
    const Eigen::LDLT<Matrix6d> solver(damped);
    const Vector6 step = solver.solve(-g);
    const double model_decrease = -(g.dot(step) + 0.5 * step.dot(H * step));
    const bool step_solved = solver.info() == Eigen::Success && step.allFinite() && model_decrease > 0.0;
    const SE3 candidate = step_solved ? SE3::exp(step) * T_cam_world : T_cam_world;
    const std::optional<double> candidate_cost = step_solved ? problem.cost(candidate) : std::nullopt;
    // Converged: Ceres stops here without taking the (tiny) last step.
    if (candidate_cost) {
      if (step.norm() <= kParameterTolerance * (ambient_norm(T_cam_world) + kParameterTolerance)) break;
      if (std::abs(*cost - *candidate_cost) <= kFunctionTolerance * *cost) break;
    }
    const double quality = candidate_cost ? (*cost - *candidate_cost) / model_decrease : -1.0;
    // linearise() cannot fail where cost() succeeded (same observations, same pose).
    if (quality > kMinRelativeDecrease && problem.linearise(candidate, H, g)) {
      T_cam_world = candidate;
      cost = candidate_cost;
      radius = std::min(kMaxTrustRegionRadius,
                        radius / std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * quality - 1.0, 3)));
      decrease_factor = 2.0;
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
  }
  return iterations;
}

// chi2 and inlier flag of every observation at `T_cam_world` (+inf, behind
// the camera, fails the gate).
void classify_at(const StereoCamera& camera, std::span<const PoseObservation> observations,
                 const SE3& T_cam_world, const Rounds& settings, MotionBaResult& result) {
  for (std::size_t i = 0; i < observations.size(); ++i) {
    const double chi2 = chi2_at(camera, observations[i], T_cam_world);
    const double gate = observations[i].is_stereo() ? settings.chi2_stereo : settings.chi2_mono;
    result.chi2[i] = chi2;
    result.inlier[i] = chi2 <= gate ? 1 : 0;
  }
}

// Optimises the pose over the inliers, round after round, re-labelling after
// each; stops early when fewer than kMinObservationsToOptimise are left.
void optimise_in_rounds(const StereoCamera& camera, std::span<const PoseObservation> observations,
                        const Rounds& settings, SE3& T_cam_world, MotionBaResult& result) {
  for (int round = 0; round < settings.rounds; ++round) {
    int active = 0;
    for (std::uint8_t f : result.inlier) active += f;
    if (active < kMinObservationsToOptimise) break;
    // The last round has no kernel: the gates have already removed outliers.
    const bool robust = round + 1 < settings.rounds;
    const RoundProblem problem(camera, observations, result.inlier, settings, robust);
    result.iterations += levenberg_marquardt(problem, settings.iterations_per_round, T_cam_world);
    ++result.rounds_run;
    classify_at(camera, observations, T_cam_world, settings, result);
  }
  if (result.rounds_run == 0) classify_at(camera, observations, T_cam_world, settings, result);
}

// Inlier counts and chi2 statistics at the pose, the a-posteriori variance
// factor and the Hessian covariance of the inliers.
void summarise_inliers(const StereoCamera& camera, std::span<const PoseObservation> observations,
                       MotionBaResult& result) {
  Matrix6d H = Matrix6d::Zero();
  int inlier_residuals = 0;
  Eigen::Vector3d r;
  Jacobian3x6 J;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (!result.inlier[i]) continue;
    const PoseObservation& o = observations[i];
    ++result.num_inliers;
    ++(o.is_stereo() ? result.num_inliers_stereo : result.num_inliers_mono);
    result.chi2_inlier_sum += result.chi2[i];
    result.chi2_inlier_max = std::max(result.chi2_inlier_max, result.chi2[i]);
    const int rows = evaluate(camera, o, result.T_cam_world, r, &J);
    SITEPOSE_CHECK(rows > 0);  // inliers are in front
    inlier_residuals += rows;
    H.noalias() += J.transpose() * J;  // a mono observation's third row is zero
  }
  // Redundancy of at least 20 before the factor is trusted.
  if (inlier_residuals >= 26) result.variance_factor = result.chi2_inlier_sum / (inlier_residuals - 6);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(H);
  const double max_ev = eig.eigenvalues().maxCoeff();
  if (result.num_inliers > 0 && max_ev > 0.0 &&
      eig.eigenvalues().minCoeff() > kMinRelativeEigenvalue * max_ev) {
    const Matrix6d cov_cam_world =
        eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
    result.covariance_world_cam = left_covariance_of_inverse(result.T_cam_world, cov_cam_world);
  }
}

}  // namespace

MotionOnlyBa::MotionOnlyBa(const StereoCamera& camera, const config::TrackingConfig& tracking)
    : camera_(camera),
      rounds_(tracking.motion_ba_rounds),
      iterations_per_round_(tracking.motion_ba_iterations),
      chi2_mono_(tracking.chi2_mono),
      chi2_stereo_(tracking.chi2_stereo) {
  // The config loader enforces these; reaching here without them is a bug.
  SITEPOSE_CHECK(rounds_ >= 1 && iterations_per_round_ >= 1);
  SITEPOSE_CHECK(chi2_mono_ > 0.0 && chi2_stereo_ > 0.0);
}

Expected<MotionBaResult> MotionOnlyBa::solve(const SE3& T_cam_world_init,
                                             std::span<const PoseObservation> observations) const {
  SITEPOSE_TRY_STATUS(validate(observations));
  const std::size_t n = observations.size();
  MotionBaResult result;
  result.T_cam_world = T_cam_world_init;
  result.inlier.assign(n, 1);
  result.chi2.assign(n, 0.0);
  // Observations behind the predicted pose cannot start in the problem: the
  // cost must be finite at the initial point.
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isinf(chi2_at(camera_, observations[i], T_cam_world_init))) result.inlier[i] = 0;
  }
  const Rounds settings{rounds_, iterations_per_round_, chi2_mono_, chi2_stereo_};
  optimise_in_rounds(camera_, observations, settings, result.T_cam_world, result);
  summarise_inliers(camera_, observations, result);
  return result;
}

Expected<std::vector<std::uint8_t>> MotionOnlyBa::inliers_at(
    const SE3& T_cam_world, std::span<const PoseObservation> observations) const {
  SITEPOSE_TRY_STATUS(validate(observations));
  MotionBaResult result;
  result.inlier.assign(observations.size(), 0);
  result.chi2.assign(observations.size(), 0.0);
  classify_at(camera_, observations, T_cam_world,
              Rounds{rounds_, iterations_per_round_, chi2_mono_, chi2_stereo_}, result);
  return std::move(result.inlier);
}

}  // namespace sitepose::optim
