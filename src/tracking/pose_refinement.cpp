#include "sitepose/tracking/pose_refinement.hpp"

#include "sitepose/core/stopwatch.hpp"

namespace sitepose::tracking {
namespace {

optim::PoseObservation observation_of(const map::ScalePyramid& pyramid, const PreparedFrame& frame, int k,
                                      const PointView& point) {
  optim::PoseObservation obs;
  obs.p_world = point.p_world;
  obs.uv_left_px = frame.uv_px[k];
  obs.u_right_px = frame.features.u_right[k];
  obs.sigma2_px2 = pyramid.scale(frame.octave[k]) * pyramid.scale(frame.octave[k]);
  return obs;
}

bool established(const PointView& point) { return point.observed_span_s >= kEstablishedSpanS; }

// Established points the frame could match: in the image and seen from
// within their viewing range (a point seen only from another side or
// another scale cannot be matched, so it does not count as hidden: in a
// turn the structures the map saw head-on are in the image at a slant).
int established_in_view(const StereoCamera& camera, const std::vector<PointView>& points,
                        const SE3& T_cam_world) {
  const Eigen::Vector3d camera_center = T_cam_world.inverse().translation();
  int n = 0;
  for (const PointView& point : points) {
    if (!established(point)) continue;
    const Eigen::Vector3d p_cam = T_cam_world * point.p_world;
    if (p_cam.z() > 0.0 && camera.in_image(camera.project(p_cam)) &&
        within_viewing_range(point, camera_center))
      ++n;
  }
  return n;
}

}  // namespace

void optimise_pose(const optim::MotionOnlyBa& motion_ba, const map::ScalePyramid& pyramid,
                   const PreparedFrame& frame, const std::vector<PointView>& points,
                   const std::vector<int>& match_of_keypoint, PassResult& result) {
  const auto start = SteadyClock::now();
  std::vector<optim::PoseObservation> observations;
  std::vector<int> keypoint_of_observation;
  for (int k = 0; k < frame.size(); ++k) {
    if (match_of_keypoint[k] < 0) continue;
    observations.push_back(observation_of(pyramid, frame, k, points[match_of_keypoint[k]]));
    keypoint_of_observation.push_back(k);
  }
  result.point_of_keypoint.assign(frame.size(), map::kNoPoint);
  result.n_inliers = 0;
  auto solved = motion_ba.solve(result.T_cam_world, observations);
  result.timings.motion_ba_ms += ms_since(start);
  if (!solved) {
    result.failure = solved.error().message;
    return;
  }
  result.T_cam_world = solved->T_cam_world;
  result.covariance_world_cam = solved->covariance_world_cam;
  result.variance_factor = solved->variance_factor;
  for (std::size_t j = 0; j < observations.size(); ++j) {
    if (!solved->inlier[j]) continue;
    const int k = keypoint_of_observation[j];
    result.point_of_keypoint[k] = points[match_of_keypoint[k]].id;
    ++result.n_inliers;
  }
}

bool established_map_hidden(const PassResult& result) {
  return result.established_in_view >= kHiddenEstablishedPoints &&
         result.established_matched < kMinMatchedEstablishedShare * result.established_in_view;
}

void optimise_pose_established_first(const optim::MotionOnlyBa& motion_ba, const StereoCamera& camera,
                                     const map::ScalePyramid& pyramid, const PreparedFrame& frame,
                                     const std::vector<PointView>& points,
                                     const std::vector<int>& match_of_keypoint, PassResult& result) {
  int n_established = 0;
  int n_fresh = 0;
  for (int k = 0; k < frame.size(); ++k) {
    if (match_of_keypoint[k] < 0) continue;
    (established(points[match_of_keypoint[k]]) ? n_established : n_fresh) += 1;
  }
  const int in_view = established_in_view(camera, points, result.T_cam_world);
  result.established_matched = n_established;
  result.established_in_view = in_view;
  if (3 * n_fresh < n_established + n_fresh) {
    optimise_pose(motion_ba, pyramid, frame, points, match_of_keypoint, result);
    return;
  }
  if (n_established < kMinEstablishedMatches) {
    if (in_view < kHiddenEstablishedPoints) {
      optimise_pose(motion_ba, pyramid, frame, points, match_of_keypoint, result);
      return;
    }
    result.point_of_keypoint.assign(frame.size(), map::kNoPoint);
    result.n_inliers = 0;
    result.failure = "the established map is hidden: " + std::to_string(in_view) +
                     " of its points in view, " + std::to_string(n_established) + " matched, " +
                     std::to_string(n_fresh) + " matches on points too new to trust alone";
    return;
  }
  // The established map alone, from the same starting pose.
  std::vector<int> match = match_of_keypoint;
  std::vector<int> fresh_keypoints;
  for (int k = 0; k < frame.size(); ++k) {
    if (match[k] >= 0 && !established(points[match[k]])) {
      fresh_keypoints.push_back(k);
      match[k] = -1;
    }
  }
  PassResult anchor = result;
  optimise_pose(motion_ba, pyramid, frame, points, match, anchor);
  const bool solver_failed = anchor.failure != result.failure;
  if (anchor.n_inliers < kMinEstablishedMatches || solver_failed) {
    // Too weak to judge the fresh points by: all of them, as usual.
    result.timings.motion_ba_ms = anchor.timings.motion_ba_ms;
    optimise_pose(motion_ba, pyramid, frame, points, match_of_keypoint, result);
    return;
  }
  // Fresh matches that fit the established pose join it.
  std::vector<optim::PoseObservation> fresh;
  fresh.reserve(fresh_keypoints.size());
  for (int k : fresh_keypoints)
    fresh.push_back(observation_of(pyramid, frame, k, points[match_of_keypoint[k]]));
  const auto start = SteadyClock::now();
  const auto fits = motion_ba.inliers_at(anchor.T_cam_world, fresh);
  anchor.timings.motion_ba_ms += ms_since(start);
  if (fits) {
    for (std::size_t j = 0; j < fresh_keypoints.size(); ++j) {
      if ((*fits)[j]) match[fresh_keypoints[j]] = match_of_keypoint[fresh_keypoints[j]];
    }
  }
  anchor.failure = result.failure;
  result = std::move(anchor);
  optimise_pose(motion_ba, pyramid, frame, points, match, result);
}

}  // namespace sitepose::tracking
