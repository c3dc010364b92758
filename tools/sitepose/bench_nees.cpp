// `sitepose bench nees`: is the published covariance consistent? A
// simulated scenario tracked frame by frame (mode full, the scenario's
// labels), each OK pose scored against ground truth under the covariance the
// daemon publishes (shipped outputs.covariance, no site anchor): mean NEES
// of position (3 dof) and pose (6 dof) with the chi-square 95 % band of the
// window mean, and the integrity flag's false alarms and missed detections
// at the shipped alert limit (experiments/pose_consistency.hpp). Figures
// only, never pass/fail. Ctrl-C / SIGTERM: the figures and CSV of the frames
// tracked, marked partial, exit 130.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>

#include "command_config.hpp"
#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/experiments/pose_consistency.hpp"

namespace sitepose::cli {
namespace {

constexpr const char* kCommand = "bench nees";

struct Args {
  std::string scenario = "static";
  int frames = 0;
  std::optional<int> seed;
  std::optional<int> width;
  std::optional<int> height;
  std::string mode = "full";
  std::string config_path;
  std::string csv;
  experiments::NeesOptions nees;
};

Status write_csv(const std::string& path, const experiments::NeesResult& r) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!f) return make_error(ErrorCode::kIoError, "--csv " + path + ": cannot open for writing");
  std::fprintf(
      f.get(),
      "frame,t_s,ex_m,ey_m,ez_m,erx_rad,ery_rad,erz_rad,error_position_m,error_rotation_deg,"
      "nees_position,nees_pose,protection_level_m,alert,features_used,travelled_m,map_travel_m,x_m,y_m,z_m");
  // The tracker's own [dp; dtheta] covariance, upper triangle row by row
  // (tools/nees_calibrate.py re-scores other settings from it).
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) std::fprintf(f.get(), ",tracker_c%d%d", i, j);
  std::fprintf(f.get(), "\n");
  for (const auto& s : r.samples) {
    std::fprintf(
        f.get(),
        "%d,%.6f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%d,%d,%.6g,%.6g,%.6g,%.6g,%.6g",
        s.frame, s.t_s, s.error_position_m.x(), s.error_position_m.y(), s.error_position_m.z(),
        s.error_rotation_rad.x(), s.error_rotation_rad.y(), s.error_rotation_rad.z(),
        s.error_position_m.norm(), s.error_rotation_rad.norm() * 180.0 / std::numbers::pi, s.nees_position,
        s.nees_pose, s.protection_level_m, s.alert ? 1 : 0, s.features_used, s.travelled_m, s.map_travel_m,
        s.position_m.x(), s.position_m.y(), s.position_m.z());
    for (int i = 0; i < 6; ++i)
      for (int j = i; j < 6; ++j) std::fprintf(f.get(), ",%.9g", s.tracker_covariance(i, j));
    std::fprintf(f.get(), "\n");
  }
  if (std::fflush(f.get()) != 0 || std::ferror(f.get()))
    return make_error(ErrorCode::kIoError, "--csv " + path + ": write failed");
  return {};
}

double largest_map_travel_m(const experiments::NeesResult& r) {
  double largest_m = 0.0;
  for (const auto& s : r.samples) largest_m = std::max(largest_m, s.map_travel_m);
  return largest_m;
}

double share(int count, int total) { return total > 0 ? static_cast<double>(count) / total : 0.0; }

const char* in_band_word(double mean, const experiments::MeanBand& band) {
  if (mean < band.low) return "below (cautious)";
  if (mean > band.high) return "ABOVE (overconfident)";
  return "inside";
}

// Means over consecutive windows of kWindowFrames scored frames (the
// issue's "NEES over a window"): how many lie inside, below and above the
// band of one chi2 value.
void print_window_means(const experiments::NeesResult& r) {
  constexpr std::size_t kWindowFrames = 50;
  for (const int dof : {3, 6}) {
    const auto band = experiments::chi_square_band_95(dof);
    int below = 0;
    int inside = 0;
    int above = 0;
    for (std::size_t begin = 0; begin + kWindowFrames <= r.samples.size(); begin += kWindowFrames) {
      double sum = 0.0;
      for (std::size_t i = begin; i < begin + kWindowFrames; ++i)
        sum += dof == 3 ? r.samples[i].nees_position : r.samples[i].nees_pose;
      const double mean = sum / kWindowFrames;
      (mean < band.low ? below : mean > band.high ? above : inside) += 1;
    }
    std::printf("  %zu-frame windows, %d dof: %d inside, %d below, %d above\n", kWindowFrames, dof, inside,
                below, above);
  }
}

