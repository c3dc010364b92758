#pragma once
// A named network namespace for LCM udpm between processes (PLATFORM.md):
// udpm needs a multicast route, and the root namespace's default route would
// carry the packets off the machine, so a test builds its own:
//   ip netns add <name>; ip -n <name> link set lo up;
//   ip -n <name> route add 224.0.0.0/4 dev lo
// and each process enters it (enter_network_namespace) before opening
// udpm://239.255.76.67:7667?ttl=0. Deleted when the object goes, also when
// an assertion failed. Needs root (ip netns add); tests skip otherwise.

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <cstdlib>
#include <string>

#include "sitepose/testing/files.hpp"

namespace sitepose::testing {

// `command` through the shell; its stdout and stderr in *output.
inline int shell(const std::string& command, std::string* output = nullptr) {
  const TempDir dir("shell-cmd");
  const std::string log = dir / "cmd.log";
  const int rc = std::system((command + " >" + log + " 2>&1").c_str());
  if (output) *output = read_text(log);
  return rc;
}

class NetworkNamespace {
 public:
  explicit NetworkNamespace(std::string name) : name_(std::move(name)) {}
  ~NetworkNamespace() {
    if (created_) shell("ip netns del " + name_);
  }
  NetworkNamespace(const NetworkNamespace&) = delete;
  NetworkNamespace& operator=(const NetworkNamespace&) = delete;

  // "" on success, else why not.
  std::string create(bool multicast_route) {
    std::string out;
    if (shell("ip netns add " + name_, &out) != 0) return "ip netns add failed: " + out;
    created_ = true;
    if (shell("ip -n " + name_ + " link set lo up", &out) != 0) return "link set lo up: " + out;
    if (multicast_route && shell("ip -n " + name_ + " route add 224.0.0.0/4 dev lo", &out) != 0) {
      return "route add 224.0.0.0/4: " + out;
    }
    return "";
  }
  const std::string& name() const { return name_; }

 private:
  std::string name_;
  bool created_ = false;
};

// Moves the calling process (a forked child) into the named namespace.
inline bool enter_network_namespace(const std::string& name) {
  const int fd = open(("/var/run/netns/" + name).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = setns(fd, CLONE_NEWNET) == 0;
  close(fd);
  return ok;
}

}  // namespace sitepose::testing
