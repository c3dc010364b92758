// sitepose: the command-line front end (sim, run, eval, bench, demo, ...).
// The command contract is in FORMATS.md; exit status 0 ok, 1 failure while
// running, 2 bad usage or bad input.

#include <algorithm>
#include <map>
#include <string>

#include "command_registry.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/log.hpp"

int main(int argc, char** argv) {
  using namespace sitepose;
  CLI::App app{"sitepose: stereo visual positioning for construction machines"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("sitepose ") + version_string() + " (" +
                                        git_revision() + ", " + build_type() + ")");
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off")
      ->capture_default_str();

  std::vector<cli::CommandSpec> commands = cli::registered_commands();
  std::sort(commands.begin(), commands.end(),
            [](const auto& a, const auto& b) { return a.name < b.name; });
  std::map<CLI::App*, cli::CommandAction> actions;
  for (const auto& spec : commands) {
    CLI::App* sub = app.add_subcommand(spec.name, spec.description);
    actions[sub] = spec.setup(*sub);
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int cli_status = app.exit(e);  // prints help / the usage error
    return cli_status == 0 ? 0 : 2;
  }
  if (auto st = set_log_level(log_level); !st) {
    return cli::fail("", st.error().message, 2);
  }
  for (auto& [sub, action] : actions) {
    if (sub->parsed()) return action();
  }
  return 2;
}
