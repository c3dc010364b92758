#pragma once
// What every output publishes of one tracked pose, computed once from the
// tracker's answer (docs/daemon/README.md "Reference point, velocity,
// covariance"):
//   - the machine reference point instead of the left camera: a lever arm
//     given in the machine frame (x forward, y left, z up; the camera
//     upright: machine up = -y of the camera, forward = the configured
//     camera axis), so T_world_ref = T_world_cam * [I, R_cam_machine l];
//     the orientation stays the camera's;
//   - its covariance: the tracker's (over the left twist of T_world_cam,
//     PoseEstimate contract; the same twist moves the reference point)
//     times the a-posteriori variance factor `scale`, plus an isotropic
//     position / attitude error at the reference point (the floor for
//     unmodelled effects, and the site anchor's uncertainty where a site
//     frame is used), so no published covariance is zero: not the first
//     pose (which defines the SLAM frame, error 0 by construction), not one
//     the tracker reports without a covariance;
//   - the map's drift: the tracker's covariance is the pose given the map
//     (motion-only BA holds the points fixed), but the map itself drifts
//     from its origin as it is extended (visual odometry without loop
//     closure), so an isotropic position / attitude std that grows with
//     the distance over which the map was built out to the pose
//     (PoseEstimate::map_travel_m) is added too (docs/daemon/pose_quality.md
//     has its calibration);
//   - its velocity from two successive positions in the published frame.
// Pure functions; no state.

#include <cstdint>
#include <limits>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/geo/site_frame.hpp"

namespace sitepose::output {

struct ReferencePointOptions {
  Eigen::Vector3d lever_arm_m = Eigen::Vector3d::Zero();  // camera -> reference point, machine frame
};

struct CovarianceOptions {
  double scale = 1.0;                 // a-posteriori variance factor on the tracker's covariance
  double floor_position_m = 0.0;      // isotropic std added to the position (unmodelled effects)
  double floor_attitude_deg = 0.0;    // isotropic std added to the attitude
  double drift_m_per_sqrt_m = 0.0;    // map drift: position std where the map was built over 1 m
  double drift_deg_per_sqrt_m = 0.0;  // map drift: attitude std where the map was built over 1 m
};

// The map drift's isotropic stds where the map was built out over
// map_travel_m metres: a random walk over the distance, std = rate *
// sqrt(map_travel_m) (variance growing linearly with the path; it fits the
// simulated suite better than a std linear in the distance,
// docs/daemon/pose_quality.md).
struct DriftStd {
  double position_m = 0.0;
  double attitude_rad = 0.0;
};
DriftStd drift_std(const CovarianceOptions& covariance, double map_travel_m);

// Rotation machine -> camera for a machine whose forward axis is the camera
// axis `forward` and whose up is -y of the camera (the camera upright).
// Fails for forward = +y / -y (parallel to up).
Expected<Eigen::Matrix3d> rotation_cam_machine(geo::ForwardAxis forward);

// The reference point's pose: T_world_cam * [I, lever_arm_cam_m]; the
// covariance (left twist) is unchanged, as the same twist moves both.
PoseEstimate reference_pose(const PoseEstimate& camera, const Eigen::Vector3d& lever_arm_cam_m);

// Left-twist covariance of T_world_x that is an independent isotropic
// position error (std position_std_m at the point p_world) and attitude
// error (std attitude_std_rad): J^-1 D J^-T with J = [I, -hat(p); 0, I]
// (twist -> [dp; dtheta], geo::site_covariance).
Matrix6d isotropic_point_covariance(const Eigen::Vector3d& p_world, double position_std_m,
                                    double attitude_std_rad);

// The published pose of one tracked pose: reference point, scaled
// covariance plus the isotropic extra (floor, anchor and the map drift at
// camera.map_travel_m, as stds combined in quadrature).
PoseEstimate published_pose(const PoseEstimate& camera, const Eigen::Vector3d& lever_arm_cam_m,
                            const CovarianceOptions& covariance, double extra_position_std_m,
                            double extra_attitude_std_rad);

// Integrity (outputs.integrity): the protection level is
// protection_level_sigmas times the largest position standard deviation,
// sqrt(largest eigenvalue of the 3x3 [dp] covariance) (infinite when not
// finite); the alert is raised when it exceeds the alert limit (0 = never).
// The covariance is calibrated to be consistent (mean NEES in the chi2
// band), so its 3 sigma does not cover every frame; the protection level's
// multiple carries the integrity margin (docs/daemon/pose_quality.md).
struct IntegrityOptions {
  double alert_limit_m = 0.0;
  double protection_level_sigmas = 3.0;
};
double protection_level_m(const Eigen::Matrix3d& position_covariance, double sigmas);
inline bool integrity_alert(double bound_m, double alert_limit_m) {
  return alert_limit_m > 0.0 && !(bound_m <= alert_limit_m);
}

// Velocity of a point from two positions (same frame) and their [dp]
// covariances; errors of the two treated as independent (an upper bound:
// successive poses of one track are positively correlated).
struct Velocity {
  Eigen::Vector3d mps = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  bool valid() const { return mps.allFinite(); }
};
Velocity finite_difference_velocity(const Eigen::Vector3d& p0, const Eigen::Matrix3d& covariance0,
                                    std::int64_t t0_ns, const Eigen::Vector3d& p1,
                                    const Eigen::Matrix3d& covariance1, std::int64_t t1_ns);

}  // namespace sitepose::output
