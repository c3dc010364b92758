// Receives siteposed's poses over LCM with the generated C++ classes
// (sitepose-dev: /usr/include/sitepose/pose_t.hpp) and prints one line per
// pose. Build against the installed package:
//   g++ -std=c++17 pose_subscriber.cpp -o pose_subscriber -llcm
// Usage: pose_subscriber [--count N] [--url URL] [--channel NAME]
//   --count N   exit after N poses (default: run until killed)
//   --url URL   LCM URL (default: LCM_DEFAULT_URL, else udpm://239.255.76.67:7667?ttl=0)
//   --channel   pose channel (default SITEPOSE_POSE, outputs.lcm.pose_channel)

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "sitepose/pose_t.hpp"

namespace {

struct Printer {
  long count = 0;
  long limit = 0;
  void on_pose(const lcm::ReceiveBuffer*, const std::string&, const sitepose::pose_t* m) {
    // Steer only on STATE_OK; FRAME_SITE: position is E, N, U in metres from
    // the site origin, lat/lon/height WGS84 (pose_t.lcm documents each field).
    std::printf(
        "pose seq=%lld utime=%lld state=%d frame=%d position=%.6f,%.6f,%.6f "
        "orientation=%.6f,%.6f,%.6f,%.6f velocity=%.6f,%.6f,%.6f lat=%.9f lon=%.9f height=%.4f "
        "heading=%.4f position_std=%.6f\n",
        static_cast<long long>(m->seq), static_cast<long long>(m->utime), m->state, m->frame, m->position[0],
        m->position[1], m->position[2], m->orientation[0], m->orientation[1], m->orientation[2],
        m->orientation[3], m->velocity[0], m->velocity[1], m->velocity[2], m->latitude_deg, m->longitude_deg,
        m->height_m, m->heading_deg, m->position_std_m);
    std::fflush(stdout);
    ++count;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string url;
  std::string channel = "SITEPOSE_POSE";
  Printer printer;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--count") == 0) {
      printer.limit = std::atol(argv[i + 1]);
    } else if (std::strcmp(argv[i], "--url") == 0) {
      url = argv[i + 1];
    } else if (std::strcmp(argv[i], "--channel") == 0) {
      channel = argv[i + 1];
    } else {
      std::fprintf(stderr, "usage: %s [--count N] [--url URL] [--channel NAME]\n", argv[0]);
      return 2;
    }
  }
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::fprintf(stderr, "cannot open LCM %s\n", url.empty() ? "(default URL)" : url.c_str());
    return 1;
  }
  lcm.subscribe(channel, &Printer::on_pose, &printer);
  while (printer.limit == 0 || printer.count < printer.limit) {
    if (lcm.handle() != 0) return 1;
  }
  return 0;
}
