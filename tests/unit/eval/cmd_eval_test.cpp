// Runs the built `sitepose eval` binary on files written here and checks
// its JSON figures, its PNG and its exit codes.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "sitepose/testing/files.hpp"
#include "test_trajectories.hpp"

namespace sitepose::eval {
namespace {

namespace fs = std::filesystem;
using testing::curvy_trajectory;
using testing::some_rigid_transform;
using testing::transformed;

struct RunResult {
  int exit_status = -1;
  std::string out;
  std::string err;
};

class CmdEval : public ::testing::Test {
 protected:
  RunResult run(const std::string& args) const {
    const fs::path out = dir_ / "stdout.txt";
    const fs::path err = dir_ / "stderr.txt";
    const std::string cmd = std::string(SITEPOSE_SITEPOSE_EXE) + " eval " + args + " > " +
                            out.string() + " 2> " + err.string();
    const int raw = std::system(cmd.c_str());
    RunResult r;
    r.exit_status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    r.out = sitepose::testing::read_text(out.string());
    r.err = sitepose::testing::read_text(err.string());
    return r;
  }

  void write_gt(const io::Trajectory& gt) const {
    std::ofstream poses(dir_ / "poses.txt");
    std::ofstream times(dir_ / "times.txt");
    char line[512];
    for (const auto& p : gt) {
      const Eigen::Matrix<double, 3, 4> m = p.T_world_cam.matrix3x4();
      std::snprintf(line, sizeof line,
                    "%.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e %.12e\n",
                    m(0, 0), m(0, 1), m(0, 2), m(0, 3), m(1, 0), m(1, 1), m(1, 2), m(1, 3),
                    m(2, 0), m(2, 1), m(2, 2), m(2, 3));
      poses << line;
      std::snprintf(line, sizeof line, "%.6f\n", p.t_s);
      times << line;
    }
  }

  void write_tum(const io::Trajectory& est) const {
    std::ofstream out(dir_ / "est.txt");
    out << "# t x y z qx qy qz qw\n";
    char line[512];
    for (const auto& p : est) {
      const Eigen::Vector3d& t = p.T_world_cam.translation();
      const Eigen::Quaterniond& q = p.T_world_cam.rotation();
      std::snprintf(line, sizeof line, "%.6f %.9f %.9f %.9f %.12f %.12f %.12f %.12f\n", p.t_s,
                    t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
      out << line;
    }
  }

  std::string file_args() const {
    return "--gt " + (dir_ / "poses.txt").string() + " --times " + (dir_ / "times.txt").string() +
           " --est " + (dir_ / "est.txt").string();
  }

  sitepose::testing::TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

// Value of a numeric JSON field at `path` like "ate_m.rmse" (one level of
// nesting is enough for the figures checked here).
double json_value(const std::string& json, const std::string& object, const std::string& key) {
  std::string scope = json;
  if (!object.empty()) {
    const auto at = json.find("\"" + object + "\": {");
    if (at == std::string::npos) return std::nan("");
    scope = json.substr(at, json.find('}', at) - at);
  }
  const std::regex re("\"" + key + "\": (-?[0-9.eE+-]+)");
  std::smatch m;
  if (!std::regex_search(scope, m, re)) return std::nan("");
  return std::stod(m[1].str());
}

// Ground truth of 300 poses at 10 Hz; the estimate lacks every other pose in
// the first 100 frames (coverage 250 / 300), lives in another world frame,
// runs on a clock 0.3 s behind, and has 3 cm per-axis Gaussian noise.
io::Trajectory make_estimate(const io::Trajectory& gt, double clock_behind_s) {
  io::Trajectory est;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.03);
  for (std::size_t i = 0; i < gt.size(); ++i) {
    if (i < 100 && i % 2 == 1) continue;
    io::StampedPose p = gt[i];
    p.t_s -= clock_behind_s;
    const Eigen::Vector3d n(noise(rng), noise(rng), noise(rng));
    p.T_world_cam = SE3(p.T_world_cam.rotation(), p.T_world_cam.translation() + n);
    est.push_back(p);
  }
  return transformed(est, some_rigid_transform());
}

TEST_F(CmdEval, JsonFiguresAndPlot) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  write_gt(gt);
  write_tum(make_estimate(gt, 0.0));
  const fs::path png = dir_ / "eval.png";
  const RunResult r = run(file_args() + " --json --plot " + png.string());
  ASSERT_EQ(r.exit_status, 0) << r.err;
  EXPECT_EQ(json_value(r.out, "", "gt_frames"), 300.0) << r.out;
  EXPECT_EQ(json_value(r.out, "", "est_poses"), 250.0);
  EXPECT_EQ(json_value(r.out, "", "associated"), 250.0);
  EXPECT_NEAR(json_value(r.out, "", "coverage"), 250.0 / 300.0, 1e-6);
  const double ate = json_value(r.out, "ate_m", "rmse");
  EXPECT_NEAR(ate, 0.03 * std::sqrt(3.0), 0.15 * 0.03 * std::sqrt(3.0)) << r.out;
  EXPECT_GT(json_value(r.out, "ate_m", "max"), ate);
  EXPECT_GT(json_value(r.out, "rpe_time", "pairs"), 200.0);
  EXPECT_GT(json_value(r.out, "rpe_frames", "pairs"), 200.0);

