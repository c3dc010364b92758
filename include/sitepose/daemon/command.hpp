#pragma once
// What `siteposed` does once its command line is parsed (FORMATS.md command
// contract: `siteposed --config FILE`): load and validate the settings, then
// either print them (--check-config) or run the Daemon until the source ends
// or SIGTERM/SIGINT arrives. tools/siteposed/main.cpp only parses the
// command line and calls run_siteposed().

#include <string>

namespace sitepose::daemon {

struct Invocation {
  std::string config_path;
  bool check_config = false;  // validate, open the replay sequence, print the resolved settings
  std::string log_level;      // overrides logging.level when not empty
};

// Call on the main thread before any other thread exists: it blocks the stop
// signals for every thread started later, so that only the supervisor's
// sigtimedwait() takes them. Logs go to stderr (stdout may carry candump
// lines). Returns the exit status: 0 ok, 1 failure while running, 2 bad
// input (the message on stderr names the key or file).
int run_siteposed(const Invocation& invocation);

}  // namespace sitepose::daemon
