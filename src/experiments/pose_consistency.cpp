#include "sitepose/experiments/pose_consistency.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Cholesky>

#include "sitepose/experiments/dynamic_run.hpp"
#include "sitepose/geo/site_frame.hpp"
#include "sitepose/output/travelled_distance.hpp"

namespace sitepose::experiments {
namespace {

constexpr double kZ975 = 1.959963984540054;  // standard normal 97.5 % quantile

// Wilson-Hilferty: chi2inv(p, v) ~ v (1 - 2/(9v) + z_p sqrt(2/(9v)))^3.
double chi_square_quantile(double z, double dof) {
  const double a = 2.0 / (9.0 * dof);
  const double c = 1.0 - a + z * std::sqrt(a);
  return dof * c * c * c;
}

struct OkPose {
  int frame = 0;
  PoseEstimate pose;
  double travelled_m = 0.0;  // path length at this pose (reported; the drift term uses map_travel_m)
};

// e^T P^-1 e; NaN when P is not positive definite.
template <int N>
double nees(const Eigen::Matrix<double, N, 1>& e, const Eigen::Matrix<double, N, N>& P) {
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(P);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  return e.dot(llt.solve(e));
}

NeesSample score(const OkPose& ok, const SE3& T_slam_cam_gt, const NeesOptions& options) {
  const PoseEstimate published =
      output::published_pose(ok.pose, Eigen::Vector3d::Zero(), options.covariance, 0.0, 0.0);
  // [dp; dtheta] covariance, as the daemon forms it for its protection level.
  const Matrix6d P = geo::site_covariance(SE3::identity(), published.T_world_cam, published.covariance);
  NeesSample s;
  s.frame = ok.frame;
  s.t_s = static_cast<double>(ok.pose.t_ns) * 1e-9;
  s.error_position_m = T_slam_cam_gt.translation() - published.T_world_cam.translation();
  s.error_rotation_rad = so3_log(T_slam_cam_gt.rotation() * published.T_world_cam.rotation().conjugate());
  Vector6d e;
  e << s.error_position_m, s.error_rotation_rad;
  const Eigen::Matrix3d P_position = P.topLeftCorner<3, 3>();
  s.nees_position = nees<3>(s.error_position_m, P_position);
  s.nees_pose = nees<6>(e, P);
  s.protection_level_m = output::protection_level_m(P_position, options.integrity.protection_level_sigmas);
  s.alert = output::integrity_alert(s.protection_level_m, options.integrity.alert_limit_m);
  s.features_used = ok.pose.counters.features_used;
  s.travelled_m = ok.travelled_m;
  s.map_travel_m = ok.pose.map_travel_m;
  s.position_m = published.T_world_cam.translation();
  s.tracker_covariance = geo::site_covariance(SE3::identity(), ok.pose.T_world_cam, ok.pose.covariance);
  return s;
}

template <typename Pred>
int count_if(const std::vector<NeesSample>& samples, Pred pred) {
  return static_cast<int>(std::count_if(samples.begin(), samples.end(), pred));
}

double mean_of(const std::vector<NeesSample>& samples, double NeesSample::*field) {
  if (samples.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (const NeesSample& s : samples) sum += s.*field;
  return sum / static_cast<double>(samples.size());
}

}  // namespace

MeanBand chi_square_mean_band_95(int samples, int dof) {
  if (samples <= 0 || dof <= 0) return {};
  const double v = static_cast<double>(samples) * dof;
  return {chi_square_quantile(-kZ975, v) / samples, chi_square_quantile(kZ975, v) / samples};
}

MeanBand chi_square_band_95(int dof) {
  // chi2inv(0.025, k), chi2inv(0.975, k) for k = 1..6.
  static constexpr std::array<MeanBand, 6> kBands{{{0.000982, 5.0239},
                                                   {0.0506, 7.3778},
                                                   {0.2158, 9.3484},
                                                   {0.4844, 11.1433},
                                                   {0.8312, 12.8325},
                                                   {1.2373, 14.4494}}};
  if (dof < 1 || dof > static_cast<int>(kBands.size())) return {};
  return kBands[static_cast<std::size_t>(dof - 1)];
}

double NeesResult::mean_nees_position() const { return mean_of(samples, &NeesSample::nees_position); }
double NeesResult::mean_nees_pose() const { return mean_of(samples, &NeesSample::nees_pose); }

int NeesResult::false_alarms() const {
  return count_if(samples,
                  [&](const NeesSample& s) { return s.alert && s.error_position_m.norm() < alert_limit_m; });
}

int NeesResult::missed_detections() const {
  return count_if(samples,
                  [&](const NeesSample& s) { return !s.alert && s.error_position_m.norm() > alert_limit_m; });
}

int NeesResult::errors_over_limit() const {
  return count_if(samples, [&](const NeesSample& s) { return s.error_position_m.norm() > alert_limit_m; });
}

int NeesResult::alerts() const {
  return count_if(samples, [](const NeesSample& s) { return s.alert; });
}

NeesResult::IntegrityCounts NeesResult::integrity_at(double limit_m) const {
  IntegrityCounts c;
  for (const NeesSample& s : samples) {
    const bool alert = output::integrity_alert(s.protection_level_m, limit_m);
    const double error_m = s.error_position_m.norm();
    c.alerts += alert ? 1 : 0;
    c.errors_over_limit += error_m > limit_m ? 1 : 0;
    c.false_alarms += alert && error_m < limit_m ? 1 : 0;
    c.missed_detections += !alert && error_m > limit_m ? 1 : 0;
  }
  return c;
}

double NeesResult::bound_coverage() const {
  if (samples.empty()) return std::numeric_limits<double>::quiet_NaN();
  const int covered = count_if(
      samples, [](const NeesSample& s) { return s.error_position_m.norm() <= s.protection_level_m; });
  return static_cast<double>(covered) / static_cast<double>(samples.size());
}

Expected<NeesResult> run_nees(const LabelledSource& source, const config::SiteposeConfig& config,
                              const NeesOptions& options) {
  std::vector<OkPose> ok;
  output::TravelledDistance travelled;  // over every pose, OK or not
  DynamicRunOptions run_options;
  run_options.frames = options.frames;
  run_options.stop = options.stop;
  run_options.on_frame = [&](int i, int frames, const slam::FrameReport& report) {
    const double travelled_m = travelled.update(report.pose);
    if (report.pose.state == TrackingState::kOk) ok.push_back({i, report.pose, travelled_m});
    if (options.on_frame) options.on_frame(i + 1, frames);
  };
  SITEPOSE_TRY(DynamicRunResult run, run_dynamic(source, config, run_options));
  if (static_cast<int>(run.ground_truth.size()) != run.frames) {
    return make_error(ErrorCode::kInvalidArgument, source.name() +
                                                       ": NEES needs ground truth for every frame (" +
                                                       std::to_string(run.ground_truth.size()) + " of " +
                                                       std::to_string(run.frames) + ")");
  }
  NeesResult result;
  result.name = source.name();
  result.frames = run.frames;
  result.partial = run.partial;
  result.frames_ok = static_cast<int>(ok.size());
  result.alert_limit_m = options.integrity.alert_limit_m;
  result.protection_level_sigmas = options.integrity.protection_level_sigmas;
  if (ok.empty()) return result;
  const OkPose& first = ok.front();
  result.anchor_frame = first.frame;
  const SE3 T_gt_slam = run.ground_truth[first.frame].T_world_cam * first.pose.T_world_cam.inverse();
  result.anchor_offset_m = T_gt_slam.translation().norm();
  const SE3 T_slam_gt = T_gt_slam.inverse();
  for (std::size_t k = 1; k < ok.size(); ++k) {
    const SE3 T_slam_cam_gt = T_slam_gt * run.ground_truth[ok[k].frame].T_world_cam;
    result.samples.push_back(score(ok[k], T_slam_cam_gt, options));
  }
  return result;
}

}  // namespace sitepose::experiments
