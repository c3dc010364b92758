#include "sitepose/loop/loop_verifier.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

#include "sitepose/loop/rigid_fit.hpp"
#include "sitepose/mapping/fuse.hpp"

namespace sitepose::loop {
namespace {

using Matrix23d = Eigen::Matrix<double, 2, 3>;
using Matrix26d = Eigen::Matrix<double, 2, 6>;

// One matched pair of stage 1 with what the residuals need.
struct Pair {
  int current_keypoint = -1;
  int candidate_keypoint = -1;
  map::PointId loop_point = map::kNoPoint;
  Eigen::Vector3d a_world;  // the candidate's point (world)
  Eigen::Vector3d b_cam;    // the current's point in the current camera
  Eigen::Vector2d uv_current;
  Eigen::Vector2d uv_candidate;
  double inv_sigma2_current = 1.0;
  double inv_sigma2_candidate = 1.0;
};

Matrix23d projection_jacobian(const StereoCamera& camera, const Eigen::Vector3d& p) {
  const double iz = 1.0 / p.z();
  Matrix23d J;
  J << camera.fx * iz, 0.0, -camera.fx * p.x() * iz * iz, 0.0, camera.fy * iz, -camera.fy * p.y() * iz * iz;
  return J;
}

// Squared reprojection errors at sigma of a pair under T_cam_world of the
// current keyframe (X); +inf when a point falls behind a camera.
std::pair<double, double> pair_errors(const StereoCamera& camera, const SE3& T_candidate_world, const SE3& X,
                                      const Pair& p) {
  constexpr double kBehind = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d in_current = X * p.a_world;
  const Eigen::Vector3d in_candidate = T_candidate_world * (X.inverse() * p.b_cam);
  if (!(in_current.z() > 0.0) || !(in_candidate.z() > 0.0)) return {kBehind, kBehind};
  const double e1 = (p.uv_current - camera.project(in_current)).squaredNorm() * p.inv_sigma2_current;
  const double e2 = (p.uv_candidate - camera.project(in_candidate)).squaredNorm() * p.inv_sigma2_candidate;
  return {e1, e2};
}

bool is_pair_inlier(const StereoCamera& camera, const SE3& T_candidate_world, const SE3& X, const Pair& p,
                    double chi2) {
  const auto [e1, e2] = pair_errors(camera, T_candidate_world, X, p);
  return e1 < chi2 && e2 < chi2;
}

std::vector<Pair> make_pairs(const map::ScalePyramid& pyramid, const LoopView& current,
                             const LoopView& candidate, const std::vector<std::pair<int, int>>& matches) {
  std::vector<Pair> pairs;
  for (const auto& [i, j] : matches) {
    const map::PointId pc = current.keyframe.point_of_keypoint[static_cast<std::size_t>(i)];
    const map::PointId pl = candidate.keyframe.point_of_keypoint[static_cast<std::size_t>(j)];
    const auto ic = current.p_world.find(pc);
    const auto il = candidate.p_world.find(pl);
    if (ic == current.p_world.end() || il == candidate.p_world.end()) continue;
    Pair p;
    p.current_keypoint = i;
    p.candidate_keypoint = j;
    p.loop_point = pl;
    p.a_world = il->second;
    p.b_cam = current.keyframe.T_cam_world * ic->second;
    const map::KeyPointData& kc = current.keyframe.keypoints[static_cast<std::size_t>(i)];
    const map::KeyPointData& kl = candidate.keyframe.keypoints[static_cast<std::size_t>(j)];
    p.uv_current = kc.uv_px;
    p.uv_candidate = kl.uv_px;
    p.inv_sigma2_current = 1.0 / std::pow(pyramid.scale(kc.octave), 2);
    p.inv_sigma2_candidate = 1.0 / std::pow(pyramid.scale(kl.octave), 2);
    pairs.push_back(p);
  }
  return pairs;
}

// Adds one weighted 2D residual r with Jacobian J (d r / d delta) to the
// normal equations, Huber-weighted at sqrt(chi2).
void accumulate(const Eigen::Vector2d& r, const Matrix26d& J, double inv_sigma2, double chi2, Matrix6d& H,
                Vector6d& g) {
  const double e = std::sqrt(r.squaredNorm() * inv_sigma2);
  const double huber = e <= std::sqrt(chi2) ? 1.0 : std::sqrt(chi2) / e;
  const double w = huber * inv_sigma2;
  H += w * J.transpose() * J;
  g += w * J.transpose() * r;
}

// Gauss-Newton on X = T_cam_world of the current keyframe, left
// perturbation X' = exp(delta) X (core/se3.hpp tangent order):
//   current view:   p = X a,                r = uv - pi(p),
//                   d r / d delta = -J_pi(p) [I, -hat(p)];
//   candidate view: q = T_kw X^-1 b,        r = uv - pi(q); X'^-1 = X^-1 exp(-delta), so
//                   d r / d delta = J_pi(q) R_kw R_X^T [I, -hat(b)].
SE3 refine_pose(const StereoCamera& camera, const SE3& T_candidate_world, SE3 X,
                const std::vector<Pair>& pairs, const std::vector<int>& use,
                const LoopVerifierParams& params) {
  const Eigen::Matrix3d R_kw = T_candidate_world.rotation_matrix();
  for (int it = 0; it < params.refine_iterations; ++it) {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    const SE3 X_inv = X.inverse();
    const Eigen::Matrix3d R_kw_Rxt = R_kw * X.rotation_matrix().transpose();
    for (int k : use) {
      const Pair& p = pairs[static_cast<std::size_t>(k)];
      const Eigen::Vector3d pc = X * p.a_world;
      const Eigen::Vector3d q = T_candidate_world * (X_inv * p.b_cam);
      if (!(pc.z() > 0.0) || !(q.z() > 0.0)) continue;
      Eigen::Matrix<double, 3, 6> dp;
      dp << Eigen::Matrix3d::Identity(), -hat(pc);
      accumulate(p.uv_current - camera.project(pc), -projection_jacobian(camera, pc) * dp,
                 p.inv_sigma2_current, params.chi2_inlier, H, g);
      Eigen::Matrix<double, 3, 6> db;
      db << Eigen::Matrix3d::Identity(), -hat(p.b_cam);
      accumulate(p.uv_candidate - camera.project(q), projection_jacobian(camera, q) * R_kw_Rxt * db,
                 p.inv_sigma2_candidate, params.chi2_inlier, H, g);
    }
    const Eigen::LDLT<Matrix6d> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    const Vector6d delta = ldlt.solve(-g);
    if (!delta.allFinite()) break;
    X = SE3::exp(delta) * X;
    if (delta.norm() < 1e-10) break;
  }
  return X;
}

std::vector<int> inliers_of(const StereoCamera& camera, const SE3& T_candidate_world, const SE3& X,
                            const std::vector<Pair>& pairs, double chi2) {
  std::vector<int> out;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (is_pair_inlier(camera, T_candidate_world, X, pairs[k], chi2)) out.push_back(static_cast<int>(k));
  }
  return out;
}

// The loop points the keyframe should see at its pose, with the tests of
// the fusion search (mapping/fuse.hpp): in front, in the image, within the
// scale range (0.8 min .. 1.2 max) and 60 degrees of the point's normal.
int visible_points(const StereoCamera& camera, const mapping::KeyFrameSnapshot& keyframe,
                   const std::vector<mapping::PointSnapshot>& points) {
  int n = 0;
  const Eigen::Vector3d centre = keyframe.camera_center();
  for (const mapping::PointSnapshot& p : points) {
    if (p.is_observed_by(keyframe.id)) continue;
    const Eigen::Vector3d p_cam = keyframe.T_cam_world * p.p_world;
    if (!(p_cam.z() > 0.0) || !camera.in_image(camera.project(p_cam))) continue;
    const Eigen::Vector3d view = p.p_world - centre;
    const double d = view.norm();
    if (d < 0.8 * p.min_distance_m || d > 1.2 * p.max_distance_m || view.dot(p.normal) < 0.5 * d) continue;
    ++n;
  }
  return n;
}

Error refused(const std::string& stage, int got, int needed) {
  return Error{ErrorCode::kNotFound,
               "loop refused at " + stage + ": " + std::to_string(got) + " < " + std::to_string(needed)};
}

}  // namespace

