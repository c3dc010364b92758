#pragma once
// Subcommands of `sitepose` register themselves here, one file each
// (cmd_<name>.cpp, bench_<name>.cpp, ablate_<name>.cpp), so main.cpp never
// changes when a command is added.

#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace sitepose::cli {

// Runs a parsed subcommand; returns the process exit status
// (0 ok, 1 failure while running, 2 bad usage or input: FORMATS.md).
using CommandAction = std::function<int()>;

struct CommandSpec {
  // "" for a top-level command, or the group it sits under: "bench"
  // (timings and ratios, never pass/fail) or "ablate" (ablation studies).
  std::string group;
  std::string name;
  std::string description;
  // Adds the options to `sub` (bound to variables the action captures) and
  // returns the action to run once parsing succeeded.
  std::function<CommandAction(CLI::App& sub)> setup;
};

// The spec of a command whose options fill an Args: `add_options(sub, args)`
// binds them to the fields of an Args that lives as long as the action, and
// `run(args)` is the action, run once parsing succeeded.
template <typename Args, typename AddOptions, typename Run>
CommandSpec make_command(std::string group, std::string name, AddOptions add_options, Run run,
                         std::string description) {
  return {std::move(group), std::move(name), std::move(description),
          [add_options, run](CLI::App& sub) -> CommandAction {
            auto args = std::make_shared<Args>();
            add_options(sub, *args);
            return [args, run] { return run(*args); };
          }};
}

void register_command(CommandSpec spec);
const std::vector<CommandSpec>& registered_commands();

struct CommandRegistrar {
  explicit CommandRegistrar(CommandSpec spec) { register_command(std::move(spec)); }
};

// A required option shown in the help as `flag TYPE_NAME`, the name of what
// it takes rather than its C++ type.
template <typename T>
CLI::Option* add_required(CLI::App& sub, const std::string& flag, T& value, const std::string& type_name,
                          const std::string& help) {
  return sub.add_option(flag, value, help)->type_name(type_name)->required();
}

// An option whose help shows its default and the range [min, max] its value
// must lie in.
template <typename T, typename Bound>
CLI::Option* add_bounded(CLI::App& sub, const std::string& flag, T& value, const std::string& help, Bound min,
                         Bound max) {
  return sub.add_option(flag, value, help)->capture_default_str()->check(CLI::Range(min, max));
}

// Prints "sitepose <command>: <message>" to stderr and returns `status`.
int fail(const std::string& command, const std::string& message, int status);

}  // namespace sitepose::cli
