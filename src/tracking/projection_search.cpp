#include "sitepose/tracking/projection_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "sitepose/features/hamming.hpp"

namespace sitepose::tracking {

PointView make_point_view(const map::MapPoint& point) {
  PointView view;
  static_cast<map::PointAppearance&>(view) = map::appearance_of(point);
  return view;
}

PointView make_point_view_with_span(const map::MapData& map, const map::MapPoint& point) {
  PointView view = make_point_view(point);
  if (point.observations.size() >= 2) {
    // Keyframe ids grow with time: the first and last ids span the rest.
    const map::KeyFrame* first = map.keyframe(point.observations.begin()->first);
    const map::KeyFrame* last = map.keyframe(point.observations.rbegin()->first);
    if (first != nullptr && last != nullptr) view.observed_span_s = std::abs(last->t_ns - first->t_ns) * 1e-9;
  }
  return view;
}

std::optional<ViewingGeometry> within_viewing_range(const PointView& point,
                                                    const Eigen::Vector3d& camera_center) {
  const Eigen::Vector3d ray = point.p_world - camera_center;
  const double distance = ray.norm();
  if (distance < 0.8 * point.min_distance_m || distance > 1.2 * point.max_distance_m) return std::nullopt;
  const double view_cos = ray.dot(point.normal) / distance;
  if (view_cos < 0.5) return std::nullopt;
  return ViewingGeometry{distance, view_cos};
}

namespace {

// Jobs one search splits its points into when it has a pool.
constexpr int kSearchRunsOnPool = 8;

// What one point found, before points compete for keypoints.
struct PointCandidate {
  bool visible = false;  // inside the frustum (and the scale and view-angle range)
  int keypoint = -1;     // best usable keypoint that passed the tests, or -1
  int distance = 0;      // its descriptor distance
};

// The search of one point: depends only on the point and on which keypoints
// were matched before the search (best_distance_of_keypoint < 0), not on
// the other points, so points can be searched in any order.
PointCandidate search_point(const PreparedFrame& frame, const StereoCamera& camera,
                            const map::ScalePyramid& pyramid, const SE3& T_cam_world,
                            const Eigen::Vector3d& camera_center, const PointView& point,
                            const std::vector<std::uint8_t>& usable, const SearchParams& params,
                            const std::vector<int>& best_distance_of_keypoint) {
  PointCandidate out;
  const Eigen::Vector3d p_cam = T_cam_world * point.p_world;
  if (p_cam.z() <= 0.0) return out;
  const Eigen::Vector2d uv = camera.project(p_cam);
  if (!camera.in_image(uv)) return out;
  int level = point.octave_hint;
  double radius_scale = 1.0;
  if (params.check_view_angle) {
    const std::optional<ViewingGeometry> seen = within_viewing_range(point, camera_center);
    if (!seen) return out;
    level = pyramid.predict_level(seen->distance_m, point.max_distance_m);
    // ORB-SLAM2: a wider window when the view direction differs.
    radius_scale = seen->view_cos > 0.998 ? 2.5 : 4.0;
  }
  out.visible = true;
  const int search_level = level < 0 ? 0 : level;
  const double radius = params.radius_px * radius_scale * pyramid.scale(search_level);
  const int min_level = level < 0 ? -1 : std::max(0, level - 1);
  const int max_level = level < 0 ? -1 : level + 1;
  const double u_right = camera.project_right_u(p_cam);

  int best = std::numeric_limits<int>::max();
  int second = std::numeric_limits<int>::max();
  int best_level = -1;
  int second_level = -1;
  int best_keypoint = -1;
  for (int k : frame.grid.query(uv, radius, min_level, max_level)) {
    if (!usable[k]) continue;
    if (best_distance_of_keypoint[k] < 0) continue;  // matched in an earlier search
    if (frame.features.u_right[k] >= 0.0 && std::abs(u_right - frame.features.u_right[k]) > radius) {
      continue;
    }
    const int d =
        features::hamming_distance(point.descriptor.data(), frame.features.descriptors.ptr<std::uint8_t>(k));
    if (d < best) {
      second = best;
      second_level = best_level;
      best = d;
      best_level = frame.octave[k];
      best_keypoint = k;
    } else if (d < second) {
      second = d;
      second_level = frame.octave[k];
    }
  }
  if (best_keypoint < 0 || best > params.max_distance) return out;
  // Ratio test only between candidates of the same level (ORB-SLAM2).
  if (params.ratio < 1.0 && best_level == second_level && best > params.ratio * second) return out;
  out.keypoint = best_keypoint;
  out.distance = best;
  return out;
}

}  // namespace

int search_by_projection(const PreparedFrame& frame, const StereoCamera& camera,
                         const map::ScalePyramid& pyramid, const SE3& T_cam_world,
                         const std::vector<PointView>& points, const std::vector<std::uint8_t>& usable,
                         const SearchParams& params, std::vector<int>& match_of_keypoint,
                         std::vector<int>* visible, features::TaskPool* pool) {
  // Best distance per keypoint so a better point can take a keypoint over.
  std::vector<int> best_distance_of_keypoint(frame.size(), std::numeric_limits<int>::max());
  for (int k = 0; k < frame.size(); ++k) {
    if (match_of_keypoint[k] >= 0) best_distance_of_keypoint[k] = -1;  // taken before: keep
  }
  const Eigen::Vector3d camera_center = T_cam_world.inverse().translation();
  const int n_points = static_cast<int>(points.size());
  std::vector<PointCandidate> candidates(points.size());
  const int n_runs = pool != nullptr ? std::min(n_points, kSearchRunsOnPool) : 1;
  const auto search_run = [&](int run) {
    const int first = static_cast<int>(static_cast<long>(n_points) * run / n_runs);
    const int last = static_cast<int>(static_cast<long>(n_points) * (run + 1) / n_runs);
    for (int i = first; i < last; ++i) {
      candidates[i] = search_point(frame, camera, pyramid, T_cam_world, camera_center, points[i], usable,
                                   params, best_distance_of_keypoint);
    }
  };
  if (pool != nullptr && n_runs > 1) {
    pool->run(n_runs, search_run);
  } else if (n_points > 0) {
    search_run(0);
  }
  // Points compete for keypoints in point order: a later point takes a
  // keypoint over only with a smaller distance.
  int n_matches = 0;
  for (int i = 0; i < n_points; ++i) {
    const PointCandidate& c = candidates[i];
    if (c.visible && visible != nullptr) visible->push_back(i);
    if (c.keypoint < 0 || c.distance >= best_distance_of_keypoint[c.keypoint]) continue;
    if (match_of_keypoint[c.keypoint] < 0) ++n_matches;
    match_of_keypoint[c.keypoint] = i;
    best_distance_of_keypoint[c.keypoint] = c.distance;
  }
  return n_matches;
}

}  // namespace sitepose::tracking
