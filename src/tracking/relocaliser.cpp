#include "sitepose/tracking/relocaliser.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <unordered_set>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <opencv2/calib3d.hpp>

#include "sitepose/features/hamming.hpp"
#include "sitepose/tracking/place_recognition.hpp"
#include "sitepose/tracking/pose_refinement.hpp"

namespace sitepose::tracking {
namespace {

// ORB-SLAM2 Relocalization's thresholds (METHOD.md "Core tracker").
constexpr int kMinInliersAfterPnp = 10;  // motion-only BA inliers to go on with a candidate
constexpr int kRelocalisationMinMatches = 15;
constexpr int kRelocalisationNeighbours = 5;      // covisible keyframes searched after PnP
constexpr double kRelocalisationRadiusPx = 10.0;  // ORB-SLAM2 Relocalization's projection search
constexpr int kRelocalisationGoodInliers = 50;    // fewer after PnP + BA: search by projection

RelocalisationCandidate relocalisation_candidate(const map::MapData& map, const map::KeyFrame& kf) {
  RelocalisationCandidate c;
  c.T_cam_world = kf.T_cam_world();
  std::set<map::PointId> seen;
  for (map::PointId pid : kf.point_of_keypoint) {
    if (const map::MapPoint* p = map.good_point(pid); p != nullptr && seen.insert(pid).second) {
      c.points.push_back(make_point_view(*p));
    }
  }
  c.neighbourhood_points = c.points;
  for (map::KeyFrameId id : map.best_covisible(kf.id, kRelocalisationNeighbours)) {
    const map::KeyFrame* neighbour = map.keyframe(id);
    if (neighbour == nullptr) continue;
    for (map::PointId pid : neighbour->point_of_keypoint) {
      if (const map::MapPoint* p = map.good_point(pid); p != nullptr && seen.insert(pid).second) {
        c.neighbourhood_points.push_back(make_point_view(*p));
      }
    }
  }
  return c;
}

std::optional<RelocalisationCandidate> relocalisation_candidate(const map::SharedMap& shared_map,
                                                                map::KeyFrameId id) {
  return shared_map.read([&](const map::MapData& map) -> std::optional<RelocalisationCandidate> {
    const map::KeyFrame* kf = map.keyframe(id);
    if (kf == nullptr || kf->bad) return std::nullopt;
    return relocalisation_candidate(map, *kf);
  });
}

// Brute-force descriptor matches of the usable keypoints to `points`
// (ratio test 0.75): per keypoint the point index or -1, and the 3D-2D pairs
// for PnP with the keypoint of each.
struct DescriptorMatches {
  std::vector<int> match;
  std::vector<cv::Point3d> object_points;
  std::vector<cv::Point2d> image_points;
  std::vector<int> keypoint_of_pair;
};

DescriptorMatches match_descriptors(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                    const std::vector<PointView>& points) {
  DescriptorMatches out;
  out.match.assign(frame.size(), -1);
  const auto descriptor_of = [&](int i) { return points[i].descriptor.data(); };
  for (int k = 0; k < frame.size(); ++k) {
    if (!usable[k]) continue;
    const features::NearestTwo nearest = features::nearest_two(
        frame.features.descriptors.ptr<std::uint8_t>(k), static_cast<int>(points.size()), descriptor_of);
    if (nearest.index < 0 || nearest.distance > kDescriptorDistanceLow ||
        nearest.distance > 0.75 * nearest.second_distance) {
      continue;
    }
    out.match[k] = nearest.index;
    const Eigen::Vector3d& p = points[nearest.index].p_world;
    out.object_points.emplace_back(p.x(), p.y(), p.z());
    out.image_points.emplace_back(frame.uv_px[k].x(), frame.uv_px[k].y());
    out.keypoint_of_pair.push_back(k);
  }
  return out;
}

// PnP RANSAC from T_cam_world_init; nullopt when it fails or keeps fewer
// than kRelocalisationMinMatches inliers (indices into the pairs).
std::optional<SE3> pnp_pose(const DescriptorMatches& pairs, const StereoCamera& camera,
                            const SE3& T_cam_world_init, std::vector<int>& inliers) {
  const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  cv::Mat rvec, tvec;
  const Eigen::Matrix3d R0 = T_cam_world_init.rotation_matrix();
  cv::Mat R0_cv(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) R0_cv.at<double>(r, col) = R0(r, col);
  cv::Rodrigues(R0_cv, rvec);
  tvec = (cv::Mat_<double>(3, 1) << T_cam_world_init.translation().x(), T_cam_world_init.translation().y(),
          T_cam_world_init.translation().z());
  if (!cv::solvePnPRansac(pairs.object_points, pairs.image_points, K, cv::noArray(), rvec, tvec, true, 200,
                          4.0, 0.99, inliers, cv::SOLVEPNP_ITERATIVE) ||
      static_cast<int>(inliers.size()) < kRelocalisationMinMatches) {
    return std::nullopt;
  }
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) R(r, col) = R_cv.at<double>(r, col);
  return SE3(R, Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
}

// Two verified relocalisations farther apart than this are two places (a
// repeated scene), not one seen from two keyframes.
constexpr double kDistinctPlacesM = 0.5;

double distance_m(const PassResult& a, const SE3& T_cam_world) {
  return (a.T_cam_world.inverse().translation() - T_cam_world.inverse().translation()).norm();
}

// A candidate keyframe within a few metres of a verified pose is the same
// place seen from nearby; it would only repeat the verification.
bool accepted_near(const PassResult& accepted, const SE3& T_cam_world_keyframe) {
  return distance_m(accepted, T_cam_world_keyframe) < 2.0;
}

}  // namespace

double position_sigma_m(const PassResult& result) {
  if (!result.covariance_world_cam) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(
      result.covariance_world_cam->topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
}

bool precise_pose(const PassResult& result, int min_inliers_ok) {
  return result.n_inliers >= min_inliers_ok && position_sigma_m(result) <= kMaxOkPositionSigmaM;
}

int close_inliers(const PreparedFrame& frame, const PassResult& result, double close_depth_m) {
  int n = 0;
  const int keypoints = std::min(frame.size(), static_cast<int>(result.point_of_keypoint.size()));
  for (int k = 0; k < keypoints; ++k) {
    if (result.point_of_keypoint[k] != map::kNoPoint && frame.has_close_depth(k, close_depth_m)) ++n;
  }
  return n;
}

double found_share(const PassResult& result) {
  if (result.visible_points.empty()) return 0.0;
  return static_cast<double>(result.n_inliers) / static_cast<double>(result.visible_points.size());
}

std::optional<double> far_found_share(const map::MapData& map, const PassResult& result) {
  const std::unordered_set<map::PointId> inliers(result.point_of_keypoint.begin(),
                                                 result.point_of_keypoint.end());
  int in_view = 0;
  int found = 0;
  for (const map::PointId id : result.visible_points) {
    const map::MapPoint* point = map.good_point(id);
    if (point == nullptr || (result.T_cam_world * point->p_world).z() < kFarPointDepthM) continue;
    ++in_view;
    if (inliers.count(id) != 0) ++found;
  }
  if (in_view < kMinFarPointsInView) return std::nullopt;
  return static_cast<double>(found) / static_cast<double>(in_view);
}

bool finds_distant_background(const map::MapData& map, const PassResult& result) {
  const std::optional<double> share = far_found_share(map, result);
  return !share || *share >= kMinRelocalisationFarFoundShare;
}

double map_aware_position_sigma_m(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                  const PreparedFrame& frame, const map::MapData& map,
                                  const PassResult& result) {
  const map::KeyFrameId unconfirmed_since = map.joined_unconfirmed_since();
  // Pose parameters: camera centre in the world (3), rotation on the left of
  // R_cam_world (3). p_cam = R_cam_world (p_world - c).
  const Eigen::Matrix3d R = result.T_cam_world.rotation_matrix();
  const Eigen::Vector3d c = result.T_cam_world.inverse().translation();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  for (int k = 0; k < frame.size(); ++k) {
    const map::MapPoint* point = map.good_point(result.point_of_keypoint[k]);
    if (point == nullptr) continue;
    if (unconfirmed_since != map::kNoKeyFrame && point->first_keyframe >= unconfirmed_since) continue;
    const Eigen::Vector3d p = R * (point->p_world - c);
    if (p.z() <= 0.0) continue;
    const double z = p.z();
    const double distance_m = (point->p_world - c).norm();
    const Eigen::Vector3d& n = point->normal;
    const double along = distance_m * distance_m / camera.bf();
    const double across = distance_m / camera.fx;
    const Eigen::Matrix3d point_covariance =
        along * along * n * n.transpose() +
        across * across * (Eigen::Matrix3d::Identity() - n * n.transpose());
    const bool stereo = frame.features.u_right[k] >= 0.0;
    Eigen::Matrix<double, 3, 3> J_proj;
    J_proj << camera.fx / z, 0.0, -camera.fx * p.x() / (z * z), 0.0, camera.fy / z,
        -camera.fy * p.y() / (z * z), camera.fx / z, 0.0, -(camera.fx * p.x() - camera.bf()) / (z * z);
    Eigen::Matrix<double, 3, 6> J_pose;
    J_pose.leftCols<3>() = -R;
    J_pose.rightCols<3>() = -hat(p);
    const int rows = stereo ? 3 : 2;
    const Eigen::MatrixXd J_obs_proj = J_proj.topRows(rows);
    const double s = pyramid.scale(frame.octave[k]);
    const Eigen::MatrixXd noise = s * s * Eigen::MatrixXd::Identity(rows, rows) +
                                  J_obs_proj * R * point_covariance * R.transpose() * J_obs_proj.transpose();
    const Eigen::MatrixXd J = J_obs_proj * J_pose;
    information += J.transpose() * noise.ldlt().solve(J);
  }
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(information);
  if (!lu.isInvertible()) return std::numeric_limits<double>::infinity();
  const Eigen::Matrix3d position = lu.inverse().topLeftCorner<3, 3>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (position + position.transpose()),
                                                             Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
}

Relocaliser::Relocaliser(const StereoCamera& camera, const config::TrackingConfig& tracking,
                         const map::ScalePyramid& pyramid)
    : camera_(camera),
      min_inliers_ok_(tracking.min_inliers_ok),
      motion_ba_(camera, tracking),
      pyramid_(pyramid) {}

bool Relocaliser::relocalise(const map::SharedMap& shared_map, const PreparedFrame& frame,
                             const std::vector<std::uint8_t>& usable, PassResult& result,
                             const Verify& verify, map::KeyFrameId only_before) const {
  // Candidates from the whole map, ranked by place recognition; per
  // candidate: brute-force descriptor matching, PnP RANSAC, motion-only BA,
  // then a projection search over its neighbourhood and BA again. The
  // caller tracks the local map next, and commit() keeps the state
  // RECOVERING until the pose has held for a few frames.
  const std::vector<map::KeyFrameId> places = candidate_places(shared_map, frame, usable, only_before);
  // Every candidate is tried: where the scene repeats (fence, containers,
  // site offices), two places can both give a precise pose, and then
  // neither is trusted; the next frame tries again.
  const PassResult initial = result;
  std::optional<PassResult> accepted;
  for (const map::KeyFrameId place : places) {
    const std::optional<RelocalisationCandidate> c = relocalisation_candidate(shared_map, place);
    if (!c) continue;
    if (accepted && accepted_near(*accepted, c->T_cam_world)) continue;  // same place, already verified
    PassResult attempt = initial;
    if (!relocalise_against(frame, usable, *c, attempt) || (verify && !verify(attempt))) continue;
    if (!accepted) {
      accepted = std::move(attempt);
    } else if (distance_m(*accepted, attempt.T_cam_world) > kDistinctPlacesM) {
      result = initial;
      return false;
    }
  }
  if (!accepted) return false;
  result = std::move(*accepted);
  result.relocalised = true;
  return true;
}

std::vector<map::KeyFrameId> Relocaliser::candidate_places(const map::SharedMap& shared_map,
                                                           const PreparedFrame& frame,
                                                           const std::vector<std::uint8_t>& usable,
                                                           map::KeyFrameId only_before) const {
  if (place_source_) return place_source_(shared_map, frame.features.descriptors, usable, only_before);
  const PlaceIndex index =
      shared_map.read([&](const map::MapData& map) { return make_place_index(map, only_before); });
  std::vector<map::KeyFrameId> places;
  for (const PlaceCandidate& c : rank_places(index, frame.features.descriptors, usable))
    places.push_back(c.keyframe);
  return places;
}

bool Relocaliser::track_against_keyframe(const map::SharedMap& map, const PreparedFrame& frame,
                                         const std::vector<std::uint8_t>& usable, map::KeyFrameId keyframe,
                                         PassResult& result) const {
  std::optional<RelocalisationCandidate> c = relocalisation_candidate(map, keyframe);
  if (!c) return false;
  PassResult attempt = result;
  if (!relocalise_against(frame, usable, *c, attempt)) {
    // The keyframe alone may share too little with a camera that moved on;
    // its covisible neighbours as well.
    c->points = c->neighbourhood_points;
    attempt = result;
    if (!relocalise_against(frame, usable, *c, attempt)) return false;
  }
  result = std::move(attempt);
  return true;
}

bool Relocaliser::relocalise_against(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                     const RelocalisationCandidate& c, PassResult& result) const {
  const DescriptorMatches pairs = match_descriptors(frame, usable, c.points);
  if (static_cast<int>(pairs.object_points.size()) < kRelocalisationMinMatches) return false;
  std::vector<int> inliers;
  const std::optional<SE3> pose = pnp_pose(pairs, camera_, c.T_cam_world, inliers);
  if (!pose) return false;
  std::vector<int> inlier_match(frame.size(), -1);
  for (int i : inliers) inlier_match[pairs.keypoint_of_pair[i]] = pairs.match[pairs.keypoint_of_pair[i]];
  result.T_cam_world = *pose;
  optimise_pose(motion_ba_, pyramid_, frame, c.points, inlier_match, result);
  if (result.n_inliers < kMinInliersAfterPnp) return false;
  if (result.n_inliers < kRelocalisationGoodInliers) {
    // Few inliers: look for more among the neighbourhood's points from the
    // pose found, keeping the inliers (the points list starts with c.points).
    std::vector<int> match(frame.size(), -1);
    for (int k = 0; k < frame.size(); ++k) {
      if (result.point_of_keypoint[k] != map::kNoPoint) match[k] = inlier_match[k];
    }
    SearchParams params;
    params.radius_px = kRelocalisationRadiusPx;
    search_by_projection(frame, camera_, pyramid_, result.T_cam_world, c.neighbourhood_points, usable, params,
                         match, nullptr);
    optimise_pose(motion_ba_, pyramid_, frame, c.neighbourhood_points, match, result);
  }
  return result.n_inliers >= min_inliers_ok_;
}

}  // namespace sitepose::tracking
