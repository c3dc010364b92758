// The command-line interfaces of issue 21, through the built binary:
// Ctrl-C and SIGTERM in `sitepose run`, `sitepose sim` and the benches
// (exit 130, and what was done is written and readable — run: the
// trajectory of every frame tracked, stats marked partial; sim: a complete
// shorter sequence, no half folder; bench soak and nees: the CSV rows of
// what was done, the figures marked partial), global options after the
// subcommand, valid JSON files, and the trajectory formats scoring the same
// in eval.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sitepose/testing/files.hpp"
#include "sitepose/testing/simulated.hpp"
#include "sitepose/testing/wait.hpp"

namespace sitepose {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::vector<std::vector<double>> number_rows(const fs::path& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<double> row;
    for (double v = 0; fields >> v;) row.push_back(v);
    EXPECT_TRUE(fields.eof()) << path << ": '" << line << "'";
    rows.push_back(row);
  }
  return rows;
}

// True once process `pid` catches SIGINT (its handler is installed), read
// from SigCgt in /proc/<pid>/status.
bool catches_sigint(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("SigCgt:", 0) == 0) {
      const unsigned long long mask = std::stoull(line.substr(7), nullptr, 16);
      return (mask >> (SIGINT - 1)) & 1U;
    }
  }
  return false;
}

// `sitepose <args>` started without a shell, stdout and stderr to files.
pid_t start_sitepose(const std::vector<std::string>& args, const fs::path& out, const fs::path& err) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::FILE* o = std::freopen(out.c_str(), "w", stdout);
    std::FILE* e = std::freopen(err.c_str(), "w", stderr);
    if (o == nullptr || e == nullptr) ::_exit(120);
    std::vector<char*> argv{const_cast<char*>(SITEPOSE_SITEPOSE_EXE)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(SITEPOSE_SITEPOSE_EXE, argv.data());
    ::_exit(121);
  }
  return pid;
}

int exit_status(pid_t pid) {
  int raw = 0;
  ::waitpid(pid, &raw, 0);
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
}

class InterruptCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("interrupt_cli");
    auto written = testing::write_small_sequence("static", 320, 180, 30, seq().string(),
                                                 std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios");
    ASSERT_TRUE(written) << written.error().message;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path seq() { return dir_->path() / "seq"; }
  static std::vector<std::string> run_args(const fs::path& out) {
    return {"run",          "--sequence",
            seq().string(), "--mode",
            "none",         "--quiet",
            "--out",        (out / "traj.txt").string(),
            "--stats-out",  (out / "stats.json").string()};
  }

  static testing::TempDir* dir_;
};

testing::TempDir* InterruptCli::dir_ = nullptr;

// What an interrupted (or finished) run wrote: stats with one state per
// frame tracked, a trajectory row for each frame not LOST, at the frame's
// time, in order; `partial` says whether all frames were tracked.
void expect_complete_outputs(const fs::path& out, const std::vector<std::vector<double>>& times,
                             bool partial) {
  const nlohmann::json stats = nlohmann::json::parse(testing::read_text(out / "stats.json"));
  EXPECT_EQ(stats.at("partial").get<bool>(), partial);
  const auto& states = stats.at("states");
  const std::size_t tracked = states.size();
  EXPECT_EQ(stats.at("frames").get<std::size_t>(), tracked);
  if (partial) {
    EXPECT_LT(tracked, times.size());
  } else {
    EXPECT_EQ(tracked, times.size());
  }
  std::vector<double> expected_t;
  for (std::size_t i = 0; i < tracked; ++i) {
    if (states[i].get<std::string>() != "LOST") expected_t.push_back(times[i][0]);
  }
  const auto rows = number_rows(out / "traj.txt");
  ASSERT_EQ(rows.size(), expected_t.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    ASSERT_EQ(rows[i].size(), 8u) << "row " << i;
    EXPECT_NEAR(rows[i][0], expected_t[i], 1e-6) << "row " << i;
  }
}

