// `sitepose calibrate` through the built binary on rendered chessboard views
// of a known rig (tests/support checkerboard.hpp): the file it writes reads
// back with the intrinsics and baseline recovered, a view without the board
// is named and skipped, and bad input exits 2 saying why.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "sitepose/calib/calibration_file.hpp"
#include "sitepose/testing/charuco_target.hpp"
#include "sitepose/testing/checkerboard.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose {
namespace {

struct CliResult {
  int exit_status = -1;
  std::string out;
  std::string err;
};

CliResult run_sitepose(const testing::TempDir& dir, const std::string& args) {
  const std::string cmd = std::string(SITEPOSE_SITEPOSE_EXE) + " " + args + " > " + (dir / "stdout.txt") +
                          " 2> " + (dir / "stderr.txt");
  const int raw = std::system(cmd.c_str());
  CliResult r;
  r.exit_status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  r.out = testing::read_text(dir / "stdout.txt");
  r.err = testing::read_text(dir / "stderr.txt");
  return r;
}

// The rendered set as DIR/left/NNNNNN.png, DIR/right/NNNNNN.png, plus one
// view where the board is out of sight.
void write_views(const testing::TempDir& dir, const testing::StereoRigTruth& rig, std::size_t count,
                 const testing::PlanarTarget& target = testing::checkerboard_target({})) {
  const auto views = testing::render_calibration_set(rig, target, count);
  std::filesystem::create_directories(dir.path() / "views" / "left");
  std::filesystem::create_directories(dir.path() / "views" / "right");
  char name[32];
  for (std::size_t i = 0; i <= count && i <= views.size(); ++i) {
    std::snprintf(name, sizeof(name), "%06zu.png", i);
    const bool blank = i == count || i == views.size();
    const cv::Mat empty(rig.size, CV_8UC1, cv::Scalar(110));
    ASSERT_TRUE(cv::imwrite(dir / ("views/left/" + std::string(name)), blank ? empty : views[i].first));
    ASSERT_TRUE(cv::imwrite(dir / ("views/right/" + std::string(name)), blank ? empty : views[i].second));
  }
}

TEST(CalibrateCli, RecoversTheRigAndNamesTheViewWithoutABoard) {
  testing::TempDir dir;
  const testing::StereoRigTruth rig = testing::test_stereo_rig();
  write_views(dir, rig, 10);
  const CliResult r = run_sitepose(dir, "calibrate --images " + (dir / "views") +
                                            " --board 9x6 --square-m 0.035 --out " + (dir / "stereo.yaml"));
  ASSERT_EQ(r.exit_status, 0) << r.err;
  EXPECT_NE(r.err.find("000010.png: board not found in either image, skipped"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("corners 11/11 views"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("views used    10 of 11"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("000003.png"), std::string::npos) << "per-view rms: " << r.out;
  auto c = calib::read_stereo_calibration(dir / "stereo.yaml");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_NEAR(c->K1.at<double>(0, 0), rig.K_left(0, 0), 0.005 * rig.K_left(0, 0));
  EXPECT_NEAR(c->K2.at<double>(1, 1), rig.K_right(1, 1), 0.005 * rig.K_right(1, 1));
  EXPECT_NEAR(c->K1.at<double>(0, 2), rig.K_left(0, 2), 3.0);
  EXPECT_NEAR(c->K2.at<double>(1, 2), rig.K_right(1, 2), 3.0);
  EXPECT_NEAR(cv::norm(c->T), rig.baseline_m(), 0.01 * rig.baseline_m());
  EXPECT_GT(c->rms_px, 0.0);
  EXPECT_LT(c->rms_px, 0.3);
}

TEST(CalibrateCli, TooFewViewsAndBadBoardsExitTwo) {
  testing::TempDir dir;
  write_views(dir, testing::test_stereo_rig(), 3);
  const std::string common = "calibrate --images " + (dir / "views") + " --out " + (dir / "c.yaml");
  const CliResult few = run_sitepose(dir, common + " --board 9x6 --square-m 0.035");
  EXPECT_EQ(few.exit_status, 2) << few.err;
  EXPECT_NE(few.err.find("3 of 4 views; at least 5"), std::string::npos) << few.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "c.yaml"));
  const CliResult board = run_sitepose(dir, common + " --board 9by6 --square-m 0.035");
  EXPECT_EQ(board.exit_status, 2);
  EXPECT_NE(board.err.find("COLSxROWS"), std::string::npos) << board.err;
  const CliResult no_dir =
      run_sitepose(dir, "calibrate --images " + (dir / "none") + " --board 9x6 --square-m 0.03 --out x.yaml");
  EXPECT_EQ(no_dir.exit_status, 2);
  EXPECT_NE(no_dir.err.find("none"), std::string::npos) << no_dir.err;
}

TEST(CalibrateCli, ChArUcoBoardRecoversTheRig) {
  testing::TempDir dir;
  const testing::StereoRigTruth rig = testing::test_stereo_rig();
  write_views(dir, rig, 10, testing::charuco_target(9, 6, 0.035, 0.026, cv::aruco::DICT_5X5_100));
  const CliResult r =
      run_sitepose(dir, "calibrate --images " + (dir / "views") +
                            " --board 9x6 --square-m 0.035 --board-type charuco --marker-m 0.026 "
                            "--dictionary DICT_5X5_100 --out " +
                            (dir / "stereo.yaml"));
  ASSERT_EQ(r.exit_status, 0) << r.err;
  EXPECT_NE(r.err.find("charuco 9x6 inner corners, 0.035 m squares, 0.026 m markers of DICT_5X5_100"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.out.find("views used    10 of 11"), std::string::npos) << r.out;
  auto c = calib::read_stereo_calibration(dir / "stereo.yaml");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_NEAR(c->K1.at<double>(0, 0), rig.K_left(0, 0), 0.005 * rig.K_left(0, 0));
  EXPECT_NEAR(c->K2.at<double>(0, 2), rig.K_right(0, 2), 3.0);
  EXPECT_NEAR(cv::norm(c->T), rig.baseline_m(), 0.01 * rig.baseline_m());

  // Marker options without --board-type charuco, and a marker as big as a square.
  const std::string common =
      "calibrate --images " + (dir / "views") + " --board 9x6 --square-m 0.035 --out " + (dir / "c.yaml");
  const CliResult stray = run_sitepose(dir, common + " --marker-m 0.026");
  EXPECT_EQ(stray.exit_status, 2);
  EXPECT_NE(stray.err.find("add --board-type charuco"), std::string::npos) << stray.err;
  const CliResult big = run_sitepose(dir, common + " --board-type charuco --marker-m 0.035");
  EXPECT_EQ(big.exit_status, 2);
  EXPECT_NE(big.err.find("smaller than the square"), std::string::npos) << big.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "c.yaml"));
}

}  // namespace
}  // namespace sitepose
