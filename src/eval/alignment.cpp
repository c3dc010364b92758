#include "sitepose/eval/alignment.hpp"

#include <Eigen/SVD>
#include <fmt/format.h>

namespace sitepose::eval {

Expected<SE3> umeyama_se3(const std::vector<Eigen::Vector3d>& p_src,
                          const std::vector<Eigen::Vector3d>& p_dst) {
  if (p_src.size() != p_dst.size()) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("umeyama_se3: {} source points but {} destination points; "
                                  "expected equal counts",
                                  p_src.size(), p_dst.size()));
  }
  if (p_src.size() < 3) {
    return make_error(ErrorCode::kInvalidArgument,
                      fmt::format("umeyama_se3: {} point pairs; at least 3 are needed",
                                  p_src.size()));
  }
  const double n = static_cast<double>(p_src.size());
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_dst = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < p_src.size(); ++i) {
    mean_src += p_src[i];
    mean_dst += p_dst[i];
  }
  mean_src /= n;
  mean_dst /= n;
  // Cross-covariance Sigma = 1/n sum (y - mu_y)(x - mu_x)^T (Umeyama eq. 38).
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < p_src.size(); ++i) {
    sigma += (p_dst[i] - mean_dst) * (p_src[i] - mean_src).transpose();
  }
  sigma /= n;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // S flips the axis of the smallest singular value when U V^T would be a
  // reflection (Umeyama eq. 39/43), so det R = +1 always.
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s(2, 2) = -1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * s * svd.matrixV().transpose();
  const Eigen::Vector3d translation = mean_dst - rotation * mean_src;
  return SE3(rotation, translation);
}

}  // namespace sitepose::eval
