// The views through the built `sitepose` binary on one short simulated run
// (issue 23): `run --debug-out` feeds `view` (the video decodes back to the
// expected frame count and size), `report` (one self-contained page that
// headless chromium renders non-blank with every section and no console
// message) and `top --once` (the values a test publisher sent).

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "sitepose/health_t.hpp"
#include "sitepose/pose_t.hpp"
#include "sitepose/sim/sequence_writer.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/simulated.hpp"
#include "sitepose/views/report_html.hpp"

namespace sitepose {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 480;
constexpr int kHeight = 270;
constexpr int kFrames = 16;

struct Result {
  int status = -1;
  std::string out;
  std::string err;
};

Result shell(const std::string& command, const fs::path& dir) {
  const std::string out = (dir / "stdout.txt").string();
  const std::string err = (dir / "stderr.txt").string();
  const int raw = std::system((command + " > " + out + " 2> " + err).c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : 128, testing::read_text(out), testing::read_text(err)};
}

Result sitepose_cli(const std::string& args, const fs::path& dir) {
  return shell(std::string(SITEPOSE_SITEPOSE_EXE) + " " + args, dir);
}

// One simulated sequence and one tracked run with its debug record, shared
// by the tests (the slow part).
class ViewsCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<testing::TempDir>("views-cli");
    auto simulator = testing::small_simulator("parallel", kWidth, kHeight, kFrames,
                                              std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios");
    ASSERT_TRUE(simulator) << simulator.error().message;
    auto written = sim::write_sequence(*simulator, seq());
    ASSERT_TRUE(written) << written.error().message;
    const Result run = sitepose_cli("run --quiet --sequence " + seq() + " --mode full --out " +
                                        (*dir_ / "traj.txt") + " --debug-out " + run_dir(),
                                    dir_->path());
    ASSERT_EQ(run.status, 0) << run.err;
    ASSERT_NE(run.out.find("debug record in"), std::string::npos) << run.out;
  }
  static void TearDownTestSuite() { dir_.reset(); }

  static std::string seq() { return *dir_ / "seq"; }
  static std::string run_dir() { return *dir_ / "run"; }

  static std::unique_ptr<testing::TempDir> dir_;
};

std::unique_ptr<testing::TempDir> ViewsCli::dir_;

TEST_F(ViewsCli, VideoDecodesBackToTheFramesAsked) {
  const std::string video = *dir_ / "view.avi";
  const Result r = sitepose_cli(
      "view --quiet --sequence " + seq() + " --run " + run_dir() + " --out " + video + " --frames 3:13",
      dir_->path());
  ASSERT_EQ(r.status, 0) << r.err;
  cv::VideoCapture capture(video);
  ASSERT_TRUE(capture.isOpened());
  int frames = 0;
  cv::Mat image;
  while (capture.read(image)) {
    EXPECT_EQ(image.cols, kWidth + kHeight);
    EXPECT_EQ(image.rows, kHeight);
    ++frames;
  }
  EXPECT_EQ(frames, 10);
  // PNG frames, named by sequence frame.
  const Result png = sitepose_cli("view --quiet --sequence " + seq() + " --run " + run_dir() + " --out " +
                                      (*dir_ / "png") + " --frames 14:",
                                  dir_->path());
  ASSERT_EQ(png.status, 0) << png.err;
  const cv::Mat last = cv::imread(*dir_ / "png/000015.png");
  ASSERT_FALSE(last.empty());
  EXPECT_EQ(last.size(), cv::Size(kWidth + kHeight, kHeight));
  EXPECT_TRUE(fs::exists(*dir_ / "png/000014.png"));
  EXPECT_FALSE(fs::exists(*dir_ / "png/000013.png"));
}

TEST_F(ViewsCli, ViewOfAnotherSequenceIsRefused) {
  const Result r = sitepose_cli("view --quiet --sequence " + seq() + " --run " + run_dir() + " --out " +
                                    (*dir_ / "x.avi") + " --frames 20:30",
                                dir_->path());
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("nothing in the range"), std::string::npos) << r.err;
}

std::string find_chromium() {
  for (const char* name : {"chromium", "chromium-browser"}) {
    const std::string which = std::string("command -v ") + name + " > /dev/null 2>&1";
    if (std::system(which.c_str()) == 0) return name;
  }
  return "";
}

