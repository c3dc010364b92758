#include "sitepose/mapping/fuse.hpp"

#include <algorithm>
#include <limits>

namespace sitepose::mapping {
namespace {

// ORB-SLAM2 Fuse: scale range slack and the 60-degree viewing-angle limit.
constexpr double kMinDistanceSlack = 0.8;
constexpr double kMaxDistanceSlack = 1.2;
constexpr double kMinViewingCos = 0.5;

}  // namespace

map::KeypointGrid make_keypoint_grid(const StereoCamera& camera, const KeyFrameSnapshot& keyframe) {
  std::vector<Eigen::Vector2d> uv;
  std::vector<int> octave;
  uv.reserve(keyframe.keypoints.size());
  octave.reserve(keyframe.keypoints.size());
  for (const map::KeyPointData& kp : keyframe.keypoints) {
    uv.push_back(kp.uv_px);
    octave.push_back(kp.octave);
  }
  return map::KeypointGrid(camera.width, camera.height, uv, octave);
}

std::vector<FuseProposal> fuse_into_keyframe(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                             const KeyFrameSnapshot& target, const map::KeypointGrid& grid,
                                             const std::vector<PointSnapshot>& points,
                                             const FuseParams& params) {
  std::vector<FuseProposal> proposals;
  const Eigen::Vector3d center = target.camera_center();
  for (const PointSnapshot& p : points) {
    if (p.is_observed_by(target.id)) continue;
    const Eigen::Vector3d p_cam = target.T_cam_world * p.p_world;
    if (!(p_cam.z() > 0.0)) continue;
    const Eigen::Vector2d uv = camera.project(p_cam);
    if (!camera.in_image(uv)) continue;
    const double u_right = camera.project_right_u(p_cam);
    const Eigen::Vector3d view = p.p_world - center;
    const double distance = view.norm();
    if (distance < kMinDistanceSlack * p.min_distance_m || distance > kMaxDistanceSlack * p.max_distance_m) {
      continue;
    }
    if (view.dot(p.normal) < kMinViewingCos * distance) continue;
    const int level = pyramid.predict_level(distance, p.max_distance_m);
    const double radius = params.radius_scale * pyramid.scale(level);
    int best = std::numeric_limits<int>::max();
    int best_index = -1;
    for (int index : grid.query(uv, radius, std::max(0, level - 1), level)) {
      const map::KeyPointData& kp = target.keypoints[index];
      const double scale = pyramid.scale(kp.octave);
      const double inv_sigma2 = 1.0 / (scale * scale);
      double e2 = (uv - kp.uv_px).squaredNorm();
      double gate = params.chi2_mono;
      if (kp.u_right_px >= 0.0) {
        const double er = u_right - kp.u_right_px;
        e2 += er * er;
        gate = params.chi2_stereo;
      }
      if (e2 * inv_sigma2 > gate) continue;
      const int d = map::descriptor_distance(p.descriptor, kp.descriptor);
      if (d < best) {
        best = d;
        best_index = index;
      }
    }
    if (best_index >= 0 && best <= params.max_descriptor_distance) {
      proposals.push_back({p.id, target.id, best_index, best});
    }
  }
  return proposals;
}

FuseOutcome apply_fuse_proposals(map::MapData& map, const std::vector<FuseProposal>& proposals) {
  FuseOutcome outcome;
  for (const FuseProposal& proposal : proposals) {
    const map::MapPoint* point = map.good_point(proposal.point);
    const map::KeyFrame* keyframe = map.keyframe(proposal.keyframe);
    if (point == nullptr || keyframe == nullptr || keyframe->bad) continue;
    if (point->observations.count(proposal.keyframe) != 0) continue;
    if (proposal.index < 0 || proposal.index >= static_cast<int>(keyframe->point_of_keypoint.size())) continue;
    const map::PointId existing = keyframe->point_of_keypoint[proposal.index];
    if (existing != map::kNoPoint && map.good_point(existing) != nullptr) {
      // ORB-SLAM2 keeps the point with more (stereo-weighted) observations.
      if (map.observation_weight(existing) > map.observation_weight(proposal.point)) {
        map.replace_point(proposal.point, existing);
        outcome.touched.push_back(existing);
      } else {
        map.replace_point(existing, proposal.point);
        outcome.touched.push_back(proposal.point);
      }
      ++outcome.points_merged;
    } else {
      map.add_observation(proposal.point, proposal.keyframe, proposal.index);
      outcome.touched.push_back(proposal.point);
      ++outcome.observations_added;
    }
  }
  return outcome;
}

}  // namespace sitepose::mapping
