#pragma once
// Rigid (SE(3), no scale) least-squares alignment of point sets: Umeyama,
// "Least-squares estimation of transformation parameters between two point
// patterns", PAMI 1991, with the scale fixed to 1 (METHOD.md: the paper
// aligns with SE(3) Umeyama, evo-style). Pure computation.

#include <vector>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/se3.hpp"

namespace sitepose::eval {

// Returns T_dst_src minimising sum_i |p_dst[i] - T_dst_src * p_src[i]|^2.
// Closed form via the SVD of the cross-covariance; a reflection is never
// returned (det R = +1). For collinear points the rotation about the line is
// not observable; any minimiser is returned. Fails (kInvalidArgument) when
// the sizes differ or fewer than 3 pairs are given.
Expected<SE3> umeyama_se3(const std::vector<Eigen::Vector3d>& p_src,
                          const std::vector<Eigen::Vector3d>& p_dst);

}  // namespace sitepose::eval
