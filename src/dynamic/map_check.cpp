// MotionClassifier::check_against_map(): the objects called static, tested
// against their own map points (see the header).

#include <algorithm>
#include <cmath>

#include "detail/point_displacement.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"

namespace sitepose::dynamic {
namespace {

// The reference-frame test's object-level gate.
constexpr double kMapGate = detail::kChi2ThreeDof999;
// The map points of one object share an error that does not average out
// over them (the keyframe poses and local BA they came from), modelled as
// this fraction of one point's stereo noise, with margin: the truly static
// machines of the simulated scenarios stay well below the gate with it (and
// fail it without the term).
constexpr double kCommonMapErrorFraction = 0.3;
// The test's power is the average over many points. With fewer, a small or
// far object's mismatches and common error decide; the reference-frame test
// still covers such objects.
constexpr int kMinPoints = 30;

}  // namespace

std::vector<MapCheck> MotionClassifier::check_against_map(
    const tracking::PreparedFrame& frame,
    const std::vector<std::optional<Eigen::Vector3d>>& map_point_of_keypoint, const ObjectFeatures& current,
    const std::vector<std::uint16_t>& instances) {
  std::vector<MapCheck> out;
  if (config_.classifier == config::ClassifierMode::kPaper) return out;  // the paper has no such test
  std::optional<Matrix6d> pose_covariance;
  if (current.covariance)
    pose_covariance = *current.covariance * clamped_variance_factor(current.variance_factor);
  for (std::uint16_t instance : instances) {
    std::vector<detail::PointDisplacement> points;
    for (int k = 0; k < frame.size(); ++k) {
      if (frame.instance[k] != instance || !map_point_of_keypoint[k]) continue;
      if (!detail::gives_trusted_point(frame, k, max_depth_m_)) continue;
      const auto sighting =
          to_world(frame.uv_px[k], frame.features.u_right[k], frame.octave[k], current.variance_factor,
                   current.T_world_cam, pose_covariance ? &*pose_covariance : nullptr);
      if (!sighting) continue;
      detail::PointDisplacement p;
      p.d = sighting->p - *map_point_of_keypoint[k];
      p.covariance = sighting->covariance;
      p.pixel_covariance = sighting->pixel_covariance;
      points.push_back(p);
    }
    const std::vector<detail::PointDisplacement> kept = detail::consistent_points(points);
    if (static_cast<int>(kept.size()) < std::max(kMinPoints, config_.min_object_points)) continue;
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
      Track& track = tracks_[instance];
      track.mask_as_moving(current.t_ns);
      // A test against the map over kMinPoints points or more is not one
      // frame pair's mismatch: it counts as a second sign of motion too, so
      // the standing tracks of an articulated machine cannot unmask it while
      // its house turns (may_resume_work(), which reads the signs of
      // articulated machines only).
      track.note_sign_of_motion(current.t_ns);
    }
    out.push_back(check);
  }
  return out;
}

}  // namespace sitepose::dynamic
