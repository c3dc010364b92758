#pragma once
// The path length the camera has travelled since the run's first pose, as
// a run's report states it (bench nees). The published covariance's drift
// term does not use it: its distance is how far the map was built out to
// the pose (PoseEstimate::map_travel_m), which stays bounded where the
// machine drives over a map it has built, while this grows with every pass.
// Steps shorter than kMinStepM are accumulated from the last counted
// position, so a standing machine's pose jitter adds nothing however long
// it stands. LOST poses (the last pose repeated) are skipped; the jump of a
// relocalisation counts as a straight step.
// Not thread-safe; one owner (the daemon's publish thread, a bench).

#include <optional>

#include <Eigen/Core>

#include "sitepose/core/pose_estimate.hpp"

namespace sitepose::output {

class TravelledDistance {
 public:
  static constexpr double kMinStepM = 0.05;

  // Counts the camera position of `camera` unless it is LOST or not
  // finite; returns the distance travelled so far, m.
  double update(const PoseEstimate& camera);
  double metres() const { return travelled_m_; }

 private:
  std::optional<Eigen::Vector3d> last_counted_;
  double travelled_m_ = 0.0;
};

}  // namespace sitepose::output
