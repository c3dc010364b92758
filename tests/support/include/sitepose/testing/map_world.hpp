#pragma once
// Synthetic stereo world for map-building tests: random points on planes at
// 5-30 m with an ORB-like descriptor each, and a simulated tracker that
// inserts keyframes into a SharedMap the way the real one does (tracked
// points by association, then new stereo points of close keypoints,
// ORB-SLAM2 Tracking::CreateNewKeyFrame). Needs sitepose::map.

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <unordered_map>
#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/testing/cameras.hpp"

namespace sitepose::testing {

// Camera looking along world +z at (x, 0, 0): the machine drives along x.
inline SE3 pose_at_x(double x_m, double yaw_rad = 0.0) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY())),
             Eigen::Vector3d(x_m, 0.0, 0.0));
}

struct Plane {
  double z_m;          // depth at x = 0
  double dz_dx;        // tilt
  double x_min_m, x_max_m, y_half_m;
};

struct World {
  std::vector<Eigen::Vector3d> points;
  std::vector<map::Descriptor> descriptors;
  std::vector<int> octave;  // one per point: a point keeps its scale between nearby views
};

inline std::vector<Plane> default_planes() {
  return {{8.0, 0.1, -8.0, 18.0, 3.0},
          {15.0, 0.0, -12.0, 22.0, 5.0},
          {22.0, -0.1, -15.0, 25.0, 7.0},
          {29.0, 0.0, -18.0, 28.0, 9.0}};
}

inline World make_world(int points_per_plane, unsigned seed, const std::vector<Plane>& planes = default_planes()) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> level(0, 2);
  World w;
  for (const Plane& plane : planes) {
    std::uniform_real_distribution<double> x(plane.x_min_m, plane.x_max_m);
    std::uniform_real_distribution<double> y(-plane.y_half_m, plane.y_half_m);
    for (int i = 0; i < points_per_plane; ++i) {
      const double px = x(rng);
      w.points.emplace_back(px, y(rng), plane.z_m + plane.dz_dx * px);
      map::Descriptor d;
      for (auto& b : d) b = static_cast<std::uint8_t>(byte(rng));
      w.descriptors.push_back(d);
      w.octave.push_back(level(rng));
    }
  }
  return w;
}

struct SimTrackerOptions {
  double pixel_noise_px = 0.5;     // at level 0, times the level scale
  int bit_flips = 4;               // per view, of 256
  double stereo_max_depth_m = 25.0;  // no stereo match beyond (thin disparity)
  double stereo_dropout = 0.2;     // fraction of near keypoints without a stereo match
  double close_depth_m = 40.0;     // tracking.close_depth_baselines * baseline
  double wrong_association_fraction = 0.0;  // tracked keypoints given a wrong point
  unsigned seed = 7;
};

// Inserts keyframes like the tracker and remembers the true world point of
// every keypoint, so tests can score the map.
class SimTracker {
 public:
  SimTracker(const World& world, const StereoCamera& camera, map::SharedMap& map, SimTrackerOptions options)
      : world_(world), camera_(camera), map_(map), options_(options), rng_(options.seed) {}

