#pragma once
// The site frame and what a pose looks like in it.
//
// Site frame = local East-North-Up frame (x East, y North, z Up, metres) at
// a geodetic origin (LocalEnu). T_site_slam maps the SLAM world frame into
// it; it comes from commissioning (config) or from SiteAnchor (online, from
// RTK fixes). SiteFrame turns a SLAM pose of the left camera into ENU, WGS84
// latitude/longitude/height, UTM/UPS and a heading, and carries the pose
// covariance along.
//
// Heading: the machine's forward direction is an axis of the left camera
// frame (camera axes: x right, y down, z optical axis). The camera looks
// sideways on the roller: looking to the machine's right, forward is -x (the
// default, and the simulator's default `side: right`); looking to its left,
// forward is +x. heading_deg is the angle of that axis, projected on the
// horizontal plane, from true north (the site frame's +y), clockwise, in
// [0, 360). Grid (UTM) north differs by the meridian convergence.
//
// Covariance: PoseEstimate::covariance is over the left-multiplied twist
// [rho; omega] of T_slam_cam. It is converted to [dp; dtheta] (position
// error of the camera, m, and attitude error as a small rotation applied on
// the left, rad), both in the SLAM frame, then rotated into the site frame:
// Sigma_site = B J Sigma J^T B^T with J = [I, -hat(p_slam); 0, I] and
// B = blockdiag(R_site_slam, R_site_slam). position_std_m is
// sqrt(trace(Sigma_site position block)); heading_std_deg is the first-order
// propagation of the attitude block through the heading formula. The
// uncertainty of T_site_slam itself is not added.
//
// Immutable after construction; safe to use from any thread.

#include <cstdint>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/geo/geodetic.hpp"

namespace sitepose::geo {

enum class ForwardAxis { kPlusX, kMinusX, kPlusY, kMinusY, kPlusZ, kMinusZ };

const char* to_string(ForwardAxis axis);  // "+x", "-x", ...
// Accepts "+x" "-x" "+y" "-y" "+z" "-z" ("x" = "+x"); names the text otherwise.
Expected<ForwardAxis> parse_forward_axis(std::string_view text);
Eigen::Vector3d axis_vector(ForwardAxis axis);  // unit vector in the camera frame

struct SitePose {
  std::int64_t t_ns = 0;
  SE3 T_site_cam;              // left camera in the site (ENU) frame
  Matrix6d covariance_site;    // [dp (m); dtheta (rad)] in the site frame
  Geodetic geodetic;           // left camera origin, WGS84
  UtmPosition utm;             // left camera origin
  double heading_deg = 0.0;    // NaN when the forward axis is (near) vertical
  double heading_std_deg = 0.0;
  double position_std_m = 0.0;
};

class SiteFrame {
 public:
  // Fails when the origin is not a valid WGS84 position.
  static Expected<SiteFrame> create(const Geodetic& origin, const SE3& T_site_slam,
                                    ForwardAxis forward_axis_cam);

  const LocalEnu& enu() const { return enu_; }
  const SE3& T_site_slam() const { return T_site_slam_; }
  ForwardAxis forward_axis_cam() const { return forward_axis_cam_; }

  // covariance_slam: over the left twist of T_slam_cam, as PoseEstimate.
  // Fails only if the pose is not finite or UTM/UPS cannot represent it.
  Expected<SitePose> to_site(std::int64_t t_ns, const SE3& T_slam_cam,
                             const Matrix6d& covariance_slam) const;
  Expected<SitePose> to_site(const PoseEstimate& pose) const {
    return to_site(pose.t_ns, pose.T_world_cam, pose.covariance);
  }

 private:
  SiteFrame(LocalEnu enu, const SE3& T_site_slam, ForwardAxis forward_axis_cam)
      : enu_(std::move(enu)), T_site_slam_(T_site_slam), forward_axis_cam_(forward_axis_cam) {}

  LocalEnu enu_;
  SE3 T_site_slam_;
  ForwardAxis forward_axis_cam_;
};

// Heading (deg from north, clockwise, [0, 360)) of a direction given in the
// site frame; NaN if its horizontal part is shorter than 1e-6 of its length.
double heading_deg_of(const Eigen::Vector3d& direction_site);

// [dp; dtheta] covariance of T_site_cam from the left-twist covariance of
// T_slam_cam (formula above).
Matrix6d site_covariance(const SE3& T_site_slam, const SE3& T_slam_cam,
                         const Matrix6d& covariance_slam);

}  // namespace sitepose::geo