TEST_F(InterruptCli, SigintAtRandomFramesOfRunWritesTheFramesTracked) {
  const auto times = number_rows(seq() / "times.txt");
  ASSERT_EQ(times.size(), 30u);
  // A whole run first: how long tracking takes once the handler is in.
  const fs::path whole = dir_->path() / "whole";
  fs::create_directories(whole);
  const pid_t first = start_sitepose(run_args(whole), whole / "out.txt", whole / "err.txt");
  ASSERT_TRUE(testing::wait_for([&] { return catches_sigint(first); }, std::chrono::seconds(20)));
  const auto t0 = Clock::now();
  ASSERT_EQ(exit_status(first), 0) << testing::read_text(whole / "err.txt");
  const double run_s = std::chrono::duration<double>(Clock::now() - t0).count();
  expect_complete_outputs(whole, times, false);

  std::mt19937 rng(21);
  // Over the first 70 % of a whole run's time: the rest is closing the map
  // and writing, and a loaded machine stretches runs unevenly.
  std::uniform_real_distribution<double> at(0.0, 0.7 * run_s);
  int interrupted = 0;
  for (int attempt = 0; attempt < 20; ++attempt) {
    const fs::path out = dir_->path() / ("try" + std::to_string(attempt));
    fs::create_directories(out);
    const pid_t pid = start_sitepose(run_args(out), out / "out.txt", out / "err.txt");
    ASSERT_TRUE(testing::wait_for([&] { return catches_sigint(pid); }, std::chrono::seconds(20)));
    const int signal = attempt % 5 == 4 ? SIGTERM : SIGINT;
    const double delay_s = at(rng);
    std::this_thread::sleep_for(std::chrono::duration<double>(delay_s));
    ::kill(pid, signal);
    const int status = exit_status(pid);
    const std::string err = testing::read_text(out / "err.txt");
    SCOPED_TRACE("attempt " + std::to_string(attempt) + ", signal after " + std::to_string(delay_s) +
                 " s: " + err);
    if (status == 0) {  // finished before the signal came
      expect_complete_outputs(out, times, false);
      continue;
    }
    ASSERT_EQ(status, 130);
    ++interrupted;
    EXPECT_NE(err.find(signal == SIGTERM ? "interrupted (SIGTERM)" : "interrupted (SIGINT)"),
              std::string::npos);
    // Between "tracked all frames" and the exit a signal still reports the
    // run complete but interrupted: then the stats say partial false.
    const nlohmann::json stats = nlohmann::json::parse(testing::read_text(out / "stats.json"));
    expect_complete_outputs(out, times, stats.at("partial").get<bool>());
  }
  // The delays spread over the run: most tries stop it part-way.
  EXPECT_GE(interrupted, 10);
}

TEST_F(InterruptCli, SigintInSimLeavesACompleteShorterSequence) {
  const fs::path out = dir_->path() / "sim_out";
  const pid_t pid = start_sitepose({"sim", "--scenario", "static", "--out", out.string(), "--frames", "400",
                                    "--width", "320", "--height", "180"},
                                   dir_->path() / "sim_stdout.txt", dir_->path() / "sim_stderr.txt");
  const fs::path staging = dir_->path() / (".sim_out.partial-" + std::to_string(pid));
  ASSERT_TRUE(testing::wait_for([&] { return fs::exists(staging / "image_0" / "000002.png"); },
                                std::chrono::seconds(30)));
  EXPECT_FALSE(fs::exists(out));  // nothing under --out before the end
  ::kill(pid, SIGINT);
  ASSERT_EQ(exit_status(pid), 130) << testing::read_text(dir_->path() / "sim_stderr.txt");
  EXPECT_FALSE(fs::exists(staging));
  const nlohmann::json meta = nlohmann::json::parse(testing::read_text(out / "meta.json"));
  EXPECT_TRUE(meta.at("partial").get<bool>());
  const int frames = meta.at("frames").get<int>();
  EXPECT_GE(frames, 3);
  EXPECT_LT(frames, 400);
  EXPECT_EQ(number_rows(out / "times.txt").size(), static_cast<std::size_t>(frames));
  EXPECT_EQ(number_rows(out / "poses_tum.txt").size(), static_cast<std::size_t>(frames));
  EXPECT_TRUE(fs::exists(out / "image_1" / "000000.png"));
  EXPECT_FALSE(fs::exists(out / "image_0" / (std::to_string(frames) + ".png")));
  // The shorter sequence is one `run` accepts.
  const fs::path run_out = dir_->path() / "sim_run";
  fs::create_directories(run_out);
  const pid_t run = start_sitepose({"run", "--sequence", out.string(), "--mode", "none", "--quiet", "--out",
                                    (run_out / "traj.txt").string()},
                                   run_out / "out.txt", run_out / "err.txt");
  EXPECT_EQ(exit_status(run), 0) << testing::read_text(run_out / "err.txt");
}

