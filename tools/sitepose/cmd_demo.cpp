// `sitepose demo`: the embedded default run. It reports what this build can
// do; it grows into simulate → track → evaluate as those modules land.

#include <cstdio>

#include "command_registry.hpp"
#include "sitepose/core/build_info.hpp"

namespace sitepose::cli {
namespace {

int run_demo() {
  std::printf("sitepose %s (%s, %s)\n", version_string(), git_revision(), build_type());
  std::printf("demo: the simulator and tracker are not in this build yet; "
              "nothing was simulated or tracked.\n");
  return 0;
}

const CommandRegistrar kDemo{{"", "demo", "Simulate a site, track it and print the accuracy (embedded default)",
                              [](CLI::App&) -> CommandAction { return run_demo; }}};

}  // namespace
}  // namespace sitepose::cli
