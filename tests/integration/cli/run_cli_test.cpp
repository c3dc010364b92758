// Runs the built `sitepose` binary on a small simulated sequence with bad
// input and failing outputs (issue 20): no crash, exit 2 for bad input
// before any tracking, exit 1 when an output cannot be written, and
// messages that quote at most a short piece of a bad value.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "sitepose/testing/files.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_status = -1;
  std::string err;
};

// Longest line of `text`.
std::size_t longest_line(const std::string& text) {
  std::size_t longest = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) longest = std::max(longest, line.size());
  return longest;
}

class RunCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("sitepose_run_cli_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto written = testing::write_small_sequence("crowded", 320, 180, 6, seq().string(),
                                                 std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios");
    ASSERT_TRUE(written) << written.error().message;
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  fs::path seq() const { return dir_ / "seq"; }

  // `sitepose <args>`, stdout to `out_redirect`.
  RunResult sitepose(const std::string& args, const std::string& out_redirect = "/dev/null") const {
    const fs::path err = dir_ / "stderr.txt";
    const std::string cmd =
        std::string(SITEPOSE_SITEPOSE_EXE) + " " + args + " > " + out_redirect + " 2> " + err.string();
    const int raw = std::system(cmd.c_str());
    RunResult r;
    r.exit_status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
    r.err = testing::read_text(err);
    return r;
  }

  std::string run_args(const std::string& extra) const {
    return "run --sequence " + seq().string() + " --out " + (dir_ / "traj.txt").string() + " --quiet " +
           extra;
  }

  fs::path dir_;
};

// issue 20: an uncaught filesystem_error from the image-folder check aborted.
TEST_F(RunCli, SymlinkLoopInImageFolderIsNoCrash) {
  fs::create_symlink("loop", seq() / "image_0" / "loop");
  const RunResult r = sitepose(run_args("--mode none --frames 2"));
  EXPECT_EQ(r.exit_status, 0) << r.err;
}

// issue 20: each of these ran.
TEST_F(RunCli, BadOptionValuesExitTwoAtParse) {
  const RunResult config_dir = sitepose(run_args("--config " + dir_.string()));
  EXPECT_EQ(config_dir.exit_status, 2) << config_dir.err;
  EXPECT_NE(config_dir.err.find("directory"), std::string::npos) << config_dir.err;
  for (const char* mode : {"--mode ''", "--mode fullest"}) {
    const RunResult r = sitepose(run_args(mode));
    EXPECT_EQ(r.exit_status, 2) << mode << ": " << r.err;
    EXPECT_NE(r.err.find("--mode"), std::string::npos) << r.err;
  }
  for (const char* frames : {"--frames -3", "--frames 0"}) {
    const RunResult r = sitepose(run_args(frames));
    EXPECT_EQ(r.exit_status, 2) << frames << ": " << r.err;
    EXPECT_NE(r.err.find("--frames"), std::string::npos) << r.err;
  }
}

// The benches render a scenario at another frame rate with --fps (issue 24:
// keyframes at the cameras' rate); a recorded sequence keeps its own.
TEST_F(RunCli, BenchFpsRendersTheScenarioAtThatRateButNotASequence) {
  const fs::path out = dir_ / "bench.txt";
  const RunResult rendered = sitepose("bench track --scenario static --fps 30 --frames 8", out.string());
  EXPECT_EQ(rendered.exit_status, 0) << rendered.err;
  const std::string printed = testing::read_text(out);
  EXPECT_NE(printed.find("8 frames at 30 frames/s"), std::string::npos) << printed;
  const RunResult sequence = sitepose("bench track --sequence " + seq().string() + " --fps 30 --frames 4");
  EXPECT_EQ(sequence.exit_status, 2) << sequence.err;
  EXPECT_NE(sequence.err.find("--fps"), std::string::npos) << sequence.err;
  // bench dynamic writes the scenario to disk first (the labels detector reads it there).
  const RunResult dynamic = sitepose("bench dynamic --scenario crowded --fps 30 --frames 6");
  EXPECT_EQ(dynamic.exit_status, 0) << dynamic.err;
  EXPECT_NE(dynamic.err.find("(6 frames at 30 frames/s)"), std::string::npos) << dynamic.err;
  const RunResult dynamic_sequence = sitepose("bench dynamic --sequence " + seq().string() + " --fps 30");
  EXPECT_EQ(dynamic_sequence.exit_status, 2) << dynamic_sequence.err;
  EXPECT_NE(dynamic_sequence.err.find("--fps"), std::string::npos) << dynamic_sequence.err;
}

