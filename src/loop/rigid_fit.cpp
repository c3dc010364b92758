#include "sitepose/loop/rigid_fit.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "sitepose/eval/alignment.hpp"

namespace sitepose::loop {
namespace {

// Second singular value of the centred cross-covariance below this share of
// the first: the points lie on a line.
constexpr double kMinSingularRatio = 1e-9;

std::vector<int> count_inliers(const SE3& T_a_b, int n,
                               const std::function<bool(const SE3&, int)>& is_inlier) {
  std::vector<int> inliers;
  for (int i = 0; i < n; ++i) {
    if (is_inlier(T_a_b, i)) inliers.push_back(i);
  }
  return inliers;
}

// Samples needed so that one has only inliers with `probability`, at the
// inlier share seen so far (3 points a sample).
int iterations_needed(double inlier_share, double probability, int cap) {
  const double all_inliers = std::pow(inlier_share, 3);
  if (all_inliers >= 1.0) return 1;
  if (all_inliers <= 0.0) return cap;
  const double n = std::log(1.0 - probability) / std::log(1.0 - all_inliers);
  return static_cast<int>(std::min<double>(cap, std::ceil(n)));
}

}  // namespace

Expected<SE3> fit_rigid(const std::vector<Eigen::Vector3d>& p_a, const std::vector<Eigen::Vector3d>& p_b) {
  if (p_a.size() != p_b.size() || p_a.size() < 3) {
    return make_error(ErrorCode::kInvalidArgument, "rigid fit: needs >= 3 pairs of points, got " +
                                                       std::to_string(p_a.size()) + " and " +
                                                       std::to_string(p_b.size()));
  }
  // The collinearity guard needs only the cross-covariance's singular
  // values; the fit itself is eval's Umeyama (scale fixed to 1).
  Eigen::Vector3d c_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d c_b = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p_a.size(); ++i) {
    c_a += p_a[i];
    c_b += p_b[i];
  }
  c_a /= static_cast<double>(p_a.size());
  c_b /= static_cast<double>(p_b.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p_a.size(); ++i) H += (p_b[i] - c_b) * (p_a[i] - c_a).transpose();
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(H).singularValues();
  if (!(s(0) > 0.0) || s(1) < kMinSingularRatio * s(0)) {
    return make_error(ErrorCode::kInvalidArgument, "rigid fit: the points are (nearly) collinear");
  }
  return eval::umeyama_se3(p_b, p_a);
}

Expected<RigidRansacResult> ransac_rigid(const std::vector<Eigen::Vector3d>& p_a,
                                         const std::vector<Eigen::Vector3d>& p_b,
                                         const std::function<bool(const SE3&, int)>& is_inlier,
                                         const RigidRansacParams& params) {
  const int n = static_cast<int>(p_a.size());
  if (static_cast<int>(p_b.size()) != n || n < 3) {
    return make_error(ErrorCode::kInvalidArgument, "rigid RANSAC: needs >= 3 pairs of points");
  }
  std::mt19937_64 rng(params.seed);
  std::vector<int> order(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = i;
  RigidRansacResult best;
  int budget = params.max_iterations;
  int it = 0;
  for (; it < budget; ++it) {
    // Three distinct pairs: a partial Fisher-Yates shuffle.
    std::vector<Eigen::Vector3d> a(3);
    std::vector<Eigen::Vector3d> b(3);
    for (int k = 0; k < 3; ++k) {
      std::uniform_int_distribution<int> pick(k, n - 1);
      std::swap(order[static_cast<std::size_t>(k)], order[static_cast<std::size_t>(pick(rng))]);
      a[static_cast<std::size_t>(k)] = p_a[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])];
      b[static_cast<std::size_t>(k)] = p_b[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])];
    }
    const Expected<SE3> T = fit_rigid(a, b);
    if (!T) continue;
    std::vector<int> inliers = count_inliers(*T, n, is_inlier);
    if (inliers.size() > best.inliers.size()) {
      best.T_a_b = *T;
      best.inliers = std::move(inliers);
      budget = std::min(budget, iterations_needed(static_cast<double>(best.inliers.size()) / n,
                                                  params.probability, params.max_iterations));
    }
  }
  best.iterations = it;
  if (static_cast<int>(best.inliers.size()) < params.min_inliers) {
    return make_error(ErrorCode::kNotFound, "rigid RANSAC: best hypothesis has " +
                                                std::to_string(best.inliers.size()) + " inliers of " +
                                                std::to_string(n) + ", needs " +
                                                std::to_string(params.min_inliers));
  }
  std::vector<Eigen::Vector3d> a;
  std::vector<Eigen::Vector3d> b;
  for (int i : best.inliers) {
    a.push_back(p_a[static_cast<std::size_t>(i)]);
    b.push_back(p_b[static_cast<std::size_t>(i)]);
  }
  if (const Expected<SE3> refit = fit_rigid(a, b); refit) {
    std::vector<int> inliers = count_inliers(*refit, n, is_inlier);
    if (inliers.size() >= best.inliers.size()) {
      best.T_a_b = *refit;
      best.inliers = std::move(inliers);
    }
  }
  return best;
}

}  // namespace sitepose::loop
