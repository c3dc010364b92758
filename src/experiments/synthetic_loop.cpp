#include "sitepose/experiments/synthetic_loop.hpp"

#include <cmath>
#include <cstring>
#include <random>

namespace sitepose::experiments {

TexturedWall make_textured_wall(std::uint64_t seed, double lane_m, int points) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-8.0, lane_m + 8.0), uy(-2.0, 2.0), uz(6.0, 10.0);
  TexturedWall wall;
  for (int i = 0; i < points; ++i) {
    wall.p_world_m.emplace_back(ux(rng), uy(rng), uz(rng));
    map::Descriptor d;
    for (auto& b : d) b = static_cast<std::uint8_t>(rng() & 0xFF);
    wall.descriptors.push_back(d);
  }
  return wall;
}

SE3 lane_camera_at(double x_m) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x_m, 0.0, 0.0)); }

namespace {

// Odometry's error of one keyframe step (body frame): 1 cm forward and
// 0.1 degrees of heading.
SE3 odometry_step_error() {
  Vector6d xi;
  xi << 0.01, 0.0, 0.0, 0.0, 0.1 * M_PI / 180.0, 0.0;
  return SE3::exp(xi);
}

}  // namespace

map::KeyFrameId insert_wall_keyframe(map::MapData& map, const StereoCamera& camera, const TexturedWall& wall,
                                     const SE3& T_true, const SE3& T_map,
                                     std::vector<map::PointId>& point_of_wall_point) {
  map::KeyFrame kf;
  kf.T_world_cam = T_map;
  std::vector<std::size_t> wall_point_of_keypoint;
  for (std::size_t i = 0; i < wall.p_world_m.size(); ++i) {
    const Eigen::Vector3d p_cam = T_true.inverse() * wall.p_world_m[i];
    if (!(p_cam.z() > 0.5) || !camera.in_image(camera.project(p_cam), 2.0)) continue;
    map::KeyPointData kp;
    kp.uv_px = camera.project(p_cam);
    kp.u_right_px = camera.project_right_u(p_cam);
    kp.depth_m = p_cam.z();
    kp.descriptor = wall.descriptors[i];
    kf.keypoints.push_back(kp);
    kf.point_of_keypoint.push_back(point_of_wall_point[i]);
    wall_point_of_keypoint.push_back(i);
  }
  const map::KeyFrameId id = map.add_keyframe(kf);
  for (std::size_t k = 0; k < wall_point_of_keypoint.size(); ++k) {
    const std::size_t i = wall_point_of_keypoint[k];
    if (point_of_wall_point[i] != map::kNoPoint) continue;
    point_of_wall_point[i] =
        map.add_point(T_map * (T_true.inverse() * wall.p_world_m[i]), id, static_cast<int>(k));
  }
  return id;
}

DriftedReturn make_drifted_return(const StereoCamera& camera, const TexturedWall& wall, int lane_keyframes) {
  DriftedReturn loop;
  std::vector<map::PointId> outbound_ids(wall.p_world_m.size(), map::kNoPoint);
  for (int k = 0; k < lane_keyframes; ++k) {
    loop.outbound.push_back(
        insert_wall_keyframe(loop.map, camera, wall, lane_camera_at(k), lane_camera_at(k), outbound_ids));
    loop.map.keyframe(loop.outbound.back())->map_travel_m = k;  // a metre a keyframe
  }
  std::vector<map::PointId> inbound_ids(wall.p_world_m.size(), map::kNoPoint);
  SE3 T_map = lane_camera_at(lane_keyframes - 2);  // the first returning keyframe, still exact
  for (int r = 1; r < lane_keyframes; ++r) {
    const SE3 T_true = lane_camera_at(lane_keyframes - 1 - r);
    // Dead reckoning from the turn: the true step, then its error.
    if (r >= 2) T_map = T_map * lane_camera_at(-1.0) * odometry_step_error();
    // At the turn the return still matches the outbound points; one
    // keyframe later half of them, then none.
    std::vector<map::PointId> ids = outbound_ids;
    if (r >= 2) {
      for (std::size_t i = 0; i < wall.p_world_m.size(); ++i) {
        if (r > 2 || i % 2 == 1) ids[i] = inbound_ids[i];
      }
    }
    loop.inbound.push_back(insert_wall_keyframe(loop.map, camera, wall, T_true, T_map, ids));
    // The return loses the outbound points: its map travel goes on growing.
    loop.map.keyframe(loop.inbound.back())->map_travel_m = lane_keyframes - 1 + r;
    if (r >= 2) {
      for (std::size_t i = 0; i < wall.p_world_m.size(); ++i) {
        if (ids[i] != outbound_ids[i]) inbound_ids[i] = ids[i];
      }
    }
    loop.inbound_truth.push_back(T_true);
  }
  for (const auto& [pid, p] : loop.map.points()) loop.map.update_point_appearance(pid);
  for (const auto& [id, kf] : loop.map.keyframes()) loop.map.update_connections(id);
  return loop;
}

Expected<std::shared_ptr<const placerec::Vocabulary>> vocabulary_of(const map::MapData& map) {
  std::vector<cv::Mat> images;
  for (const auto& [id, kf] : map.keyframes()) {
    cv::Mat d(static_cast<int>(kf.keypoints.size()), 32, CV_8UC1);
    for (int r = 0; r < d.rows; ++r) {
      std::memcpy(d.ptr(r), kf.keypoints[static_cast<std::size_t>(r)].descriptor.data(), 32);
    }
    images.push_back(d);
  }
  placerec::VocabularyParams params;
  params.levels = 3;
  SITEPOSE_TRY(placerec::Vocabulary vocabulary, placerec::Vocabulary::train(images, params));
  return std::make_shared<const placerec::Vocabulary>(std::move(vocabulary));
}

double keyframe_error_m(const map::MapData& map, map::KeyFrameId id, const SE3& truth) {
  return (map.keyframe(id)->T_world_cam.translation() - truth.translation()).norm();
}

double return_rms_error_m(const map::MapData& map, const DriftedReturn& loop) {
  double sum_sq = 0.0;
  for (std::size_t r = 0; r < loop.inbound.size(); ++r) {
    sum_sq += std::pow(keyframe_error_m(map, loop.inbound[r], loop.inbound_truth[r]), 2);
  }
  return std::sqrt(sum_sq / static_cast<double>(loop.inbound.size()));
}

}  // namespace sitepose::experiments
