#include "interrupt.hpp"

#include <csignal>
#include <cstdio>

namespace sitepose::cli {
namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_stop_signal(int signal_number) { g_signal = signal_number; }

}  // namespace

void install_interrupt_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  // SA_RESTART: file reads and writes in progress are not cut short with
  // EINTR; SA_RESETHAND: a second signal takes the default action.
  action.sa_flags = SA_RESTART | SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

bool interrupted() { return g_signal != 0; }

int report_interrupted(const char* command, const char* what_was_written) {
  std::fprintf(stderr, "sitepose %s: interrupted (%s): %s\n", command,
               g_signal == SIGTERM ? "SIGTERM" : "SIGINT", what_was_written);
  return kInterruptedStatus;
}

int report_rows_interrupted(const char* command, std::size_t measured, std::size_t total,
                            const std::string& rows) {
  std::printf("%zu of %zu %s measured (interrupted: partial)\n", measured, total, rows.c_str());
  return report_interrupted(command, ("printed the rows of the " + rows + " measured").c_str());
}

}  // namespace sitepose::cli
