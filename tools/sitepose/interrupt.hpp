#pragma once
// Ctrl-C (SIGINT) and SIGTERM as a request to stop: the long commands (run,
// sim, bench) poll interrupted() between units of work, write what they
// have done, mark it partial and exit kInterruptedStatus. The handler only
// sets a flag; a second signal ends the process at once (the default action
// is restored by the first one), so a stuck command can still be killed.

#include <cstddef>
#include <string>

namespace sitepose::cli {

// 128 + SIGINT, what a shell reports for a command ended by Ctrl-C.
inline constexpr int kInterruptedStatus = 130;

// Installs the handlers: first thing in the action of a command that polls
// interrupted() (the others keep the default: a signal ends them).
void install_interrupt_handlers();

// True once SIGINT or SIGTERM arrived.
bool interrupted();

// Prints "sitepose <command>: interrupted (SIGINT|SIGTERM): <what>" to
// stderr and returns kInterruptedStatus.
int report_interrupted(const char* command, const char* what_was_written);

// For a bench that prints a table row by row: "<measured> of <total>
// <rows> measured (interrupted: partial)" on stdout, then
// report_interrupted(command, "printed the rows of the <rows> measured").
int report_rows_interrupted(const char* command, std::size_t measured, std::size_t total,
                            const std::string& rows);

}  // namespace sitepose::cli
