#include "sitepose/dynamic/two_pass.hpp"

#include <algorithm>

namespace sitepose::dynamic {
namespace {

// chi2 6 dof, 99 %. Not a sharp test: pass 1 on a reduced background is
// noisier than its covariance says (truly static machines trip it now and
// then), so a failure only means pass 2 is not trusted this frame.
constexpr double kPass2ConsistencyGate = 16.81;

}  // namespace

void InstanceSet::remove(std::uint16_t id) { std::erase(ids_, id); }

bool InstanceSet::contains(std::uint16_t id) const {
  return std::find(ids_.begin(), ids_.end(), id) != ids_.end();
}

KeypointMask background_keypoints(const tracking::PreparedFrame& frame) {
  KeypointMask mask(frame.size(), 0);
  for (int k = 0; k < frame.size(); ++k) mask[k] = frame.instance[k] == 0 ? 1 : 0;
  return mask;
}

KeypointMask keypoints_of(const tracking::PreparedFrame& frame, const InstanceSet& instances) {
  return with_keypoints_of(KeypointMask(frame.size(), 0), frame, instances);
}

KeypointMask with_keypoints_of(KeypointMask mask, const tracking::PreparedFrame& frame,
                               const InstanceSet& instances) {
  for (int k = 0; k < frame.size(); ++k) mask[k] |= instances.contains(frame.instance[k]) ? 1 : 0;
  return mask;
}

InstanceSet static_objects(const std::vector<ClassifiedObject>& objects) {
  InstanceSet out;
  for (const ClassifiedObject& o : objects) {
    if (o.verdict.state == MotionState::kStatic) out.add(o.verdict.instance);
  }
  return out;
}

int apply_map_checks(const std::vector<MapCheck>& checks, std::vector<ClassifiedObject>& objects,
                     InstanceSet& static_objects) {
  int failed = 0;
  for (const MapCheck& check : checks) {
    for (ClassifiedObject& o : objects) {
      if (o.verdict.instance != check.instance) continue;
      o.verdict.map_statistic = check.statistic;
      if (check.moving) o.verdict.state = MotionState::kMoving;
    }
    if (!check.moving) continue;
    ++failed;
    static_objects.remove(check.instance);
  }
  return failed;
}

bool pass2_agrees_with_pass1(const tracking::PassResult& pass1, const tracking::PassResult& pass2) {
  // The unmasked objects add information; they must not move the pose beyond
  // pass 1's own uncertainty (a machine that has only just started moving can
  // pass as static over a short time span, and with more points than the
  // background it would pull the pose along).
  if (!pass1.covariance_world_cam) return true;
  const SE3 T_world_cam1 = pass1.T_cam_world.inverse();
  const SE3 T_world_cam2 = pass2.T_cam_world.inverse();
  const Vector6d difference = (T_world_cam2 * T_world_cam1.inverse()).log();
  const Matrix6d covariance = *pass1.covariance_world_cam * clamped_variance_factor(pass1.variance_factor);
  return difference.dot(covariance.ldlt().solve(difference)) <= kPass2ConsistencyGate;
}

}  // namespace sitepose::dynamic