// The benches stop the same way: the figures of the frames tracked, marked
// partial, exit 130 (bench track renders and tracks its scenario frame by
// frame, far longer than the 3 s it is given here).
TEST_F(InterruptCli, SigintInBenchTrackPrintsThePartialFigures) {
  const fs::path out = dir_->path() / "bench";
  fs::create_directories(out);
  const pid_t pid =
      start_sitepose({"bench", "track", "--scenario", "static"}, out / "out.txt", out / "err.txt");
  std::this_thread::sleep_for(std::chrono::seconds(3));
  ::kill(pid, SIGINT);
  EXPECT_EQ(exit_status(pid), 130) << testing::read_text(out / "err.txt");
  const std::string printed = testing::read_text(out / "out.txt");
  EXPECT_NE(printed.find("(interrupted: partial)"), std::string::npos) << printed;
  EXPECT_NE(testing::read_text(out / "err.txt").find("interrupted (SIGINT)"), std::string::npos)
      << testing::read_text(out / "err.txt");
}

// Lines of a CSV file after its header, each split at the commas.
std::vector<std::vector<std::string>> csv_rows(const fs::path& path, std::string& header) {
  std::ifstream in(path);
  std::getline(in, header);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> fields;
    std::istringstream split(line);
    for (std::string field; std::getline(split, field, ',');) fields.push_back(field);
    rows.push_back(fields);
  }
  return rows;
}

std::size_t count_fields(const std::string& header) {
  return static_cast<std::size_t>(std::count(header.begin(), header.end(), ',')) + 1;
}

// bench soak, stopped once it has written two samples: every CSV row whole,
// frames rising and short of --frames, the PNG beside the CSV, exit 130.
TEST_F(InterruptCli, SigintInBenchSoakKeepsTheRowsDoneAndWritesThePng) {
  const fs::path out = dir_->path() / "soak";
  fs::create_directories(out);
  const pid_t pid =
      start_sitepose({"bench", "soak", "--sequence", seq().string(), "--mode", "none", "--frames", "100000",
                      "--sample-every", "10", "--csv", (out / "soak.csv").string()},
                     out / "out.txt", out / "err.txt");
  std::string header;
  ASSERT_TRUE(testing::wait_for([&] { return csv_rows(out / "soak.csv", header).size() >= 2; },
                                std::chrono::seconds(60)))
      << testing::read_text(out / "err.txt");
  ::kill(pid, SIGINT);
  ASSERT_EQ(exit_status(pid), 130) << testing::read_text(out / "err.txt");
  const std::string printed = testing::read_text(out / "out.txt");
  EXPECT_NE(printed.find("(interrupted: partial)"), std::string::npos) << printed;
  EXPECT_NE(testing::read_text(out / "err.txt").find("interrupted (SIGINT)"), std::string::npos);
  const auto rows = csv_rows(out / "soak.csv", header);
  ASSERT_GE(rows.size(), 2u);
  double last_frames = 0.0;
  for (const auto& row : rows) {
    ASSERT_EQ(row.size(), count_fields(header)) << header;
    const double frames = std::stod(row[0]);
    EXPECT_GT(frames, last_frames);
    last_frames = frames;
  }
  EXPECT_LT(last_frames, 100000.0);
  const std::string png = testing::read_text(out / "soak.png");
  EXPECT_EQ(png.substr(0, 4), "\x89PNG") << "soak.png: " << png.size() << " bytes";
}

// bench nees, stopped by SIGTERM after 50 frames: the figures of the frames
// tracked marked partial, one whole CSV row per frame scored, exit 130.
TEST_F(InterruptCli, SigtermInBenchNeesWritesTheCsvOfTheFramesTracked) {
  const fs::path out = dir_->path() / "nees";
  fs::create_directories(out);
  const pid_t pid = start_sitepose({"bench", "nees", "--scenario", "static", "--frames", "1000", "--width",
                                    "320", "--height", "180", "--csv", (out / "nees.csv").string()},
                                   out / "out.txt", out / "err.txt");
  ASSERT_TRUE(testing::wait_for(
      [&] { return testing::read_text(out / "err.txt").find("bench nees: 50/") != std::string::npos; },
      std::chrono::seconds(60)))
      << testing::read_text(out / "err.txt");
  ::kill(pid, SIGTERM);
  ASSERT_EQ(exit_status(pid), 130) << testing::read_text(out / "err.txt");
  EXPECT_NE(testing::read_text(out / "err.txt").find("interrupted (SIGTERM)"), std::string::npos);
  const std::string printed = testing::read_text(out / "out.txt");
  int frames = 0;
  int scored = 0;
  const auto at = printed.find("bench nees: ");
  ASSERT_NE(at, std::string::npos) << printed;
  const std::string line = printed.substr(at, printed.find('\n', at) - at);
  EXPECT_NE(line.find("(interrupted: partial)"), std::string::npos) << line;
  ASSERT_EQ(std::sscanf(line.c_str() + line.find(", ") + 2, "%d frames", &frames), 1) << line;
  ASSERT_EQ(std::sscanf(line.c_str() + line.rfind(", ") + 2, "%d scored", &scored), 1) << line;
  EXPECT_GE(frames, 50);
  EXPECT_LT(frames, 1000);
  std::string header;
  const auto rows = csv_rows(out / "nees.csv", header);
  EXPECT_EQ(rows.size(), static_cast<std::size_t>(scored)) << line;
  for (const auto& row : rows) ASSERT_EQ(row.size(), count_fields(header));
}

