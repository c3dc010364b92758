#include "sitepose/tracking/pose_refinement.hpp"

#include "sitepose/core/stopwatch.hpp"

namespace sitepose::tracking {

void optimise_pose(const optim::MotionOnlyBa& motion_ba, const map::ScalePyramid& pyramid,
                   const PreparedFrame& frame, const std::vector<PointView>& points,
                   const std::vector<int>& match_of_keypoint, PassResult& result) {
  const auto start = SteadyClock::now();
  std::vector<optim::PoseObservation> observations;
  std::vector<int> keypoint_of_observation;
  for (int k = 0; k < frame.size(); ++k) {
    if (match_of_keypoint[k] < 0) continue;
    optim::PoseObservation obs;
    obs.p_world = points[match_of_keypoint[k]].p_world;
    obs.uv_left_px = frame.uv_px[k];
    obs.u_right_px = frame.features.u_right[k];
    obs.sigma2_px2 = pyramid.scale(frame.octave[k]) * pyramid.scale(frame.octave[k]);
    observations.push_back(obs);
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

}  // namespace sitepose::tracking
