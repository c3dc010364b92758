#include "sitepose/core/log.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <pty.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

namespace sitepose {
namespace {

// What a logger made by use_stderr_logger(name) writes for one warning while
// stderr is a terminal (a pseudo-terminal), with NO_COLOR as given.
std::string warning_on_a_terminal(const std::string& name, const char* no_color) {
  int master = -1;
  int slave = -1;
  if (openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) return "openpty failed";
  const int saved_stderr = dup(STDERR_FILENO);
  dup2(slave, STDERR_FILENO);
  setenv("TERM", "xterm", 1);  // spdlog colours only terminals it knows
  if (no_color != nullptr) {
    setenv("NO_COLOR", no_color, 1);
  } else {
    unsetenv("NO_COLOR");
  }
  const auto previous = spdlog::default_logger();
  use_stderr_logger(name);
  spdlog::warn("a warning");
  spdlog::default_logger()->flush();
  spdlog::set_default_logger(previous);
  dup2(saved_stderr, STDERR_FILENO);
  close(saved_stderr);
  close(slave);
  fcntl(master, F_SETFL, O_NONBLOCK);
  std::string text;
  char buffer[512];
  for (ssize_t n = 0; (n = read(master, buffer, sizeof(buffer))) > 0;)
    text.append(buffer, static_cast<std::size_t>(n));
  close(master);
  unsetenv("NO_COLOR");
  return text;
}

// issue 21: NO_COLOR (no-color.org) was ignored; it was honoured later
// without a test.
TEST(Log, ColourOnATerminalUnlessNoColorIsSet) {
  const std::string coloured = warning_on_a_terminal("log_test_coloured", nullptr);
  ASSERT_NE(coloured.find("a warning"), std::string::npos) << coloured;
  EXPECT_NE(coloured.find("\x1b["), std::string::npos) << "no colour on a terminal: " << coloured;

  const std::string plain = warning_on_a_terminal("log_test_no_color", "1");
  ASSERT_NE(plain.find("a warning"), std::string::npos) << plain;
  EXPECT_EQ(plain.find("\x1b["), std::string::npos) << "colour despite NO_COLOR=1: " << plain;

  // An empty NO_COLOR does not count (no-color.org).
  const std::string empty = warning_on_a_terminal("log_test_empty_no_color", "");
  EXPECT_NE(empty.find("\x1b["), std::string::npos) << empty;
}

}  // namespace
}  // namespace sitepose