  // A keyframe seen from T_world_cam_true, entered with T_world_cam_map
  // (the tracker's estimate). associate_fraction < 1: the tracker found only
  // that share of the map points it sees (the others get new, duplicate
  // points when they have stereo depth). hidden: world points not observed
  // in this keyframe.
  map::KeyFrameId insert_keyframe(const SE3& T_world_cam_true, const SE3& T_world_cam_map,
                                  double associate_fraction = 1.0, const std::vector<bool>* hidden = nullptr) {
    std::unordered_map<int, map::PointId> known = associations();
    if (associate_fraction < 1.0) {
      std::uniform_real_distribution<double> u(0.0, 1.0);
      std::erase_if(known, [&](const auto&) { return u(rng_) >= associate_fraction; });
    }
    const SE3 T_cam_world = T_world_cam_true.inverse();
    std::normal_distribution<double> noise(0.0, options_.pixel_noise_px);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_int_distribution<int> bit(0, 255);

    map::KeyFrame kf;
    kf.T_world_cam = T_world_cam_map;
    std::vector<int> truth;
    std::vector<map::PointId> known_points;
    for (int w = 0; w < static_cast<int>(world_.points.size()); ++w) {
      if (hidden != nullptr && (*hidden)[w]) continue;
      const Eigen::Vector3d p_cam = T_cam_world * world_.points[w];
      if (p_cam.z() < 1.0) continue;
      const double scale = std::pow(1.2, world_.octave[w]);
      map::KeyPointData kp;
      kp.uv_px = camera_.project(p_cam) + scale * Eigen::Vector2d(noise(rng_), noise(rng_));
      if (!camera_.in_image(kp.uv_px, 3.0)) continue;
      kp.octave = world_.octave[w];
      kp.descriptor = world_.descriptors[w];
      for (int f = 0; f < options_.bit_flips; ++f) {
        const int b = bit(rng_);
        kp.descriptor[b / 8] ^= static_cast<std::uint8_t>(1u << (b % 8));
      }
      if (p_cam.z() < options_.stereo_max_depth_m && unit(rng_) >= options_.stereo_dropout) {
        kp.u_right_px = kp.uv_px.x() - camera_.disparity_from_depth(p_cam.z()) + 0.3 * scale * noise(rng_);
        kp.depth_m = camera_.depth_from_disparity(kp.uv_px.x() - kp.u_right_px);
      }
      const auto it = known.find(w);
      kf.keypoints.push_back(kp);
      kf.point_of_keypoint.push_back(it == known.end() ? map::kNoPoint : it->second);
      if (it != known.end()) known_points.push_back(it->second);
      truth.push_back(w);
    }
    // Deliberately wrong associations: a tracked keypoint gets another
    // tracked point of this keyframe (swapped), as a bad match would.
    if (options_.wrong_association_fraction > 0.0) {
      std::vector<int> tracked;
      for (int i = 0; i < static_cast<int>(kf.keypoints.size()); ++i) {
        if (kf.point_of_keypoint[i] != map::kNoPoint) tracked.push_back(i);
      }
      std::shuffle(tracked.begin(), tracked.end(), rng_);
      const int n_wrong = static_cast<int>(options_.wrong_association_fraction * tracked.size()) / 2 * 2;
      for (int k = 0; k + 1 < n_wrong; k += 2) {
        std::swap(kf.point_of_keypoint[tracked[k]], kf.point_of_keypoint[tracked[k + 1]]);
        wrong_.emplace_back(tracked[k], tracked[k + 1]);
      }
    }

    const map::KeyFrameId id = map_.write([&](map::MapData& m) {
      const map::KeyFrameId kf_id = m.add_keyframe(std::move(kf));
      map::KeyFrame* inserted = m.keyframe(kf_id);
      for (map::PointId pid : inserted->point_of_keypoint) {
        if (map::MapPoint* p = m.point(pid); p != nullptr) {
          ++p->n_visible;
          ++p->n_found;
        }
      }
      // ORB-SLAM2 CreateNewKeyFrame: stereo keypoints by depth; all close
      // ones become points, far ones only while fewer than 100 exist.
      std::vector<std::pair<double, int>> by_depth;
      for (int i = 0; i < static_cast<int>(inserted->keypoints.size()); ++i) {
        if (inserted->keypoints[i].depth_m > 0.0) by_depth.emplace_back(inserted->keypoints[i].depth_m, i);
      }
      std::sort(by_depth.begin(), by_depth.end());
      int n_points = 0;
      for (const auto& [depth, i] : by_depth) {
        if (m.keyframe(kf_id)->point_of_keypoint[i] == map::kNoPoint) {
          const SE3 T = m.keyframe(kf_id)->T_world_cam;
          m.add_point(T * camera_.unproject(m.keyframe(kf_id)->keypoints[i].uv_px, depth), kf_id, i);
        }
        ++n_points;
        if (depth > options_.close_depth_m && n_points > 100) break;
      }
      return kf_id;
    });
    truth_[id] = std::move(truth);
    return id;
  }

