#include "sitepose/tracking/relocaliser.hpp"

#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include <Eigen/Eigenvalues>
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

}  // namespace

double position_sigma_m(const PassResult& result) {
  if (!result.covariance_world_cam) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(
      result.covariance_world_cam->topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, eigen.eigenvalues().maxCoeff()));
}

Relocaliser::Relocaliser(const StereoCamera& camera, const config::TrackingConfig& tracking,
                         const map::ScalePyramid& pyramid)
    : camera_(camera),
      min_inliers_ok_(tracking.min_inliers_ok),
      motion_ba_(camera, tracking),
      pyramid_(pyramid) {}

bool Relocaliser::relocalise(const map::SharedMap& shared_map, const PreparedFrame& frame,
                             const std::vector<std::uint8_t>& usable, PassResult& result) const {
  // Candidates from the whole map, ranked by place recognition; per
  // candidate: brute-force descriptor matching, PnP RANSAC, motion-only BA,
  // then a projection search over its neighbourhood and BA again. The
  // caller tracks the local map next, and commit() keeps the state
  // RECOVERING until the pose has held for a few frames.
  const PlaceIndex index = shared_map.read([](const map::MapData& map) { return make_place_index(map); });
  const std::vector<PlaceCandidate> places = rank_places(index, frame.features.descriptors, usable);
  for (const PlaceCandidate& place : places) {
    const std::optional<RelocalisationCandidate> c =
        shared_map.read([&](const map::MapData& map) -> std::optional<RelocalisationCandidate> {
          const map::KeyFrame* kf = map.keyframe(place.keyframe);
          if (kf == nullptr || kf->bad) return std::nullopt;
          return relocalisation_candidate(map, *kf);
        });
    if (c && relocalise_against(frame, usable, *c, result)) {
      result.relocalised = true;
      return true;
    }
  }
  return false;
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
