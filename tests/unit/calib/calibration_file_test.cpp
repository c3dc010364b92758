#include "sitepose/calib/calibration_file.hpp"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "sitepose/calib/stereo_calibrate.hpp"
#include "sitepose/testing/files.hpp"

namespace sitepose::calib {
namespace {

StereoCalibration example_calibration() {
  StereoCalibration c;
  c.image_size = {640, 480};
  c.K1 = (cv::Mat_<double>(3, 3) << 520.1, 0, 322.4, 0, 518.2, 241.3, 0, 0, 1);
  c.K2 = (cv::Mat_<double>(3, 3) << 515.2, 0, 318.1, 0, 514.3, 236.4, 0, 0, 1);
  c.D1 = (cv::Mat_<double>(1, 5) << -0.12, 0.03, 0.001, -0.0005, 0.0);
  c.D2 = (cv::Mat_<double>(1, 5) << -0.11, 0.02, -0.001, 0.0004, 0.0);
  cv::Rodrigues(cv::Vec3d(0.003, -0.008, 0.002), c.R);
  c.T = (cv::Mat_<double>(3, 1) << -0.1201, 0.0004, -0.0011);
  c.rms_px = 0.21;
  return c;
}

double max_abs_diff(const cv::Mat& a, const cv::Mat& b) { return cv::norm(a, b, cv::NORM_INF); }

TEST(CalibrationFile, RoundTripsEveryEntry) {
  testing::TempDir dir;
  StereoCalibration c = example_calibration();
  ASSERT_TRUE(compute_rectification(c));
  const std::string path = dir / "stereo.yaml";
  ASSERT_TRUE(write_stereo_calibration(path, c));
  auto back = read_stereo_calibration(path);
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->image_size, c.image_size);
  EXPECT_DOUBLE_EQ(back->rms_px, 0.21);
  for (auto [a, b] : {std::pair{&c.K1, &back->K1}, std::pair{&c.D1, &back->D1}, std::pair{&c.K2, &back->K2},
                      std::pair{&c.D2, &back->D2}, std::pair{&c.R, &back->R}, std::pair{&c.T, &back->T},
                      std::pair{&c.R1, &back->R1}, std::pair{&c.R2, &back->R2}, std::pair{&c.P1, &back->P1},
                      std::pair{&c.P2, &back->P2}, std::pair{&c.Q, &back->Q}}) {
    ASSERT_EQ(a->size(), b->size());
    EXPECT_LT(max_abs_diff(*a, *b), 1e-12);
  }
  auto camera = rectified_camera(*back);
  ASSERT_TRUE(camera) << camera.error().message;
  EXPECT_NEAR(camera->baseline_m, cv::norm(c.T), 1e-9);
  EXPECT_EQ(camera->width, 640);
  EXPECT_EQ(camera->height, 480);
  const std::string text = testing::read_text(path);
  for (const char* key : {"image_width", "K1:", "D1:", "K2:", "D2:", "R:", "T:", "P1:", "P2:", "rms:"}) {
    EXPECT_NE(text.find(key), std::string::npos) << key;
  }
}

TEST(CalibrationFile, ComputesTheRectificationWhenTheFileHasNone) {
  testing::TempDir dir;
  const StereoCalibration c = example_calibration();
  const std::string path = dir / "no_rect.yaml";
  ASSERT_TRUE(write_stereo_calibration(path, c));
  ASSERT_EQ(testing::read_text(path).find("P1:"), std::string::npos);
  auto back = read_stereo_calibration(path);
  ASSERT_TRUE(back) << back.error().message;
  StereoCalibration expected = c;
  ASSERT_TRUE(compute_rectification(expected));
  EXPECT_LT(max_abs_diff(back->P2, expected.P2), 1e-9);
}

TEST(CalibrationFile, ErrorsNameTheFileAndTheEntry) {
  testing::TempDir dir;
  auto missing = read_stereo_calibration(dir / "absent.yaml");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);

  const StereoCalibration c = example_calibration();
  const std::string path = dir / "full.yaml";
  ASSERT_TRUE(write_stereo_calibration(path, c));
  std::string text = testing::read_text(path);
  const auto k2 = text.find("K2:");
  const auto d2 = text.find("D2:");
  ASSERT_NE(k2, std::string::npos);
  text.erase(k2, d2 - k2);  // K2 removed
  const std::string broken = dir.write("no_k2.yaml", text);
  auto no_k2 = read_stereo_calibration(broken);
  ASSERT_FALSE(no_k2);
  EXPECT_EQ(no_k2.error().exit_status(), 2);
  EXPECT_NE(no_k2.error().message.find(broken), std::string::npos) << no_k2.error().message;
  EXPECT_NE(no_k2.error().message.find("K2 must be"), std::string::npos) << no_k2.error().message;

  const std::string garbage = dir.write("garbage.yaml", "%YAML:1.0\n---\nimage_width: wide\n");
  auto bad = read_stereo_calibration(garbage);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("image_width"), std::string::npos) << bad.error().message;
}

TEST(CalibrationFile, RefusesAZeroBaseline) {
  StereoCalibration c = example_calibration();
  c.T = cv::Mat::zeros(3, 1, CV_64F);
  auto st = validate(c);
  ASSERT_FALSE(st);
  EXPECT_NE(st.error().message.find("baseline"), std::string::npos);
}

TEST(CalibrationViews, ListsTwinsAndNamesAnOrphan) {
  testing::TempDir dir;
  dir.write("left/000001.png", "x");
  dir.write("right/000001.png", "x");
  dir.write("left/000002.png", "x");
  dir.write("right/000002.png", "x");
  auto names = list_calibration_views(dir.path().string());
  ASSERT_TRUE(names) << names.error().message;
  EXPECT_EQ(*names, (std::vector<std::string>{"000001.png", "000002.png"}));
  dir.write("left/000003.png", "x");
  auto orphan = list_calibration_views(dir.path().string());
  ASSERT_FALSE(orphan);
  EXPECT_NE(orphan.error().message.find("000003.png has no twin"), std::string::npos)
      << orphan.error().message;
  auto absent = list_calibration_views(dir / "nothing");
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().exit_status(), 2);
  auto unreadable = load_calibration_view(dir.path().string(), "000001.png");
  ASSERT_FALSE(unreadable);
  EXPECT_NE(unreadable.error().message.find("cannot read"), std::string::npos);
}

}  // namespace
}  // namespace sitepose::calib