void print_result(const experiments::NeesResult& r, const Args& args) {
  const int n = static_cast<int>(r.samples.size());
  std::printf(
      "bench nees: %s, %d frames%s, %d OK (first OK frame %d defines the SLAM frame: offset to the "
      "ground truth's %.3g m; not scored), %d scored\n",
      r.name.c_str(), r.frames, r.partial ? " (interrupted: partial)" : "", r.frames_ok, r.anchor_frame,
      r.anchor_offset_m, n);
  const output::CovarianceOptions& c = args.nees.covariance;
  std::printf(
      "published covariance: scale %g x tracker + floor %g m / %g deg + drift %g m / %g deg x "
      "sqrt(map travel, m) (isotropic), no anchor; %.1f m travelled, map travel at the end %.1f m (largest "
      "%.1f m)\n",
      c.scale, c.floor_position_m, c.floor_attitude_deg, c.drift_m_per_sqrt_m, c.drift_deg_per_sqrt_m,
      r.samples.empty() ? 0.0 : r.samples.back().travelled_m,
      r.samples.empty() ? 0.0 : r.samples.back().map_travel_m, largest_map_travel_m(r));
  for (const int dof : {3, 6}) {
    const double mean = dof == 3 ? r.mean_nees_position() : r.mean_nees_pose();
    const auto band = experiments::chi_square_band_95(dof);
    const auto band_of_mean = experiments::chi_square_mean_band_95(n, dof);
    std::printf(
        "mean NEES %s (%d dof): %.3f, %s the 95 %% band of one chi2(%d) value [%.3f, %.3f] (band of the mean "
        "of %d independent frames [%.3f, %.3f])\n",
        dof == 3 ? "position" : "pose    ", dof, mean, in_band_word(mean, band), dof, band.low, band.high, n,
        band_of_mean.low, band_of_mean.high);
  }
  print_window_means(r);
  std::printf(
      "protection level (%g x largest position std) covers the position error in %.1f %% of scored frames\n",
      r.protection_level_sigmas, 100.0 * r.bound_coverage());
  std::printf(
      "integrity at alert limit %.3f m: %d alerts, %d frames with error > limit; false alarms %d "
      "(%.1f %% of scored frames), missed detections %d (%.1f %% of scored frames, %.1f %% of "
      "frames over the limit)\n",
      r.alert_limit_m, r.alerts(), r.errors_over_limit(), r.false_alarms(),
      100.0 * share(r.false_alarms(), n), r.missed_detections(), 100.0 * share(r.missed_detections(), n),
      100.0 * share(r.missed_detections(), r.errors_over_limit()));
  for (const double limit_m : {0.03, 0.05}) {
    const auto c = r.integrity_at(limit_m);
    std::printf(
        "  at %.2f m: %d alerts, %d over; false alarms %d (%.1f %%), missed detections %d (%.1f %%)\n",
        limit_m, c.alerts, c.errors_over_limit, c.false_alarms, 100.0 * share(c.false_alarms, n),
        c.missed_detections, 100.0 * share(c.missed_detections, n));
  }
}

int run(const Args& args) {
  install_interrupt_handlers();
  auto config = load_command_config(args.config_path, args.mode);
  if (!config) return fail(kCommand, config.error().message, 2);
  auto source = experiments::open_simulated(args.scenario, args.frames, args.seed, args.width, args.height);
  if (!source) return fail(kCommand, source.error().message, 2);
  experiments::NeesOptions options = args.nees;
  options.frames = args.frames;
  options.on_frame = [](int done, int frames) {
    if (done % 50 == 0 || done == frames) std::fprintf(stderr, "bench nees: %d/%d frames\n", done, frames);
  };
  options.stop = [] { return interrupted(); };
  auto result = experiments::run_nees(**source, *config, options);
  if (!result) return fail(kCommand, result.error().message, 1);
  print_result(*result, args);
  if (!args.csv.empty()) {
    if (auto st = write_csv(args.csv, *result); !st) return fail(kCommand, st.error().message, 1);
  }
  if (result->partial) {
    return report_interrupted(kCommand, args.csv.empty() ? "printed the figures of the frames tracked"
                                                         : "printed the figures and wrote the CSV of the "
                                                           "frames tracked");
  }
  return 0;
}

// --scale and one option per other shipped outputs.covariance and
// outputs.integrity setting, each overriding the shipped value to score
// another.
void add_covariance_options(CLI::App& sub, experiments::NeesOptions& nees) {
  sub.add_option("--scale", nees.covariance.scale, "outputs.covariance.scale to score (default the shipped)")
      ->check(CLI::Range(1e-6, 1e6));
  const auto add_override = [&sub](const char* flag, double& value, const std::string& key, double max) {
    sub.add_option(flag, value, key + " (default the shipped)")->check(CLI::Range(0.0, max));
  };
  output::CovarianceOptions& c = nees.covariance;
  add_override("--floor-position-m", c.floor_position_m, "outputs.covariance.floor_position_m", 100.0);
  add_override("--floor-attitude-deg", c.floor_attitude_deg, "outputs.covariance.floor_attitude_deg", 90.0);
  add_override("--drift-m-per-sqrt-m", c.drift_m_per_sqrt_m, "outputs.covariance.drift_m_per_sqrt_m", 1.0);
  add_override("--drift-deg-per-sqrt-m", c.drift_deg_per_sqrt_m, "outputs.covariance.drift_deg_per_sqrt_m",
               10.0);
  add_override("--alert-limit-m", nees.integrity.alert_limit_m, "outputs.integrity.alert_limit_m", 1000.0);
  sub.add_option("--protection-level-sigmas", nees.integrity.protection_level_sigmas,
                 "outputs.integrity.protection_level_sigmas (default the shipped)")
      ->check(CLI::Range(1.0, 100.0));
}

void add_options(CLI::App& sub, Args& args) {
  sub.add_option("--scenario", args.scenario, "Scenario name or YAML (default static)");
  sub.add_option("--frames", args.frames, "Frames (0 = the scenario's)")
      ->check(CLI::Range(0, std::numeric_limits<int>::max()));
  sub.add_option("--seed", args.seed, "Rendering seed (default the scenario's)");
  sub.add_option("--width", args.width, "Render width (same field of view)")->check(CLI::Range(64, 8192));
  sub.add_option("--height", args.height, "Render height")->check(CLI::Range(64, 8192));
  sub.add_option("--mode", args.mode, "Masking mode (default full)");
  sub.add_option("--config", args.config_path, "sitepose YAML config");
  add_covariance_options(sub, args.nees);
  sub.add_option("--csv", args.csv, "Write one row per scored frame");
}

const CommandRegistrar kBenchNees{make_command<Args>(
    "bench", "nees", add_options, run,
    "NEES of the published pose covariance and integrity false-alarm / missed-detection rates on a "
    "simulated scenario")};

}  // namespace
}  // namespace sitepose::cli