  ASSERT_TRUE(fs::exists(png));
  EXPECT_GT(fs::file_size(png), 20000u);
  const cv::Mat img = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1600);
  EXPECT_EQ(img.rows, 800);
  int coloured = 0;  // pixels that are neither white nor gray: the error colours
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b c = img.at<cv::Vec3b>(y, x);
      if (std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]}) > 60) ++coloured;
    }
  }
  EXPECT_GT(coloured, 5000);
}

TEST_F(CmdEval, TimeOffsetSearchAndTextSummary) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  write_gt(gt);
  write_tum(make_estimate(gt, 0.3));
  // Without the search each estimate pairs with the frame 0.3 s (3 frames)
  // away, and 0.3 s of motion dominates the ATE.
  const RunResult plain = run(file_args() + " --json");
  ASSERT_EQ(plain.exit_status, 0) << plain.err;
  EXPECT_GT(json_value(plain.out, "ate_m", "rmse"), 0.2) << plain.out;
  EXPECT_EQ(json_value(plain.out, "", "time_offset_s"), 0.0);

  const RunResult searched = run(file_args() + " --json --time-offset-search 1.0");
  ASSERT_EQ(searched.exit_status, 0) << searched.err;
  EXPECT_NEAR(json_value(searched.out, "", "time_offset_s"), 0.3, 0.02) << searched.out;
  EXPECT_EQ(json_value(searched.out, "", "associated"), 250.0);

  const RunResult text = run(file_args() + " --time-offset-search 1.0 --max-dt 0.01");
  ASSERT_EQ(text.exit_status, 0) << text.err;
  EXPECT_NE(text.out.find("ATE [m]"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("coverage      83.3 %"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("max |dt| 0.01 s"), std::string::npos) << text.out;
}

// issue 21: eval took only KITTI ground truth and TUM estimates. The same
// trajectories in each format score the same.
TEST_F(CmdEval, TumKittiAndEurocFilesScoreTheSame) {
  const io::Trajectory gt = curvy_trajectory(300, 10.0);
  write_gt(gt);
  const io::Trajectory est = make_estimate(gt, 0.0);
  write_tum(est);
  const RunResult reference = run(file_args() + " --json");
  ASSERT_EQ(reference.exit_status, 0) << reference.err;
  const double ate = json_value(reference.out, "ate_m", "rmse");

  ASSERT_TRUE(io::write_tum_trajectory((dir_ / "gt.tum").string(), gt));
  const std::string est_path = (dir_ / "est.txt").string();
  const RunResult tum_gt = run("--gt " + (dir_ / "gt.tum").string() + " --est " + est_path + " --json");
  ASSERT_EQ(tum_gt.exit_status, 0) << tum_gt.err;
  EXPECT_NEAR(json_value(tum_gt.out, "ate_m", "rmse"), ate, 1e-6);

  for (io::TrajectoryFormat format : {io::TrajectoryFormat::kKitti, io::TrajectoryFormat::kEuroc}) {
    const std::string path = (dir_ / (std::string("est.") + io::to_string(format))).string();
    ASSERT_TRUE(io::write_trajectory(path, est, format));
    const RunResult r = run("--gt " + (dir_ / "gt.tum").string() + " --est " + path + " --json");
    ASSERT_EQ(r.exit_status, 0) << io::to_string(format) << ": " << r.err;
    EXPECT_NEAR(json_value(r.out, "ate_m", "rmse"), ate, 1e-6) << io::to_string(format);
    EXPECT_EQ(json_value(r.out, "", "associated"), 250.0) << io::to_string(format);
  }
  // KITTI ground truth without its times is bad usage.
  const RunResult no_times = run("--gt " + (dir_ / "poses.txt").string() + " --est " + est_path);
  EXPECT_EQ(no_times.exit_status, 2);
  EXPECT_NE(no_times.err.find("--times is required"), std::string::npos) << no_times.err;
}

TEST_F(CmdEval, BadInputExitsTwo) {
  const io::Trajectory gt = curvy_trajectory(50, 10.0);
  write_gt(gt);
  write_tum(gt);
  const std::string missing = (dir_ / "missing.txt").string();
  const RunResult no_est = run("--gt " + (dir_ / "poses.txt").string() + " --times " +
                               (dir_ / "times.txt").string() + " --est " + missing);
  EXPECT_EQ(no_est.exit_status, 2);
  EXPECT_NE(no_est.err.find(missing), std::string::npos) << no_est.err;

  const RunResult no_gt = run("--gt " + missing + " --times " + (dir_ / "times.txt").string() +
                              " --est " + (dir_ / "est.txt").string());
  EXPECT_EQ(no_gt.exit_status, 2);
  EXPECT_NE(no_gt.err.find(missing), std::string::npos) << no_gt.err;

  { std::ofstream empty(dir_ / "est.txt"); }
  const RunResult empty = run(file_args());
  EXPECT_EQ(empty.exit_status, 2);
  EXPECT_FALSE(empty.err.empty());

  io::Trajectory later = gt;  // no timestamp within reach of the ground truth
  for (auto& p : later) p.t_s += 1000.0;
  write_tum(later);
  const RunResult none = run(file_args());
  EXPECT_EQ(none.exit_status, 2);
  EXPECT_NE(none.err.find("only 0 estimated poses associate"), std::string::npos) << none.err;

  write_tum(gt);
  EXPECT_EQ(run(file_args() + " --max-dt -1").exit_status, 2);
  EXPECT_EQ(run(file_args() + " --plot " + (dir_ / "plot.jpg").string()).exit_status, 2);
  EXPECT_EQ(run("--gt " + (dir_ / "poses.txt").string()).exit_status, 2);  // missing options
  EXPECT_EQ(run(file_args()).exit_status, 0);
}

// issue 20: the figures went to a full stdout and eval still exited 0.
TEST_F(CmdEval, FullStdoutIsAFailure) {
  const io::Trajectory gt = curvy_trajectory(50, 10.0);
  write_gt(gt);
  write_tum(gt);
  const fs::path err = dir_ / "stderr.txt";
  for (const char* format : {"", " --json"}) {
    const std::string cmd = std::string(SITEPOSE_SITEPOSE_EXE) + " eval " + file_args() + format +
                            " > /dev/full 2> " + err.string();
    const int raw = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(raw));
    EXPECT_EQ(WEXITSTATUS(raw), 1) << format;
    EXPECT_NE(sitepose::testing::read_text(err.string()).find("sitepose eval: cannot write to stdout: No space left on device"), std::string::npos)
        << sitepose::testing::read_text(err.string());
  }
}

}  // namespace
}  // namespace sitepose::eval
