#include "sitepose/daemon/command.hpp"

#include <signal.h>

#include <cstdio>

#include "sitepose/config/config.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/log.hpp"
#include "sitepose/daemon/daemon.hpp"
#include "sitepose/daemon/daemon_config.hpp"

namespace sitepose::daemon {
namespace {

int fail(const std::string& message, int status) {
  std::fprintf(stderr, "siteposed: %s\n", message.c_str());
  return status;
}

}  // namespace

int run_siteposed(const Invocation& invocation) {
  // Before any thread exists, so every thread inherits the mask and only the
  // supervisor's sigtimedwait() takes these signals.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  // Logs on stderr (the journal under systemd); stdout may carry candump lines.
  use_stderr_logger("siteposed");

  auto config = load_daemon_config(invocation.config_path);
  if (!config) return fail(config.error().message, 2);
  const std::string level =
      invocation.log_level.empty() ? config->sitepose.logging.level : invocation.log_level;
  if (auto st = set_log_level(level); !st) return fail("--log-level: " + st.error().message, 2);

  if (!config->orbslam2_ignored_keys.empty()) {
    std::string keys;
    for (const std::string& key : config->orbslam2_ignored_keys) keys += (keys.empty() ? "" : ", ") + key;
    spdlog::warn("source.orbslam2_settings {}: keys sitepose does not use, ignored: {}",
                 config->orbslam2_settings, keys);
  }
  const std::string resolved = to_yaml(*config);
  if (invocation.check_config) {
    if (auto st = check_startable(*config); !st) return fail(st.error().message, 2);
    std::printf("%s", resolved.c_str());
    std::fprintf(stderr, "siteposed: %s: configuration ok\n", invocation.config_path.c_str());
    return 0;
  }
  spdlog::info("siteposed {} ({}) starting with {}", version_string(), git_revision(),
               invocation.config_path);
  spdlog::info("resolved configuration:\n{}", resolved);

  auto daemon = Daemon::create(*config);
  if (!daemon) return fail(daemon.error().message, daemon.error().exit_status());
  return (*daemon)->run(stop_signals);
}

}  // namespace sitepose::daemon
