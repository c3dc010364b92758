#pragma once
// A detector plugin run in a child process, sitepose-detector-host, so that
// a plugin that crashes (SIGSEGV, abort) or hangs cannot end or block the
// process that uses it (issue 20; siteposed's dynamic.detector_isolation).
//
// The host is started with posix_spawn (no fork of this multi-threaded
// process; the child gets an empty signal mask and default handlers, its
// stdout is our stderr so that a chatty plugin cannot write into a CAN dump
// on stdout). Frames go through a memfd, messages through a socket pair:
// detector_host/protocol.hpp. What comes back is validated by the same
// code as an in-process plugin's (plugin_calls.hpp).
//
// Failure of the host, each a failed call (an Error: the caller goes on
// without detections for that frame, as for any detector failure):
//   * crash: the socket reaches EOF (or a reply does not decode): the host
//     is reaped, counted in `crashes` with its signal or exit status;
//   * hang: no reply within call_timeout: the host is killed (SIGKILL),
//     reaped and counted in `hangs`;
//   then calls fail at once ("restarting") until the back-off has passed
//   (backoff_min, doubling per failed start or death up to backoff_max,
//   back to backoff_min after a call that succeeds); the next call starts a
//   new host (counted in `restarts` once it is ready) and is made.
// The first start happens in load_isolated_plugin(); its failure (no host
// binary, a plugin that does not load, create() failing, a host that dies
// at start) is returned as the error, like load_detector_plugin()'s.
// Threads: as any Detector (one thread at a time); the counters are atomics
// that any thread may read.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/detect/plugin_loader.hpp"

namespace sitepose::detect {

struct HostCounters {
  std::atomic<std::int64_t> crashes{0};   // host deaths during a call (signal, exit, garbage)
  std::atomic<std::int64_t> hangs{0};     // hosts killed at call_timeout
  std::atomic<std::int64_t> restarts{0};  // hosts started again after a death, ready
  std::atomic<std::int64_t> failed_starts{0};
};

struct IsolationOptions {
  bool in_child_process = false;                   // false: load_detector_plugin() in this process
  std::chrono::milliseconds call_timeout{10000};   // a detect/segment call longer: the host is killed
  std::chrono::milliseconds start_timeout{30000};  // host start + dlopen + create()
  std::chrono::milliseconds backoff_min{200};
  std::chrono::milliseconds backoff_max{10000};
  std::string host_path;                   // empty: detector_host_path()
  std::shared_ptr<HostCounters> counters;  // may be empty
};

// sitepose-detector-host: $SITEPOSE_DETECTOR_HOST when set, else
// <directory of the running executable>/../lib/sitepose/sitepose-detector-host
// (installed layout), else the build tree's (compiled in). kNotFound names
// where it looked.
Expected<std::string> detector_host_path();

Expected<std::unique_ptr<Detector>> load_isolated_plugin(const std::string& path,
                                                         const std::string& config_yaml,
                                                         const PluginLoadOptions& options,
                                                         const IsolationOptions& isolation);

}  // namespace sitepose::detect
