#pragma once
// Waiting in tests for what another thread or process makes true (datagrams
// arriving, a file growing, a pipeline counting frames): poll the condition
// until it holds or a deadline passes. A passing test goes on as soon as
// the condition holds; the deadline only bounds a failing one, so it can be
// generous. Never sleep a fixed time and then count.

#include <chrono>
#include <thread>
#include <utility>

namespace sitepose::testing {

using WaitClock = std::chrono::steady_clock;

// True as soon as done() holds; false when `deadline` passed first.
template <class Condition>
bool wait_until(Condition&& done, WaitClock::time_point deadline,
                std::chrono::milliseconds poll = std::chrono::milliseconds(5)) {
  while (!done()) {
    if (WaitClock::now() >= deadline) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

// wait_until with the deadline `timeout` from now.
template <class Condition>
bool wait_for(Condition&& done, WaitClock::duration timeout,
              std::chrono::milliseconds poll = std::chrono::milliseconds(5)) {
  return wait_until(std::forward<Condition>(done), WaitClock::now() + timeout, poll);
}

}  // namespace sitepose::testing
