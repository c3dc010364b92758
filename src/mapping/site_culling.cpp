#include "sitepose/mapping/site_culling.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sitepose/mapping/keyframe_culling.hpp"

namespace sitepose::mapping {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

// Bins centred on 0: the first keyframe's height, heading and elevation are
// 0, and a machine on flat ground stays near them; bins with a border at 0
// would split its keyframes by noise.
long bin_of(double value, double size) { return std::lround(value / size); }

}  // namespace

Eigen::Vector3d viewing_direction(const map::KeyFrame& keyframe) {
  return keyframe.T_world_cam.rotation() * Eigen::Vector3d::UnitZ();
}

SiteCell site_cell_of(const map::KeyFrame& keyframe, const SiteNeighbourhood& neighbourhood) {
  const Eigen::Vector3d c = keyframe.camera_center();
  const Eigen::Vector3d d = viewing_direction(keyframe);
  const double azimuth_deg = kDegPerRad * std::atan2(d.x(), d.z());
  const double elevation_deg = kDegPerRad * std::asin(std::clamp(-d.y(), -1.0, 1.0));
  const double r = neighbourhood.radius_m;
  const double a = neighbourhood.angle_deg;
  return {bin_of(c.x(), r), bin_of(c.y(), r), bin_of(c.z(), r), bin_of(azimuth_deg, a),
          bin_of(elevation_deg, a)};
}

bool within_neighbourhood(const map::KeyFrame& a, const map::KeyFrame& b,
                          const SiteNeighbourhood& neighbourhood) {
  if ((a.camera_center() - b.camera_center()).norm() > neighbourhood.radius_m) return false;
  const double cos_angle = std::clamp(viewing_direction(a).dot(viewing_direction(b)), -1.0, 1.0);
  return kDegPerRad * std::acos(cos_angle) <= neighbourhood.angle_deg;
}

bool has_cell_mate(const map::MapData& map, map::KeyFrameId keyframe,
                   const SiteNeighbourhood& neighbourhood) {
  const map::KeyFrame* kf = map.keyframe(keyframe);
  if (kf == nullptr) return false;
  const SiteCell cell = site_cell_of(*kf, neighbourhood);
  for (const auto& [id, other] : map.keyframes()) {
    if (id != keyframe && !other.bad && site_cell_of(other, neighbourhood) == cell) return true;
  }
  return false;
}

bool is_protected(const map::MapData& map, map::KeyFrameId keyframe, map::KeyFrameId current) {
  return keyframe == map.first_keyframe() || keyframe >= current || map.is_tracker_keyframe(keyframe);
}

std::vector<map::KeyFrameId> site_candidates(const map::MapData& map, map::KeyFrameId current,
                                             const SiteNeighbourhood& neighbourhood) {
  std::vector<map::KeyFrameId> result;
  const map::KeyFrame* kf = map.keyframe(current);
  if (kf == nullptr) return result;
  for (const auto& [id, other] : map.keyframes()) {
    if (other.bad || is_protected(map, id, current)) continue;
    if (within_neighbourhood(*kf, other, neighbourhood)) result.push_back(id);
  }
  std::sort(result.begin(), result.end(), std::greater<>());
  return result;
}

std::vector<map::KeyFrameId> site_neighbours(const map::MapData& map, map::KeyFrameId current,
                                             const SiteNeighbourhood& neighbourhood, int n) {
  std::vector<std::pair<double, map::KeyFrameId>> near;
  const map::KeyFrame* kf = map.keyframe(current);
  if (kf == nullptr) return {};
  for (const auto& [id, other] : map.keyframes()) {
    if (id == current || other.bad || !within_neighbourhood(*kf, other, neighbourhood)) continue;
    near.emplace_back((other.camera_center() - kf->camera_center()).norm(), id);
  }
  std::sort(near.begin(), near.end());
  std::vector<map::KeyFrameId> result;
  for (const auto& [distance_m, id] : near) {
    if (static_cast<int>(result.size()) >= n) break;
    result.push_back(id);
  }
  return result;
}

bool may_cull_from_site(const map::MapData& map, map::KeyFrameId keyframe, map::KeyFrameId current,
                        const SiteNeighbourhood& neighbourhood, double redundancy, double close_depth_m) {
  const map::KeyFrame* kf = map.keyframe(keyframe);
  if (kf == nullptr || kf->bad || is_protected(map, keyframe, current)) return false;
  return is_keyframe_redundant(map, keyframe, redundancy, close_depth_m) &&
         has_cell_mate(map, keyframe, neighbourhood);
}

}  // namespace sitepose::mapping
