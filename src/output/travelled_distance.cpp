#include "sitepose/output/travelled_distance.hpp"

namespace sitepose::output {

double TravelledDistance::update(const PoseEstimate& camera) {
  if (camera.state == TrackingState::kLost) return travelled_m_;
  const Eigen::Vector3d p = camera.T_world_cam.translation();
  if (!p.allFinite()) return travelled_m_;
  if (!last_counted_) {
    last_counted_ = p;
    return travelled_m_;
  }
  const double step_m = (p - *last_counted_).norm();
  if (step_m >= kMinStepM) {
    travelled_m_ += step_m;
    last_counted_ = p;
  }
  return travelled_m_;
}

}  // namespace sitepose::output
