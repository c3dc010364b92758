// siteposed: the sitepose positioning daemon (FORMATS.md command contract:
// `siteposed --config FILE`). Exit status: 0 ok, 1 failure while running,
// 2 bad usage or bad input (the message names the key or file).
// The command line only; the daemon is sitepose::daemon (src/daemon/).

#include <CLI/CLI.hpp>
#include <string>

#include "sitepose/core/build_info.hpp"
#include "sitepose/daemon/command.hpp"

namespace {

constexpr const char* kDescription =
    "siteposed: real-time stereo visual positioning daemon.\n"
    "Pipeline: capture -> detect -> track -> publish, one thread each, joined by lock-free rings "
    "(full ring: oldest frame dropped and counted; a replay at rate 'max' is lossless instead).\n"
    "Source: replay of a recorded sequence, two GigE Vision / USB3 Vision cameras through Aravis "
    "(source.type aravis) or UVC/V4L2 cameras, two devices or one side-by-side (source.type v4l2): "
    "paired by timestamp, rectified, reconnected with back-off when lost.\n"
    "Detect stage: the configured detector plugin (detector.name) when dynamic.mode is not none; "
    "the track stage then runs the dynamic layer in that mode (full = two-pass tracking).\n"
    "Outputs: LCM pose_t/health_t, CAN frames (J1939/NMEA 2000/sitepose PGN) to a candump log, "
    "stdout or a SocketCAN interface (a J1939 node: address claim, requests, heartbeat), TUM "
    "trajectory; site anchoring fixed or online from GNSS.\n"
    "systemd: Type=notify (READY after the first frame, STATUS, WATCHDOG while frames flow); "
    "SIGTERM/SIGINT stop cleanly.\n"
    "Settings: see config/siteposed.yaml.";

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{kDescription, "siteposed"};
  sitepose::daemon::Invocation invocation;
  app.add_option("--config", invocation.config_path, "Daemon settings YAML (see config/siteposed.yaml)")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_flag(
      "--check-config", invocation.check_config,
      "Validate the settings (and open a replay sequence; cameras are not opened), print the resolved "
      "settings, exit");
  app.add_option("--log-level", invocation.log_level,
                 "Override logging.level (trace, debug, info, warn, error, off)");
  app.set_version_flag("--version", std::string("siteposed ") + sitepose::version_string() + " (" +
                                        sitepose::git_revision() + ", " + sitepose::build_type() + ")");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  return sitepose::daemon::run_siteposed(invocation);
}