std::vector<std::pair<int, int>> match_keyframe_points(const LoopView& current, const LoopView& candidate,
                                                       const LoopVerifierParams& params) {
  std::vector<int> with_point;
  for (std::size_t j = 0; j < candidate.keyframe.keypoints.size(); ++j) {
    if (candidate.p_world.count(candidate.keyframe.point_of_keypoint[j]) != 0)
      with_point.push_back(static_cast<int>(j));
  }
  // Candidate keypoint -> (current keypoint, distance): one match each.
  std::unordered_map<int, std::pair<int, int>> best_of;
  for (std::size_t i = 0; i < current.keyframe.keypoints.size(); ++i) {
    if (current.p_world.count(current.keyframe.point_of_keypoint[i]) == 0) continue;
    const map::Descriptor& d = current.keyframe.keypoints[i].descriptor;
    int best = std::numeric_limits<int>::max();
    int second = std::numeric_limits<int>::max();
    int best_j = -1;
    for (int j : with_point) {
      const int dist =
          map::descriptor_distance(d, candidate.keyframe.keypoints[static_cast<std::size_t>(j)].descriptor);
      if (dist < best) {
        second = best;
        best = dist;
        best_j = j;
      } else if (dist < second) {
        second = dist;
      }
    }
    if (best_j < 0 || best > params.max_descriptor_distance) continue;
    if (static_cast<double>(best) >= params.ratio * static_cast<double>(second)) continue;
    const auto it = best_of.find(best_j);
    if (it == best_of.end() || best < it->second.second) best_of[best_j] = {static_cast<int>(i), best};
  }
  std::vector<std::pair<int, int>> out;
  out.reserve(best_of.size());
  for (const auto& [j, m] : best_of) out.emplace_back(m.first, j);
  std::sort(out.begin(), out.end());
  return out;
}

