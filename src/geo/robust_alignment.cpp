#include "sitepose/geo/robust_alignment.hpp"

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "sitepose/eval/alignment.hpp"

namespace sitepose::geo {

namespace {

// A minimal sample whose triangle is thinner than this (twice its area, m^2)
// cannot fix the rotation about the line through it.
constexpr double kMinSampleCrossNorm_m2 = 1e-4;

struct Scored {
  std::vector<bool> inlier;
  int count = 0;
  double sum_sq_m2 = 0.0;
};

Scored score(const SE3& T, const std::vector<Eigen::Vector3d>& p_src,
             const std::vector<Eigen::Vector3d>& p_dst, double threshold_m) {
  Scored s;
  s.inlier.assign(p_src.size(), false);
  const double threshold_sq = threshold_m * threshold_m;
  for (std::size_t i = 0; i < p_src.size(); ++i) {
    const double r_sq = (p_dst[i] - T * p_src[i]).squaredNorm();
    if (r_sq < threshold_sq) {
      s.inlier[i] = true;
      ++s.count;
      s.sum_sq_m2 += r_sq;
    }
  }
  return s;
}

bool better(const Scored& a, const Scored& b) {
  return a.count > b.count || (a.count == b.count && a.sum_sq_m2 < b.sum_sq_m2);
}

}  // namespace

Expected<RobustAlignment> robust_umeyama_se3(const std::vector<Eigen::Vector3d>& p_src,
                                             const std::vector<Eigen::Vector3d>& p_dst,
                                             const RobustAlignmentOptions& options) {
  if (p_src.size() != p_dst.size()) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("robust alignment: {} source points but {} destination points",
                                  p_src.size(), p_dst.size()));
  }
  if (p_src.size() < 3) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("robust alignment: {} point pairs, need at least 3", p_src.size()));
  }
  if (!(options.inlier_threshold_m > 0.0) || options.ransac_iterations < 1 ||
      options.max_refits < 0) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("robust alignment options: inlier_threshold_m = {} (must be > 0), "
                                  "ransac_iterations = {} (>= 1), max_refits = {} (>= 0)",
                                  options.inlier_threshold_m, options.ransac_iterations,
                                  options.max_refits));
  }

  const int n = static_cast<int>(p_src.size());
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  Scored best;
  SE3 best_T;
  for (int iteration = 0; iteration < options.ransac_iterations; ++iteration) {
    const int a = pick(rng);
    int b = pick(rng);
    int c = pick(rng);
    if (a == b || a == c || b == c) continue;
    const Eigen::Vector3d cross = (p_src[b] - p_src[a]).cross(p_src[c] - p_src[a]);
    if (cross.norm() < kMinSampleCrossNorm_m2) continue;
    auto T = eval::umeyama_se3({p_src[a], p_src[b], p_src[c]}, {p_dst[a], p_dst[b], p_dst[c]});
    if (!T) continue;
    Scored s = score(*T, p_src, p_dst, options.inlier_threshold_m);
    if (better(s, best)) {
      best = std::move(s);
      best_T = *T;
    }
  }
  if (best.count < 3) {
    return make_error(ErrorCode::kRuntime,
                      fmt::format("robust alignment: no 3-point sample out of {} pairs gathered 3 "
                                  "inliers within {} m (points collinear or inconsistent)",
                                  n, options.inlier_threshold_m));
  }

  // Refit on all inliers until the set is stable: the minimal-sample fit is
  // noisy, the least-squares fit over the inliers is not.
  for (int refit = 0; refit < options.max_refits; ++refit) {
    std::vector<Eigen::Vector3d> src, dst;
    for (int i = 0; i < n; ++i) {
      if (best.inlier[i]) {
        src.push_back(p_src[i]);
        dst.push_back(p_dst[i]);
      }
    }
    auto T = eval::umeyama_se3(src, dst);
    if (!T) break;
    Scored s = score(*T, p_src, p_dst, options.inlier_threshold_m);
    if (s.count < 3) break;
    const bool same_set = s.inlier == best.inlier;
    best = std::move(s);
    best_T = *T;
    if (same_set) break;
  }

  RobustAlignment out;
  out.T_dst_src = best_T;
  out.inlier = std::move(best.inlier);
  out.num_inliers = best.count;
  out.inlier_rms_m = std::sqrt(best.sum_sq_m2 / best.count);
  return out;
}

}  // namespace sitepose::geo
