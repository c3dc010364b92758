#include <gtest/gtest.h>

#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/experiments/pose_consistency.hpp"

namespace sitepose::experiments {
namespace {

// Reference quantiles: chi2inv(0.025, 30) = 16.791, chi2inv(0.975, 30) =
// 46.979; chi2inv(0.025, 600) = 534.02, chi2inv(0.975, 600) = 669.77.
TEST(PoseConsistency, MeanBandMatchesChiSquareQuantiles) {
  const MeanBand small = chi_square_mean_band_95(10, 3);
  EXPECT_NEAR(small.low, 1.6791, 0.005);
  EXPECT_NEAR(small.high, 4.6979, 0.005);
  const MeanBand large = chi_square_mean_band_95(100, 6);
  EXPECT_NEAR(large.low, 5.3402, 0.001);
  EXPECT_NEAR(large.high, 6.6977, 0.001);
  const MeanBand none = chi_square_mean_band_95(0, 6);
  EXPECT_EQ(none.low, 0.0);
  EXPECT_EQ(none.high, 0.0);
}

// One value: chi2inv(0.025 / 0.975, 3) = 0.2158 / 9.3484, (.., 6) = 1.2373 /
// 14.4494; the band of the mean of one frame is the same band (to the
// Wilson-Hilferty approximation's error at 3 and 6 dof).
TEST(PoseConsistency, BandOfOneValueMatchesChiSquareQuantiles) {
  EXPECT_NEAR(chi_square_band_95(3).low, 0.2158, 1e-4);
  EXPECT_NEAR(chi_square_band_95(3).high, 9.3484, 1e-4);
  EXPECT_NEAR(chi_square_band_95(6).low, 1.2373, 1e-4);
  EXPECT_NEAR(chi_square_band_95(6).high, 14.4494, 1e-4);
  EXPECT_NEAR(chi_square_mean_band_95(1, 6).low, chi_square_band_95(6).low, 0.05);
  EXPECT_NEAR(chi_square_mean_band_95(1, 6).high, chi_square_band_95(6).high, 0.1);
  EXPECT_EQ(chi_square_band_95(7).high, 0.0);
  EXPECT_EQ(chi_square_band_95(0).high, 0.0);
}

NeesSample sample(double error_m, double bound_m, bool alert) {
  NeesSample s;
  s.error_position_m = Eigen::Vector3d(error_m, 0.0, 0.0);
  s.protection_level_m = bound_m;
  s.alert = alert;
  return s;
}

TEST(PoseConsistency, IntegrityCountsSplitAlarmsByTheTrueError) {
  NeesResult r;
  r.alert_limit_m = 0.10;
  r.samples = {sample(0.02, 0.05, false),  // fine
               sample(0.05, 0.20, true),   // false alarm
               sample(0.30, 0.05, false),  // missed detection
               sample(0.30, 0.50, true)};  // detected
  EXPECT_EQ(r.alerts(), 2);
  EXPECT_EQ(r.errors_over_limit(), 2);
  EXPECT_EQ(r.false_alarms(), 1);
  EXPECT_EQ(r.missed_detections(), 1);
  EXPECT_DOUBLE_EQ(r.bound_coverage(), 0.75);
}

}  // namespace
}  // namespace sitepose::experiments

namespace sitepose::experiments {
namespace {

// bench nees scores what siteposed ships.
TEST(PoseConsistency, OptionsAreTheDaemonsShippedDefaults) {
  const daemon::DaemonConfig shipped;
  const NeesOptions options;
  EXPECT_EQ(options.covariance.scale, shipped.covariance.scale);
  EXPECT_EQ(options.covariance.floor_position_m, shipped.covariance.floor_position_m);
  EXPECT_EQ(options.covariance.floor_attitude_deg, shipped.covariance.floor_attitude_deg);
  EXPECT_EQ(options.covariance.drift_m_per_sqrt_m, shipped.covariance.drift_m_per_sqrt_m);
  EXPECT_EQ(options.covariance.drift_deg_per_sqrt_m, shipped.covariance.drift_deg_per_sqrt_m);
  EXPECT_EQ(options.integrity.alert_limit_m, shipped.integrity.alert_limit_m);
  EXPECT_EQ(options.integrity.protection_level_sigmas, shipped.integrity.protection_level_sigmas);
}

}  // namespace
}  // namespace sitepose::experiments
