#pragma once
// Helpers of the daemon integration tests: a simulated sequence shared by
// the tests (generated once with `sitepose sim` into the build tree), child
// processes with their own environment, and TUM/GT checks; temp folders,
// the notify socket and waiting come from sitepose/testing.

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
#include "sitepose/testing/notify_socket.hpp"
#include "sitepose/testing/wait.hpp"

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

using sitepose::testing::NotifySocket;
using sitepose::testing::read_lines;
using sitepose::testing::read_text;
using sitepose::testing::TempDir;
using sitepose::testing::wait_for;
using sitepose::testing::write_file;

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
    int status = 0;
    done_ = wait_for([&] { return waitpid(pid_, &status, WNOHANG) == pid_; }, timeout, std::chrono::milliseconds(20));
    if (!done_) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
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
