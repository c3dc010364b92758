// siteposed: the sitepose positioning daemon (FORMATS.md command contract:
// `siteposed --config FILE`). Exit status: 0 ok, 1 failure while running,
// 2 bad usage or bad input (the message names the key or file).

#include <signal.h>

#include <spdlog/sinks/stdout_color_sinks.h>

#include <CLI/CLI.hpp>
#include <cstdio>

#include "daemon.hpp"
#include "daemon_config.hpp"
#include "sitepose/config/config.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/log.hpp"

namespace {

constexpr const char* kDescription =
    "siteposed: real-time stereo visual positioning daemon.\n"
    "Pipeline: capture -> detect -> track -> publish, one thread each, joined by lock-free rings "
    "(full ring: oldest frame dropped and counted; a replay at rate 'max' is lossless instead).\n"
    "Source: replay of a recorded sequence (camera drivers are not in this build).\n"
    "Detect stage: the configured detector plugin (detector.name) when dynamic.mode is not none; "
    "the track stage then runs the dynamic layer in that mode (full = two-pass tracking).\n"
    "Outputs: LCM pose_t/health_t, CAN frames (J1939/NMEA 2000/sitepose PGN) to a candump log or "
    "stdout (no SocketCAN in this build), TUM trajectory; site anchoring fixed or online from GNSS.\n"
    "systemd: Type=notify (READY after the first frame, STATUS, WATCHDOG while frames flow); "
    "SIGTERM/SIGINT stop cleanly.\n"
    "Settings: see config/siteposed.yaml.";

int fail(const std::string& message, int status) {
  std::fprintf(stderr, "siteposed: %s\n", message.c_str());
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{kDescription, "siteposed"};
  std::string config_path;
  bool check_only = false;
  std::string log_level;
  app.add_option("--config", config_path, "Daemon settings YAML (see config/siteposed.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_flag("--check-config", check_only,
               "Validate the settings (and open the replay sequence), print the resolved settings, exit");
  app.add_option("--log-level", log_level, "Override logging.level (trace, debug, info, warn, error, off)");
  app.set_version_flag("--version", std::string("siteposed ") + sitepose::version_string() + " (" +
                                        sitepose::git_revision() + ", " + sitepose::build_type() + ")");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }

  // Before any thread exists, so every thread inherits the mask and only the
  // supervisor's sigtimedwait() takes these signals.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  // Logs on stderr (the journal under systemd); stdout may carry candump lines.
  spdlog::set_default_logger(spdlog::stderr_color_mt("siteposed"));

  auto config = sitepose::daemon::load_daemon_config(config_path);
  if (!config) return fail(config.error().message, 2);
  const std::string level = log_level.empty() ? config->sitepose.logging.level : log_level;
  if (auto st = sitepose::set_log_level(level); !st) return fail("--log-level: " + st.error().message, 2);

  const std::string resolved =
      sitepose::daemon::daemon_sections_to_yaml(*config) + sitepose::config::to_yaml(config->sitepose);
  if (check_only) {
    // The sequence is part of the input: check that it opens too.
    auto source = sitepose::pipeline::ReplaySource::open(config->replay);
    if (!source) return fail("source.replay.sequence: " + source.error().message, 2);
    std::printf("%s", resolved.c_str());
    std::fprintf(stderr, "siteposed: %s: configuration ok\n", config_path.c_str());
    return 0;
  }
  spdlog::info("siteposed {} ({}) starting with {}", sitepose::version_string(), sitepose::git_revision(),
               config_path);
  spdlog::info("resolved configuration:\n{}", resolved);

  auto daemon = sitepose::daemon::Daemon::create(*config);
  if (!daemon) return fail(daemon.error().message, daemon.error().exit_status());
  return (*daemon)->run(stop_signals);
}