Expected<VerifiedLoop> verify_loop(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                   const LoopView& current, const LoopView& candidate,
                                   const std::vector<mapping::PointSnapshot>& loop_points,
                                   const LoopVerifierParams& params) {
  VerifiedLoop out;
  out.candidate = candidate.keyframe.id;
  const std::vector<Pair> pairs =
      make_pairs(pyramid, current, candidate, match_keyframe_points(current, candidate, params));
  out.descriptor_matches = static_cast<int>(pairs.size());
  if (out.descriptor_matches < params.min_descriptor_matches) {
    return Unexpected{refused("descriptor matching", out.descriptor_matches, params.min_descriptor_matches)};
  }
  std::vector<Eigen::Vector3d> a;
  std::vector<Eigen::Vector3d> b;
  for (const Pair& p : pairs) {
    a.push_back(p.a_world);
    b.push_back(p.b_cam);
  }
  const SE3& T_kw = candidate.keyframe.T_cam_world;
  RigidRansacParams ransac;
  ransac.max_iterations = params.ransac_iterations;
  ransac.min_inliers = params.min_ransac_inliers;
  const Expected<RigidRansacResult> fit = ransac_rigid(
      a, b,
      [&](const SE3& T_world_cam, int k) {
        return is_pair_inlier(camera, T_kw, T_world_cam.inverse(), pairs[static_cast<std::size_t>(k)],
                              params.chi2_inlier);
      },
      ransac);
  if (!fit) return Unexpected{Error{ErrorCode::kNotFound, "loop refused at RANSAC: " + fit.error().message}};
  out.ransac_inliers = static_cast<int>(fit->inliers.size());
  const SE3 X = refine_pose(camera, T_kw, fit->T_a_b.inverse(), pairs, fit->inliers, params);
  const std::vector<int> inliers = inliers_of(camera, T_kw, X, pairs, params.chi2_inlier);
  out.refined_inliers = static_cast<int>(inliers.size());
  if (out.refined_inliers < params.min_refined_inliers) {
    return Unexpected{refused("refinement", out.refined_inliers, params.min_refined_inliers)};
  }
  out.T_world_cam = X.inverse();
  std::unordered_set<int> matched_keypoints;
  std::unordered_set<map::PointId> matched_points;
  for (int k : inliers) {
    const Pair& p = pairs[static_cast<std::size_t>(k)];
    out.matches.push_back({p.current_keypoint, p.loop_point});
    matched_keypoints.insert(p.current_keypoint);
    matched_points.insert(p.loop_point);
  }
  mapping::KeyFrameSnapshot moved = current.keyframe;
  moved.T_cam_world = X;
  moved.T_world_cam = out.T_world_cam;
  mapping::FuseParams guided;
  guided.radius_scale = params.guided_radius_scale;
  guided.max_descriptor_distance = params.max_descriptor_distance;
  std::vector<mapping::FuseProposal> proposals = mapping::fuse_into_keyframe(
      camera, pyramid, moved, mapping::make_keypoint_grid(camera, moved), loop_points, guided);
  std::sort(
      proposals.begin(), proposals.end(),
      [](const mapping::FuseProposal& x, const mapping::FuseProposal& y) { return x.distance < y.distance; });
  for (const mapping::FuseProposal& p : proposals) {
    if (matched_points.count(p.point) != 0 || !matched_keypoints.insert(p.index).second) continue;
    matched_points.insert(p.point);
    out.matches.push_back({p.index, p.point});
  }
  const int total = static_cast<int>(out.matches.size());
  if (total < params.min_total_matches)
    return Unexpected{refused("guided matching", total, params.min_total_matches)};
  out.visible_loop_points = visible_points(camera, moved, loop_points);
  if (static_cast<double>(total) < params.min_match_ratio * out.visible_loop_points) {
    return Unexpected{Error{ErrorCode::kNotFound,
                            "loop refused at the match ratio: " + std::to_string(total) + " of " +
                                std::to_string(out.visible_loop_points) + " loop points in view matched"}};
  }
  return out;
}

}  // namespace sitepose::loop
