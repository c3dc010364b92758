// sitepose: the command-line front end (sim, run, eval, bench, demo, ...).
// The command contract is in FORMATS.md; exit status 0 ok, 1 failure while
// running, 2 bad usage or bad input.

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <tuple>

#include "command_registry.hpp"
#include "sitepose/core/build_info.hpp"
#include "sitepose/core/log.hpp"

int main(int argc, char** argv) {
  using namespace sitepose;
  use_stderr_logger("sitepose");
  CLI::App app{"sitepose: stereo visual positioning for construction machines"};
  app.require_subcommand(1);
  // Options the subcommands do not know (--log-level) go to this app, so
  // they may come after the subcommand too; subcommands inherit the setting.
  app.fallthrough();
  app.set_version_flag("--version", std::string("sitepose ") + version_string() + " (" + git_revision() +
                                        ", " + build_type() + ")");
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off")->capture_default_str();

  std::vector<cli::CommandSpec> commands = cli::registered_commands();
  std::sort(commands.begin(), commands.end(), [](const auto& a, const auto& b) {
    return std::tie(a.group, a.name) < std::tie(b.group, b.name);
  });
  const std::map<std::string, std::string> group_descriptions{
      {"bench", "Timings and ratios measured in one run (never pass/fail)"},
      {"ablate", "Ablation studies of the paper, each writing CSV + PNG"},
      {"map", "Saved site maps (sitepose run --map-out)"},
      {"vocab", "Place-recognition vocabularies (sitepose run --vocabulary)"}};
  std::map<std::string, CLI::App*> groups;
  std::map<CLI::App*, cli::CommandAction> actions;
  for (const auto& spec : commands) {
    CLI::App* parent = &app;
    if (!spec.group.empty()) {
      auto [it, inserted] = groups.try_emplace(spec.group, nullptr);
      if (inserted) {
        const auto desc = group_descriptions.find(spec.group);
        it->second =
            app.add_subcommand(spec.group, desc != group_descriptions.end() ? desc->second : spec.group);
        it->second->require_subcommand(1);
      }
      parent = it->second;
    }
    CLI::App* sub = parent->add_subcommand(spec.name, spec.description);
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
    if (!sub->parsed()) continue;
    const int status = action();
    // Results printed on stdout are output too: a full disk or closed pipe
    // there is a failure, seen only when stdio writes its buffer.
    if (std::fflush(stdout) != 0 || std::ferror(stdout) != 0) {
      return cli::fail(sub->get_name(), std::string("cannot write to stdout: ") + std::strerror(errno),
                       status == 0 ? 1 : status);
    }
    return status;
  }
  return 2;
}
