#include "sitepose/pipeline/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>
#include <cstring>
#include <string>

namespace sitepose::pipeline {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0) {
    watchdog_ns_ = static_cast<std::int64_t>(usec) * 1000;
  }
}

Status SystemdNotifier::notify(std::string_view assignments) {
  if (!enabled_) return ok_status();
  const std::string text(assignments);
  const int r = sd_notify(0, text.c_str());
  if (r > 0) {
    ++sent_;
    return ok_status();
  }
  ++failures_;
  return make_error(ErrorCode::kIoError,
                    std::string("sd_notify(\"") + text.substr(0, text.find('\n')) + "\"): " +
                        (r < 0 ? std::strerror(-r) : "NOTIFY_SOCKET not usable"));
}

// STATUS= is one line: newlines would start new assignments.
static std::string one_line(std::string_view text) {
  std::string s(text);
  for (char& c : s) {
    if (c == '\n') c = ' ';
  }
  return s;
}

Status SystemdNotifier::ready(std::string_view status) {
  return notify("READY=1\nSTATUS=" + one_line(status));
}
Status SystemdNotifier::status(std::string_view status) { return notify("STATUS=" + one_line(status)); }
Status SystemdNotifier::watchdog() { return notify("WATCHDOG=1"); }
Status SystemdNotifier::stopping(std::string_view status) {
  return notify("STOPPING=1\nSTATUS=" + one_line(status));
}

}  // namespace sitepose::pipeline
