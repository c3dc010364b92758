#include "sitepose/eval/alignment.hpp"

#include <fmt/format.h>
#include <Eigen/Geometry>

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
  Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(p_src.size()));
  Eigen::Matrix3Xd dst(3, static_cast<Eigen::Index>(p_dst.size()));
  for (std::size_t i = 0; i < p_src.size(); ++i) {
    src.col(static_cast<Eigen::Index>(i)) = p_src[i];
    dst.col(static_cast<Eigen::Index>(i)) = p_dst[i];
  }
  // Eigen's implementation of the paper, scale fixed to 1 (with_scaling
  // false); it guards against reflections the same way (det R = +1).
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  const Eigen::Matrix3d rotation = T.topLeftCorner<3, 3>();
  const Eigen::Vector3d translation = T.topRightCorner<3, 1>();
  return SE3(rotation, translation);
}

}  // namespace sitepose::eval
