#pragma once
// Wall time of the stages of a frame, for the timing reports.

#include <chrono>

namespace sitepose {

using SteadyClock = std::chrono::steady_clock;

// Milliseconds from `start` to now.
inline double ms_since(SteadyClock::time_point start) {
  return std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
}

}  // namespace sitepose
