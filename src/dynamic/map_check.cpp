// MotionClassifier::check_against_map(): the objects called static, tested
// against their own map points (see the header).

#include <cmath>

#include "detail/point_displacement.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/optim/triangulation.hpp"

namespace sitepose::dynamic {
namespace {

// chi2 3 dof, 99.9 %: like the reference-frame test's object-level gate.
constexpr double kMapGate = 16.27;
// The map points of one object share an error that does not average out
// over them (the keyframe poses and local BA they came from), modelled as
// this fraction of one point's stereo noise. Measured with 0.15 on parked,
// crowded and fast: truly static machines scored at most 9.6 (p99 7.3 over
// 298 tests); the roller of the re-mask test scored 21.6 16 mm into its
// start. Without the term, static machines reached 24.9.
constexpr double kCommonMapErrorFraction = 0.15;

}  // namespace

std::vector<MapCheck> MotionClassifier::check_against_map(
    const tracking::PreparedFrame& frame, const std::vector<std::optional<Eigen::Vector3d>>& map_point_of_keypoint,
    const ObjectFeatures& current, const std::vector<std::uint16_t>& instances) {
  std::vector<MapCheck> out;
  if (config_.classifier == config::ClassifierMode::kPaper) return out;  // the paper has no such test
  std::optional<Matrix6d> pose_covariance;
  if (current.covariance) pose_covariance = *current.covariance * clamped_variance_factor(current.variance_factor);
  const Eigen::Matrix3d R_world_cam = current.T_world_cam.rotation_matrix();
  for (std::uint16_t instance : instances) {
    std::vector<detail::PointDisplacement> points;
    for (int k = 0; k < frame.size(); ++k) {
      if (frame.instance[k] != instance || !map_point_of_keypoint[k]) continue;
      if (!frame.features.has_depth(k) || frame.features.depth_m[k] > max_depth_m_) continue;
      if (!frame.features.stereo_ambiguous.empty() && frame.features.stereo_ambiguous[k]) continue;
      const double sigma_px = pixel_sigma_px(frame.octave[k], current.variance_factor);
      const auto p_cam = optim::stereo_point_in_camera(
          camera_, frame.uv_px[k], frame.features.u_right[k],
          optim::stereo_pixel_covariance(sigma_px, sigma_px, sigma_px));
      if (!p_cam) continue;
      const optim::PointWithCovariance p_world =
          optim::point_to_world(*p_cam, current.T_world_cam, pose_covariance ? &*pose_covariance : nullptr);
      detail::PointDisplacement p;
      p.d = p_world.p - *map_point_of_keypoint[k];
      p.covariance = p_world.covariance;
      p.pixel_covariance = R_world_cam * p_cam->covariance * R_world_cam.transpose();
      points.push_back(p);
    }
    const std::vector<detail::PointDisplacement> kept = detail::consistent_points(points);
    if (static_cast<int>(kept.size()) < config_.min_object_points) continue;
    const detail::CommonDisplacement common =
        detail::weighted_common_displacement(kept, kCommonMapErrorFraction);
    MapCheck check;
    check.instance = instance;
    check.points = static_cast<int>(kept.size());
    check.displacement_m = common.mean_m;
    check.statistic = common.statistic;
    check.moving = common.statistic > kMapGate;
    if (check.moving) {
      // As after a moving verdict: unmasked again only after
      // hysteresis_frames static verdicts.
      tracks_[instance].mask_as_moving();
    }
    out.push_back(check);
  }
  return out;
}

}  // namespace sitepose::dynamic
