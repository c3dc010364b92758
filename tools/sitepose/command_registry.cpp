#include "command_registry.hpp"

#include <cstdio>

namespace sitepose::cli {
namespace {
std::vector<CommandSpec>& registry() {
  static std::vector<CommandSpec> commands;  // filled during static init
  return commands;
}
}  // namespace

void register_command(CommandSpec spec) { registry().push_back(std::move(spec)); }

const std::vector<CommandSpec>& registered_commands() { return registry(); }

int fail(const std::string& command, const std::string& message, int status) {
  std::fprintf(stderr, "sitepose %s: %s\n", command.c_str(), message.c_str());
  return status;
}

}  // namespace sitepose::cli
