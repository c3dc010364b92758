#pragma once
// Helpers of the daemon integration tests: a simulated sequence shared by
// the tests (generated once with `sitepose sim` into the build tree), temp
// folders, a systemd notify socket that records what arrives (with the
// time), child processes with their own environment, and TUM/GT checks.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sitepose/eval/evaluate.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::daemon::testing {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

inline constexpr int kSequenceFrames = 30;

// A simulated scenario (960x540) generated once per build tree under
// SITEPOSE_TEST_DATA_DIR/<scenario><frames>, then reused; an atomic rename
// keeps parallel tests safe. Empty when the simulator failed.
inline std::string simulated_sequence(const std::string& scenario, int frames) {
  const std::string name = scenario + std::to_string(frames);
  const fs::path dir = fs::path(SITEPOSE_TEST_DATA_DIR) / name;
  if (fs::exists(dir / "times.txt")) return dir.string();
  fs::create_directories(dir.parent_path());
  const fs::path tmp = dir.parent_path() / (name + ".tmp." + std::to_string(getpid()));
  const std::string cmd = std::string(SITEPOSE_SITEPOSE_EXE) + " sim --scenario " + scenario + " --frames " +
                          std::to_string(frames) + " --out " + tmp.string() + " > /dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) return "";
  std::error_code ec;
  fs::rename(tmp, dir, ec);
  if (ec) fs::remove_all(tmp);  // another test won the race
  return fs::exists(dir / "times.txt") ? dir.string() : "";
}

// static scenario, 30 frames at 6 fps (about 10 s to generate).
inline std::string shared_sequence() { return simulated_sequence("static", kSequenceFrames); }

using sitepose::testing::read_lines;
using sitepose::testing::read_text;
using sitepose::testing::TempDir;
using sitepose::testing::write_file;

// Datagrams as systemd's notify socket receives them, each with its time.
class NotifySocket {
 public:
  struct Message {
    Clock::time_point t;
    std::string text;
  };
  explicit NotifySocket(const std::string& path) : path_(path) {
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
    unlink(path.c_str());
    ok_ = fd_ >= 0 && bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0;
    timeval tv{0, 100'000};
    setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
    reader_ = std::jthread([this](std::stop_token stop) {
      char buf[4096];
      while (!stop.stop_requested()) {
        const ssize_t n = recv(fd_, buf, sizeof(buf), 0);
        if (n <= 0) continue;  // timeout: look at the stop token again
        std::lock_guard lock(mutex_);
        messages_.push_back({Clock::now(), std::string(buf, n)});
      }
    });
  }
  ~NotifySocket() {
    reader_ = {};
    if (fd_ >= 0) close(fd_);
    unlink(path_.c_str());
  }
  bool ok() const { return ok_; }
  std::vector<Message> messages() {
    std::lock_guard lock(mutex_);
    return messages_;
  }
  // Messages containing `needle`.
  std::vector<Message> with(const std::string& needle) {
    std::vector<Message> out;
    for (auto& m : messages()) {
      if (m.text.find(needle) != std::string::npos) out.push_back(m);
    }
    return out;
  }

 private:
  std::string path_;
  int fd_ = -1;
  bool ok_ = false;
  std::mutex mutex_;
  std::vector<Message> messages_;
  std::jthread reader_;
};

// A child process running `argv` with extra environment variables
// ("WATCHDOG_PID" with value "self" becomes the child's own pid); stderr
// goes to `stderr_path`.
class Child {
 public:
  Child(std::vector<std::string> argv, std::vector<std::pair<std::string, std::string>> env,
        const std::string& stderr_path) {
    pid_ = fork();
    if (pid_ == 0) {
      for (auto& [k, v] : env) setenv(k.c_str(), v == "self" ? std::to_string(getpid()).c_str() : v.c_str(), 1);
      const int fd = open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        dup2(fd, 2);
        dup2(fd, 1);
      }
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~Child() {
    if (pid_ > 0 && !done_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  // Exit status, -1 on timeout (then killed), 128 + signal when signalled.
  int wait(std::chrono::seconds timeout) {
    const auto end = Clock::now() + timeout;
    while (Clock::now() < end) {
      int status = 0;
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        done_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));  // test harness only
    }
    return -1;
  }

 private:
  pid_t pid_ = -1;
  bool done_ = false;
};

// Every line of a TUM file has 8 numbers.
inline void expect_complete_tum_lines(const std::vector<std::string>& lines) {
  for (const auto& line : lines) {
    std::istringstream in(line);
    double v;
    int n = 0;
    while (in >> v) ++n;
    EXPECT_EQ(n, 8) << "incomplete TUM line: \"" << line << "\"";
  }
}

// ATE (m, after SE(3) alignment without scale) of a TUM file against the
// sequence's ground truth.
inline double ate_rmse_m(const std::string& sequence, const std::string& tum) {
  auto gt = io::read_kitti_trajectory(sequence + "/poses.txt", sequence + "/times.txt");
  auto est = io::read_tum_trajectory(tum);
  EXPECT_TRUE(gt && est);
  if (!gt || !est) return 1e9;
  auto r = eval::evaluate(*gt, *est, eval::EvalOptions{});
  EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
  return r ? r->ate_m.rmse : 1e9;
}

}  // namespace sitepose::daemon::testing