TEST_F(ViewsCli, ReportRendersInHeadlessChromium) {
  const Result r = sitepose_cli(
      "report --run " + run_dir() + " --gt " + seq() + " --out " + (*dir_ / "report"), dir_->path());
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string page = *dir_ / "report/report.html";
  const std::string html = testing::read_text(page);
  EXPECT_NE(html.find("ATE (m)"), std::string::npos);
  EXPECT_EQ(html.find("http"), std::string::npos) << "the page must fetch nothing";
  const std::string chromium = find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "chromium is not installed (tools/install-deps.sh installs it)";
  const std::string shot = *dir_ / "report.png";
  const std::string sandbox = ::geteuid() == 0 ? " --no-sandbox" : "";
  const Result c =
      shell("timeout 60 " + chromium + " --headless" + sandbox +
                " --disable-gpu --hide-scrollbars --enable-logging=stderr --v=0 --window-size=900,2400"
                " --screenshot=" +
                shot + " --dump-dom file://" + page,
            dir_->path());
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_EQ(c.err.find("CONSOLE"), std::string::npos) << c.err;
  for (const auto& id : views::report_sections()) {
    EXPECT_NE(c.out.find("<section id=\"" + id + "\">"), std::string::npos) << id;
  }
  const cv::Mat image = cv::imread(shot);
  ASSERT_FALSE(image.empty());
  cv::Scalar mean;
  cv::Scalar stddev;
  cv::meanStdDev(image, mean, stddev);
  EXPECT_GT(stddev[0] + stddev[1] + stddev[2], 30.0) << "blank screenshot";
}

TEST_F(ViewsCli, TopShowsWhatAPublisherSent) {
  // A test publisher writes one health_t and one pose_t into an LCM log; top
  // reads it as it would read the bus (file:// provider).
  const std::string log = *dir_ / "bus.lcmlog";
  {
    lcm::LCM writer("file://" + log + "?mode=w");
    ASSERT_TRUE(writer.good());
    sitepose::health_t health{};
    health.fps = 9.5F;
    health.latency_p50_ms = 41.0F;
    health.latency_p99_ms = 87.5F;
    health.state = sitepose::pose_t::STATE_RECOVERING;
    health.state_reason = "few inliers";
    health.frames_captured = 1234;
    health.frames_tracked = 1200;
    health.num_stages = 2;
    health.stage_names = {"capture", "track"};
    health.drops = {0, 17};
    health.queue_depths = {0, 2};
    health.p50_ms = {1.0F, 40.0F};
    health.p99_ms = {2.0F, 80.0F};
    health.num_outputs = 1;
    health.output_names = {"can"};
    health.output_errors = {3};
    health.output_failed = {1};
    ASSERT_EQ(writer.publish("SITEPOSE_HEALTH", &health), 0);
    sitepose::pose_t pose{};
    pose.seq = 4321;
    pose.frame = sitepose::pose_t::FRAME_SITE;
    pose.position[0] = 12.5;
    pose.position[1] = -3.25;
    pose.position[2] = 0.75;
    pose.state = sitepose::pose_t::STATE_OK;
    pose.features_used = 321;
    pose.static_objects_unmasked = 2;
    pose.masked_area_ratio = 0.4F;
    pose.latitude_deg = 48.1;
    pose.longitude_deg = 11.5;
    ASSERT_EQ(writer.publish("SITEPOSE_POSE", &pose), 0);
  }
  const Result r = sitepose_cli("top --once --no-colour --timeout-s 5 --lcm-url 'file://" + log + "?speed=0'",
                                dir_->path());
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  for (const char* expected :
       {"rate 9.5 frames/s", "p50 41.0 ms", "p99 87.5 ms", "RECOVERING", "(few inliers)", "track", "17",
        "output can", "errors 3", "failed 1", "pose seq 4321", "12.500 -3.250 0.750",
        "static objects unmasked 2", "masked area 0.40", "last error: health: few inliers"}) {
    EXPECT_NE(r.out.find(expected), std::string::npos) << expected << "\n" << r.out;
  }
}

TEST_F(ViewsCli, TopWithNothingOnTheBusExitsOne) {
  // Traffic on another channel only (LCM cannot open an empty log).
  const std::string log = *dir_ / "other.lcmlog";
  {
    lcm::LCM writer("file://" + log + "?mode=w");
    ASSERT_EQ(writer.publish("SOMETHING_ELSE", "x", 1), 0);
  }
  const Result r =
      sitepose_cli("top --once --timeout-s 1 --lcm-url 'file://" + log + "?speed=0'", dir_->path());
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("nothing received"), std::string::npos) << r.err;
}

// The demo ends with the report and an annotated clip and says where they are.
TEST(DemoCli, WritesTheReportAndAnAnnotatedClip) {
  testing::TempDir dir;
  const Result r = sitepose_cli("demo --frames 6 --clip-frames 3 --out-dir " + (dir / "demo"), dir.path());
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("report: " + (dir / "demo/report.html")), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("annotated clip: " + (dir / "demo/clip.avi") + " (3 frames"), std::string::npos)
      << r.out;
  cv::VideoCapture clip(dir / "demo/clip.avi");
  ASSERT_TRUE(clip.isOpened());
  EXPECT_EQ(static_cast<int>(clip.get(cv::CAP_PROP_FRAME_COUNT)), 3);
  EXPECT_NE(testing::read_text(dir / "demo/report.html").find("ATE (m)"), std::string::npos);
}

}  // namespace
}  // namespace sitepose
