#pragma once
// The LCM connection shared by the publisher and the GNSS subscriber.
//
// One lcm::LCM instance (open_lcm) may be shared by an LcmPublisher and an
// LcmGnssSubscriber: LCM allows publish() from one thread while another
// thread runs handle(). Provider URLs: "udpm://239.255.76.67:7667?ttl=0"
// (LCM's default, used when url is empty and LCM_DEFAULT_URL is unset),
// "memq://" (in-process, tests), "file:///path.lcmlog?mode=w" (a log).
// udpm needs a multicast route (PLATFORM.md); ttl=0 keeps packets on the
// host.

#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "sitepose/core/expected.hpp"

namespace sitepose::output {

struct LcmOptions {
  std::string url;  // empty: LCM_DEFAULT_URL or LCM's udpm default
  std::string pose_channel = "SITEPOSE_POSE";
  std::string health_channel = "SITEPOSE_HEALTH";
  std::string gnss_channel = "SITEPOSE_GNSS";
  int max_send_attempts = 3;  // per message and call, first attempt included

  // The URL parses (check_lcm_url), channels non-empty and distinct,
  // max_send_attempts in 1..10; the message names the key under `prefix`.
  Status validate(const std::string& prefix = "lcm") const;
};

// Ok when LCM would parse `url` (empty: the default): a known provider
// (udpm, memq, file, tcpq), for udpm a multicast IPv4 address and a port in
// 1..65535, options as key=value joined by &, ttl 0..255. Nothing is
// opened, so it holds while the network is not up yet. kInvalidArgument
// naming `key` and the (capped) URL.
Status check_lcm_url(const std::string& url, const std::string& key);

// kIoError naming the URL when LCM cannot open it (e.g. udpm without a
// multicast route: see PLATFORM.md).
Expected<std::shared_ptr<lcm::LCM>> open_lcm(const std::string& url);

}  // namespace sitepose::output
