#pragma once
// What the AravisSource test files share (aravis_source_test.cpp: scripted
// cameras; aravis_action_test.cpp: cameras on action commands): a 64x48
// stereo pair, its calibration and source options, and a bounded wait for
// the next event.

#include <chrono>
#include <cstdint>

#include "sitepose/drivers/aravis/aravis_source.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::aravis::test {

using Clock = std::chrono::steady_clock;
using pipeline::SourceEventKind;
using testing::TempDir;
using namespace std::chrono_literals;

inline constexpr int kW = 64, kH = 48;
inline constexpr std::int64_t kMs = 1'000'000;

// Cameras "L" and "R" at 20 Hz, pairs within 2 ms, lost after 0.2 s,
// reconnect backoff 10-40 ms.
inline AravisSourceOptions options(const TempDir& dir) {
  AravisSourceOptions o;
  o.left_id = "L";
  o.right_id = "R";
  o.calibration = dir.write("calib.txt",
                            "P0: 50 0 32 0 0 50 24 0 0 0 1 0\n"
                            "P1: 50 0 32 -10 0 50 24 0 0 0 1 0\n");
  o.camera.frame_rate_hz = 20.0;
  o.pair_tolerance_ms = 2.0;
  o.lost_timeout_s = 0.2;
  o.reconnect_min_s = 0.01;
  o.reconnect_max_s = 0.04;
  return o;
}

inline Expected<pipeline::SourceEvent> next_within(AravisSource& source, std::chrono::milliseconds timeout) {
  return source.next({}, Clock::now() + timeout);
}

}  // namespace sitepose::drivers::aravis::test
