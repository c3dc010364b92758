#pragma once
// Consistency of the published pose against ground truth: per OK frame the
// normalised estimation error squared (NEES) of the position (3 dof) and of
// the whole pose (6 dof) under the covariance the daemon publishes
// (output::published_pose, no site anchor), and the integrity flag's false
// alarms and missed detections. Shared by `sitepose bench nees` and its
// regression test. Inline mapping: reproducible.
//
// Frames: the SLAM world is the left camera of the frame the map was
// initialised on; the simulator's world is the left camera of frame 0. The
// estimate is mapped into the ground truth's world by the ground truth of
// the first OK frame (T_gt_slam = T_gt,first * T_est,first^-1; the identity
// when the map starts on frame 0), not by a fit over the run, which would
// hide drift the covariance does not claim. That first frame is not scored
// (its error is 0 by construction).
//
// Error vector e = [p_gt - p_est; log(R_gt R_est^T)] (world frame, rotation
// applied on the left), the [dp; dtheta] of geo::site_covariance, whose
// covariance (from the published left-twist one) the daemon's protection
// level uses too.

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/output/published_pose.hpp"

namespace sitepose::experiments {

struct NeesOptions {
  int frames = 0;  // 0 = all of the source
  // Copies of the daemon's shipped outputs.covariance and
  // outputs.integrity (the sitepose tool does not link the daemon module;
  // experiments_unit_test checks them against daemon::DaemonConfig).
  output::CovarianceOptions covariance{1.0, 0.001, 0.005, 0.003, 0.008};
  output::IntegrityOptions integrity{0.10, 4.5};
  std::function<void(int, int)> on_frame;  // (frame done, frames)
  // Polled before each frame; true ends the run there, scored so far
  // (NeesResult::partial).
  std::function<bool()> stop;
};

struct NeesSample {
  int frame = 0;
  double t_s = 0.0;
  Eigen::Vector3d error_position_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d error_rotation_rad = Eigen::Vector3d::Zero();
  double nees_position = 0.0;       // 3 dof
  double nees_pose = 0.0;           // 6 dof
  double protection_level_m = 0.0;  // as published
  bool alert = false;               // integrity flag, as published
  int features_used = 0;
  double travelled_m = 0.0;   // path length since the run's first pose (output::TravelledDistance)
  double map_travel_m = 0.0;  // distance of the map-drift term (PoseEstimate::map_travel_m)
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // the estimate (SLAM world, like the error)
  // The tracker's own covariance over [dp; dtheta] (before scale, floor and
  // drift), so a calibration can re-score other settings without re-running.
  Matrix6d tracker_covariance = Matrix6d::Zero();
};

// The chi-square band for the mean of N independent chi2(k) values:
// [chi2inv(0.025, N k) / N, chi2inv(0.975, N k) / N], quantiles by the
// Wilson-Hilferty approximation (relative error < 1e-3 for N k >= 30).
struct MeanBand {
  double low = 0.0;
  double high = 0.0;
};
MeanBand chi_square_mean_band_95(int samples, int dof);
// The 95 % band of one chi2(dof) value, dof 1..6 (exact quantiles; empty
// band for other dof). A consistent covariance puts a run's mean NEES in
// it: a run's error is mostly the map's slowly varying drift, so its
// frames are far from independent and its mean scatters from run to run
// like a single value, not like the mean of N (the band above).
MeanBand chi_square_band_95(int dof);

struct NeesResult {
  std::string name;
  int frames = 0;                // frames tracked
  bool partial = false;          // NeesOptions::stop ended the run early
  int frames_ok = 0;             // OK frames, the first (defining the frame) included
  int anchor_frame = -1;         // the first OK frame
  double anchor_offset_m = 0.0;  // |translation of T_gt_slam|
  std::vector<NeesSample> samples;
  double alert_limit_m = 0.0;
  double protection_level_sigmas = 0.0;

  double mean_nees_position() const;
  double mean_nees_pose() const;
  int false_alarms() const;       // alert while |dp| < alert limit
  int missed_detections() const;  // |dp| > alert limit without alert
  int errors_over_limit() const;  // |dp| > alert limit
  int alerts() const;
  double bound_coverage() const;  // share of samples with |dp| <= protection level

  // The same counts had the alert limit been limit_m (alert: protection
  // level over it, output::integrity_alert).
  struct IntegrityCounts {
    int alerts = 0;
    int errors_over_limit = 0;
    int false_alarms = 0;
    int missed_detections = 0;
  };
  IntegrityCounts integrity_at(double limit_m) const;
};

Expected<NeesResult> run_nees(const LabelledSource& source, const config::SiteposeConfig& config,
                              const NeesOptions& options = {});

}  // namespace sitepose::experiments