  // True world point of a keypoint.
  int world_of(map::KeyFrameId keyframe, int index) const { return truth_.at(keyframe).at(index); }

  // World point most of a map point's observations belong to (-1 if none).
  // Ties go to the oldest keyframe's view (the one that created the point).
  int world_of_point(const map::MapPoint& p) const {
    std::map<int, int> votes;
    for (const auto& [kf, index] : p.observations) ++votes[world_of(kf, index)];
    int best = -1;
    int best_votes = 0;
    for (const auto& [kf, index] : p.observations) {  // ascending keyframe id
      const int w = world_of(kf, index);
      if (votes[w] > best_votes) {
        best_votes = votes[w];
        best = w;
      }
    }
    return best;
  }

  // World point -> the good map point that has most observations of it.
  std::unordered_map<int, map::PointId> associations() const {
    return map_.read([&](const map::MapData& m) {
      std::unordered_map<int, map::PointId> result;
      std::unordered_map<int, std::size_t> weight;
      for (const auto& [pid, p] : m.points()) {
        if (p.bad) continue;
        const int w = world_of_point(p);
        if (w >= 0 && p.observations.size() > weight[w]) {
          weight[w] = p.observations.size();
          result[w] = pid;
        }
      }
      return result;
    });
  }

  const World& world() const { return world_; }
  std::size_t wrong_associations_made() const { return wrong_.size() * 2; }

 private:
  const World& world_;
  StereoCamera camera_;
  map::SharedMap& map_;
  SimTrackerOptions options_;
  std::mt19937 rng_;
  std::unordered_map<map::KeyFrameId, std::vector<int>> truth_;
  std::vector<std::pair<int, int>> wrong_;
};

// Both sides of every reference agree; empty when consistent, else the
// first problem found.
inline std::string check_consistency(const map::MapData& m) {
  for (const auto& [pid, p] : m.points()) {
    if (p.bad) {
      if (!p.observations.empty()) return "bad point " + std::to_string(pid) + " keeps observations";
      continue;
    }
    if (!p.p_world.allFinite()) return "point " + std::to_string(pid) + " not finite";
    for (const auto& [kf_id, index] : p.observations) {
      const map::KeyFrame* kf = m.keyframe(kf_id);
      if (kf == nullptr) return "point " + std::to_string(pid) + " observed by missing keyframe";
      if (kf->point_of_keypoint[index] != pid) return "point " + std::to_string(pid) + " not in its keyframe";
    }
  }
  for (const auto& [kf_id, kf] : m.keyframes()) {
    for (int i = 0; i < static_cast<int>(kf.point_of_keypoint.size()); ++i) {
      const map::PointId pid = kf.point_of_keypoint[i];
      if (pid == map::kNoPoint) continue;
      const map::MapPoint* p = m.good_point(pid);
      if (p == nullptr) return "keyframe " + std::to_string(kf_id) + " names a missing or bad point";
      const auto it = p->observations.find(kf_id);
      if (it == p->observations.end() || it->second != i) {
        return "keyframe " + std::to_string(kf_id) + " keypoint " + std::to_string(i) + " not observed back";
      }
    }
    for (const auto& [other, weight] : kf.covisibility) {
      const map::KeyFrame* o = m.keyframe(other);
      if (o == nullptr) return "covisibility names a missing keyframe";
      if (o->covisibility.count(kf_id) == 0) return "covisibility is not symmetric";
    }
    if (kf_id != m.first_keyframe() && kf.parent != map::kNoKeyFrame && m.keyframe(kf.parent) == nullptr) {
      return "keyframe " + std::to_string(kf_id) + " has a missing parent";
    }
  }
  return {};
}

}  // namespace sitepose::testing
