#pragma once
// Helpers of the daemon integration tests: a simulated sequence shared by
// the tests (generated once with `sitepose sim` into the build tree), child
// processes with their own environment, TUM/GT checks, the replay config
// and the SIGTERM loop shared with the sweep; temp folders, the notify
// socket and waiting come from sitepose/testing.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
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
      for (auto& [k, v] : env)
        setenv(k.c_str(), v == "self" ? std::to_string(getpid()).c_str() : v.c_str(), 1);
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
    done_ = wait_for([&] { return waitpid(pid_, &status, WNOHANG) == pid_; }, timeout,
                     std::chrono::milliseconds(20));
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

// siteposed replaying `seq` at `rate` (max | recorded) into DIR/traj.tum
// and DIR/can.log, LCM to `lcm_url`, a fixed site anchor, mode none.
inline std::string config_text(const std::string& seq, const TempDir& dir, const std::string& rate,
                               const std::string& lcm_url) {
  return "source:\n  replay: {sequence: \"" + seq + "\", rate: " + rate +
         "}\n"
         "pipeline: {stall_timeout_s: 2.0}\n"
         "supervisor: {status_interval_s: 0.5}\n"
         "outputs:\n"
         "  trajectory: {path: \"" +
         (dir / "traj.tum") +
         "\", append: false}\n"
         "  can: {path: \"" +
         (dir / "can.log") +
         "\"}\n"
         "  lcm: {url: \"" +
         lcm_url +
         "\"}\n"
         "geo:\n  mode: fixed\n"
         "  origin: {latitude_deg: 48.137, longitude_deg: 11.575, height_m: 520.0}\n"
         "  T_site_slam: {translation_m: [0, 0, 2], rotation_wxyz: [0.5, -0.5, 0.5, -0.5]}\n"
         "dynamic: {mode: none}\n";
}

// Counts the pose/quality frames (PGN 65296 = 0xFF10) of a candump log and
// those whose TrackingState (data byte 1, bits 4-5) is not LOST.
inline std::pair<int, int> count_quality_frames(const std::string& path) {
  int all = 0, not_lost = 0;
  for (const auto& line : read_lines(path)) {
    const auto hash = line.find('#');
    if (hash == std::string::npos || hash < 8) continue;
    const std::string id = line.substr(hash - 8, 8);
    if (id.substr(2, 4) != "FF10") continue;
    ++all;
    const int state = (std::stoi(line.substr(hash + 3, 2), nullptr, 16) >> 4) & 0x3;
    not_lost += state != 2;
  }
  return {all, not_lost};
}

// SIGTERM at spread-out points of `runs` runs (during start-up, before the
// first pose, mid-run): every run stops within 2 s, cleanly, the trajectory
// holds only whole lines that parse, and exactly the poses published on CAN
// that were not LOST. Delays from a fixed seed, printed for a rerun; the
// runs, trajectory lines and lost lines (not-LOST poses on CAN without a
// trajectory line) are printed and recorded as test properties.
inline void expect_sigterm_at_random_points_loses_no_line(int runs) {
  const std::string seq = shared_sequence();
  ASSERT_FALSE(seq.empty());
  std::mt19937 rng(20);
  std::uniform_int_distribution<int> delay_ms(0, 5000);
  int lines_total = 0;
  int lost_total = 0;
  for (int run = 0; run < runs; ++run) {
    TempDir dir("sigterm-random");
    write_file(dir / "siteposed.yaml", config_text(seq, dir, "recorded", "memq://"));
    const int delay = delay_ms(rng);
    SCOPED_TRACE("run " + std::to_string(run) + ", SIGTERM after " + std::to_string(delay) + " ms");
    Child daemon({SITEPOSED_EXE, "--config", dir / "siteposed.yaml"}, {}, dir / "stderr.txt");
    std::this_thread::sleep_for(std::chrono::milliseconds(delay));
    const auto t0 = Clock::now();
    ASSERT_EQ(kill(daemon.pid(), SIGTERM), 0);
    const int status = daemon.wait(std::chrono::seconds(10));
    EXPECT_LT(Clock::now() - t0, std::chrono::seconds(2));
    // Before siteposed blocks the stop signals (its first lines; seconds on a
    // loaded machine) SIGTERM ends it by default (128 + 15, a clean stop for
    // systemd); nothing is open yet then.
    if (status == 128 + SIGTERM) {
      EXPECT_FALSE(fs::exists(dir / "traj.tum")) << "killed by SIGTERM after the outputs opened";
      continue;
    }
    EXPECT_EQ(status, 0) << read_text(dir / "stderr.txt");
    if (!fs::exists(dir / "traj.tum")) continue;  // stopped before the outputs opened
    const auto tum = read_lines(dir / "traj.tum");
    expect_complete_tum_lines(tum);
    auto parsed = io::read_tum_trajectory(dir / "traj.tum");
    EXPECT_TRUE(parsed) << parsed.error().message;
    if (fs::exists(dir / "can.log")) {
      const auto [published, not_lost] = count_quality_frames(dir / "can.log");
      EXPECT_EQ(static_cast<int>(tum.size()), not_lost) << "TUM lines vs poses published on CAN";
      EXPECT_GE(published, not_lost);
      lost_total += std::max(0, not_lost - static_cast<int>(tum.size()));
    }
    lines_total += static_cast<int>(tum.size());
  }
  std::printf("[figures] SIGTERM at random points: %d runs, %d trajectory lines, %d lost lines\n", runs,
              lines_total, lost_total);
  ::testing::Test::RecordProperty("runs", runs);
  ::testing::Test::RecordProperty("trajectory_lines", lines_total);
  ::testing::Test::RecordProperty("lost_lines", lost_total);
  EXPECT_GT(lines_total, 0) << "no run got as far as a pose: the delays test nothing mid-run";
}

}  // namespace sitepose::daemon::testing