TEST_F(InterruptCli, GlobalOptionsAfterTheSubcommand) {
  const fs::path out = dir_->path() / "global";
  fs::create_directories(out);
  auto args = run_args(out);
  args.insert(args.end(), {"--frames", "3", "--log-level", "warn"});
  const pid_t pid = start_sitepose(args, out / "out.txt", out / "err.txt");
  EXPECT_EQ(exit_status(pid), 0) << testing::read_text(out / "err.txt");
  args.back() = "loud";
  const pid_t bad = start_sitepose(args, out / "out.txt", out / "err.txt");
  EXPECT_EQ(exit_status(bad), 2);
  EXPECT_NE(testing::read_text(out / "err.txt").find("unknown log level 'loud'"), std::string::npos)
      << testing::read_text(out / "err.txt");
}

// Every JSON file the commands write (sim's meta.json, run's stats, eval's
// figures) parses with Python's json module.
TEST_F(InterruptCli, EveryJsonFileParsesWithPython) {
  const fs::path out = dir_->path() / "json";
  fs::create_directories(out);
  const pid_t run = start_sitepose(run_args(out), out / "out.txt", out / "err.txt");
  ASSERT_EQ(exit_status(run), 0) << testing::read_text(out / "err.txt");
  const pid_t eval =
      start_sitepose({"eval", "--gt", (seq() / "poses.txt").string(), "--times",
                      (seq() / "times.txt").string(), "--est", (out / "traj.txt").string(), "--json"},
                     out / "eval.json", out / "eval_err.txt");
  ASSERT_EQ(exit_status(eval), 0) << testing::read_text(out / "eval_err.txt");
  for (const fs::path& json : {seq() / "meta.json", out / "stats.json", out / "eval.json"}) {
    const std::string cmd = "python3 -c 'import json, sys; json.load(open(sys.argv[1]))' " + json.string();
    EXPECT_EQ(std::system(cmd.c_str()), 0) << json << ":\n" << testing::read_text(json).substr(0, 2000);
  }
}

// issue 21: `run --format kitti` and `--format tum` of one run score the
// same in eval, against KITTI and TUM ground truth; euroc too.
TEST_F(InterruptCli, RunFormatsScoreTheSameInEval) {
  const fs::path out = dir_->path() / "formats";
  fs::create_directories(out);
  std::vector<double> ates;
  for (const std::string format : {"tum", "kitti", "euroc"}) {
    const fs::path traj = out / ("traj." + format);
    const pid_t run =
        start_sitepose({"run", "--sequence", seq().string(), "--mode", "none", "--quiet", "--format", format,
                        "--out", traj.string(), "--tracking-out", (out / "tracking.csv").string()},
                       out / "out.txt", out / "err.txt");
    ASSERT_EQ(exit_status(run), 0) << format << ": " << testing::read_text(out / "err.txt");
    for (const std::vector<std::string>& gt :
         {std::vector<std::string>{"--gt", (seq() / "poses.txt").string(), "--times",
                                   (seq() / "times.txt").string()},
          std::vector<std::string>{"--gt", (seq() / "poses_tum.txt").string()}}) {
      std::vector<std::string> args{"eval", "--json", "--est", traj.string()};
      args.insert(args.end(), gt.begin(), gt.end());
      const pid_t eval = start_sitepose(args, out / "eval.json", out / "eval_err.txt");
      ASSERT_EQ(exit_status(eval), 0)
          << format << " vs " << gt[1] << ": " << testing::read_text(out / "eval_err.txt");
      const nlohmann::json figures = nlohmann::json::parse(testing::read_text(out / "eval.json"));
      EXPECT_EQ(figures.at("associated").get<int>(), figures.at("est_poses").get<int>());
      ates.push_back(figures.at("ate_m").at("rmse").get<double>());
    }
  }
  for (double ate : ates) EXPECT_NEAR(ate, ates.front(), 1e-6);
  // The tracking states sidecar: one row per frame, each a known state.
  const auto rows = testing::read_text(out / "tracking.csv");
  EXPECT_EQ(rows.rfind("frame,t_s,state\n", 0), 0u) << rows;
  EXPECT_EQ(std::count(rows.begin(), rows.end(), '\n'), 31) << rows;
}

}  // namespace
}  // namespace sitepose
