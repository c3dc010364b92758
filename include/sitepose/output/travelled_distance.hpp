#pragma once
// The distance the camera has travelled since the run's first pose, for the
// map-drift term of the published covariance (published_pose.hpp,
// docs/daemon/pose_quality.md). The map is anchored where the run starts:
// at its origin when the run builds it, at the first relocalisation when it
// was loaded (its own error there is what geo.anchor_std must cover). From
// there the map is extended by visual odometry without loop closure, so its
// error grows with the path, not with the time.
//
// A path length, not the straight line from the start: an honest upper
// measure for a machine that drives a loop (the straight line would shrink
// back to 0 with the drift kept); it also grows on back-and-forth passes
// over a map already built, where the drift does not (conservative there).
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
