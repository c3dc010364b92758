#pragma once
// Runs a shell command line (the CLI tests' calls of the built binary).

#include <sys/wait.h>

#include <cstdlib>
#include <string>

namespace sitepose::testing {

// Exit status of `command` run by the shell; -1 when it did not exit
// (killed by a signal).
inline int run_command(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace sitepose::testing