// issue 20: an output path that cannot be written failed (exit 1) only after
// the whole run.
TEST_F(RunCli, UnwritableOutputsExitTwoBeforeTracking) {
  const std::string no_dir = (dir_ / "no" / "such" / "dir" / "x.txt").string();
  for (const std::string option : {"--out", "--states-out", "--stats-out", "--final-out"}) {
    const RunResult r = sitepose("run --sequence " + seq().string() + " --quiet --out " +
                                 (option == "--out" ? no_dir : (dir_ / "traj.txt").string()) +
                                 (option == "--out" ? "" : " " + option + " " + no_dir));
    EXPECT_EQ(r.exit_status, 2) << option << ": " << r.err;
    EXPECT_NE(r.err.find(option + ": " + no_dir + ": cannot write"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "traj.txt"));
}

// issue 20: a config camera of another size than the images, and a bad mask,
// failed mid-run with exit 1.
TEST_F(RunCli, BadCameraSizeAndMaskExitTwo) {
  std::ofstream(dir_ / "camera.yaml") << "camera:\n  stereo: {fx: 233.3, fy: 233.3, cx: 150, cy: 80, "
                                         "baseline_m: 1.0, width: 300, height: 170}\n";
  const RunResult camera = sitepose(run_args("--mode none --config " + (dir_ / "camera.yaml").string()));
  EXPECT_EQ(camera.exit_status, 2) << camera.err;
  EXPECT_NE(camera.err.find("camera.stereo is 300x170 but the images of"), std::string::npos) << camera.err;

  const fs::path mask = seq() / "labels" / "masks" / "000003.png";
  cv::imwrite(mask.string(), cv::imread((seq() / "image_0" / "000003.png").string(), cv::IMREAD_UNCHANGED));
  const RunResult r = sitepose(run_args("--mode pixel"));
  EXPECT_EQ(r.exit_status, 2) << r.err;
  EXPECT_NE(r.err.find("000003.png: expected a 16-bit single-channel PNG"), std::string::npos) << r.err;
}

// issue 21: ORB-SLAM2 settings whose image size is not the sequence's were
// found only at frame 0 (exit 1, "frame 0: frame 0 ..."), and the keys
// sitepose does not use were never printed.
TEST_F(RunCli, OrbSlam2SettingsPrintIgnoredKeysAndAWrongSizeExitsTwoBeforeTracking) {
  const std::string settings =
      std::string(SITEPOSE_SOURCE_DIR) + "/config/orbslam2/sitepose_default_stereo.yaml";
  const RunResult r = sitepose(run_args("--mode none --orbslam2-settings " + settings));
  EXPECT_EQ(r.exit_status, 2) << r.err;
  EXPECT_NE(r.err.find("keys sitepose does not use, ignored: Viewer.KeyFrameSize, Viewer.KeyFrameLineWidth"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("camera.stereo (from --orbslam2-settings " + settings +
                       ") is 960x540 but the images of " + seq().string() + " are 320x180"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(r.err.find("frame 0"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "traj.txt"));
}

// issue 20: `--states-out /dev/full` and a full stdout exited 0.
TEST_F(RunCli, FullOutputsExitOne) {
  const RunResult states = sitepose(run_args("--mode full --states-out /dev/full"));
  EXPECT_EQ(states.exit_status, 1) << states.err;
  EXPECT_NE(states.err.find("/dev/full"), std::string::npos) << states.err;
  const RunResult stats = sitepose(run_args("--mode none --stats-out /dev/full"));
  EXPECT_EQ(stats.exit_status, 1) << stats.err;
  const RunResult out = sitepose(run_args("--mode none"), "/dev/full");
  EXPECT_EQ(out.exit_status, 1) << out.err;
  EXPECT_NE(out.err.find("cannot write to stdout"), std::string::npos) << out.err;
  const RunResult ok = sitepose(run_args("--mode none"));
  EXPECT_EQ(ok.exit_status, 0) << ok.err;
}

// issue 20: a 10 MB value came back in one stderr line.
TEST_F(RunCli, ReaderMessagesQuoteAShortPieceOfABadLine) {
  std::ofstream(seq() / "times.txt") << "0.0\n" << std::string(100'000, 'x') << "\n";
  const RunResult times = sitepose(run_args("--mode none"));
  EXPECT_EQ(times.exit_status, 2);
  EXPECT_NE(times.err.find("times.txt:2: field 1 'xxxx"), std::string::npos) << times.err.substr(0, 500);
  EXPECT_LT(longest_line(times.err), 400u);
}

// issue 20: a 10 MB value came back in one stderr line; `sim --scenario
// /etc/passwd` printed the file.
TEST_F(RunCli, ConfigMessagesQuoteAShortPieceOfABadValue) {
  const std::string huge(100'000, 'x');
  std::ofstream(dir_ / "huge.yaml") << "dynamic:\n  mode: " << huge << "\n";
  const RunResult config = sitepose(run_args("--config " + (dir_ / "huge.yaml").string()));
  EXPECT_EQ(config.exit_status, 2);
  EXPECT_NE(config.err.find("dynamic.mode"), std::string::npos) << config.err.substr(0, 500);
  EXPECT_LT(longest_line(config.err), 400u) << config.err.substr(0, 500);

  const RunResult mode = sitepose(run_args("--mode " + huge));
  EXPECT_EQ(mode.exit_status, 2);
  EXPECT_LT(longest_line(mode.err), 400u) << mode.err.substr(0, 500);

  std::ofstream passwd(dir_ / "passwd");
  for (int i = 0; i < 200; ++i)
    passwd << "user" << i << ":x:" << 1000 + i << ":100::/home/user" << i << ":/bin/sh\n";
  passwd.close();
  const RunResult sim =
      sitepose("sim --scenario " + (dir_ / "passwd").string() + " --out " + (dir_ / "s").string());
  EXPECT_EQ(sim.exit_status, 2) << sim.err;
  EXPECT_EQ(sim.err.find("user199"), std::string::npos) << sim.err.substr(0, 500);
  EXPECT_LT(sim.err.size(), 1000u) << sim.err.substr(0, 500);
}

// The stats say what became of the provisional maps (issue 19). Scenario
// lostmap: the lens is covered, and the view comes back (frame 138) where
// the site map is not in sight, so a provisional map is begun 0.5 s later
// (tracking.new_map_after_lost_s). The site map is back in view only
// after frame 290, so within these 160 frames it is neither joined nor
// dropped.
TEST_F(RunCli, StatsCountTheProvisionalMaps) {
  const fs::path seq = dir_ / "lostmap";
  auto written = testing::write_small_sequence("lostmap", 320, 180, 160, seq.string(),
                                               std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios");
  ASSERT_TRUE(written) << written.error().message;
  const fs::path config = dir_ / "c.yaml";
  std::ofstream(config) << "tracking:\n  new_map_after_lost_s: 0.5\n";
  const fs::path stats = dir_ / "stats.json";
  const fs::path final_trajectory = dir_ / "final.txt";
  const RunResult r = sitepose("run --sequence " + seq.string() + " --out " + (dir_ / "t.txt").string() +
                               " --quiet --mode none --config " + config.string() + " --stats-out " +
                               stats.string() + " --final-out " + final_trajectory.string());
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(testing::read_text(stats.string()));
  ASSERT_TRUE(json.contains("provisional_maps")) << json.dump();
  const nlohmann::json& maps = json["provisional_maps"];
  const int started = maps.value("started", -1);
  const int joined = maps.value("joined", -1);
  const int dropped = maps.value("dropped", -1);
  const int unconfirmed = maps.value("joins_dropped_unconfirmed", -1);
  std::printf("provisional maps: started %d, joined %d, dropped %d, joins dropped unconfirmed %d\n", started,
              joined, dropped, unconfirmed);
  EXPECT_EQ(started, 1);
  EXPECT_EQ(joined, 0);
  EXPECT_EQ(dropped, 0);
  EXPECT_EQ(unconfirmed, 0);

  // --final-out: the frames of --out, each moved with its keyframe. The
  // provisional map was neither joined nor dropped, so every frame is placed.
  ASSERT_TRUE(json.contains("final_trajectory")) << json.dump();
  const auto times_of = [](const fs::path& path) {
    std::vector<std::string> times;
    std::istringstream lines(testing::read_text(path.string()));
    for (std::string line; std::getline(lines, line);) {
      if (!line.empty() && line[0] != '#') times.push_back(line.substr(0, line.find(' ')));
    }
    return times;
  };
  const std::vector<std::string> tracked = times_of(dir_ / "t.txt");
  EXPECT_GT(tracked.size(), 50u);  // 79: lostmap is LOST for half its frames
  EXPECT_EQ(times_of(final_trajectory), tracked);
  EXPECT_EQ(json["final_trajectory"].value("poses", -1), static_cast<int>(tracked.size()));
  EXPECT_EQ(json["final_trajectory"].value("left_out", -1), 0);

  // Matches per frame, and their sums: nothing here is 60 s old (27 s run).
  ASSERT_TRUE(json.contains("matches") && json["matches"].is_array()) << json.dump();
  EXPECT_EQ(json["matches"].size(), 160u);
  ASSERT_TRUE(json.contains("old_keyframe_matches")) << json.dump();
  long sum = 0;
  for (const auto& m : json["matches"]) sum += m.get<long>();
  EXPECT_GT(sum, 0);
  EXPECT_EQ(json["old_keyframe_matches"].value("matches", -1L), sum);
  EXPECT_EQ(json["old_keyframe_matches"].value("from_old_keyframes", -1L), 0);
}

}  // namespace
}  // namespace sitepose
