#include "sitepose/drivers/aravis/rectifier.hpp"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "sitepose/testing/files.hpp"

namespace sitepose::drivers::aravis {
namespace {

using testing::TempDir;

// An ideal pair: same K, no distortion, no rotation, right camera at +b.
StereoCalibration ideal(int w, int h, double f, double b) {
  StereoCalibration c;
  c.K1 = (cv::Mat_<double>(3, 3) << f, 0, w / 2.0, 0, f, h / 2.0, 0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -b, 0, 0);  // p_right = R p_left + T
  c.width = w;
  c.height = h;
  return c;
}

std::string write_calibration(const TempDir& dir, const StereoCalibration& c, bool with_size = true) {
  const std::string path = dir / "stereo.yaml";
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  fs << "K1" << c.K1 << "D1" << c.D1 << "K2" << c.K2 << "D2" << c.D2 << "R" << c.R << "T" << c.T;
  if (with_size) fs << "image_width" << c.width << "image_height" << c.height;
  fs << "rms" << 0.2;
  return path;
}

TEST(Rectifier, IdealPairGivesItsOwnCameraAndNearIdentityMaps) {
  TempDir dir;
  const std::string path = write_calibration(dir, ideal(320, 240, 300.0, 0.4));
  const auto r = Rectifier::load(path, 320, 240);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(r->remaps());
  EXPECT_NEAR(r->camera().fx, 300.0, 1e-3);
  EXPECT_NEAR(r->camera().cx, 160.0, 1e-3);
  EXPECT_NEAR(r->camera().baseline_m, 0.4, 1e-9);
  cv::Mat left(240, 320, CV_8UC1), right(240, 320, CV_8UC1);
  cv::randu(left, 0, 256);
  cv::randu(right, 0, 256);
  const auto out = r->rectify(left, right);
  ASSERT_TRUE(out) << out.error().message;
  EXPECT_EQ(cv::norm(out->first, left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(out->second, right, cv::NORM_INF), 0.0);
}

TEST(Rectifier, RotatedPairIsStraightened) {
  StereoCalibration c = ideal(320, 240, 300.0, 0.4);
  cv::Rodrigues(cv::Vec3d(0.0, 0.02, 0.01), c.R);  // right camera yawed and rolled
  const auto r = Rectifier::from_calibration(c);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_NEAR(r->camera().baseline_m, 0.4, 1e-3);  // |T| is the baseline
  cv::Mat img(240, 320, CV_8UC1);
  cv::randu(img, 0, 256);
  const auto out = r->rectify(img, img);
  ASSERT_TRUE(out);
  EXPECT_GT(cv::norm(out->second, img, cv::NORM_L1), 0.0);  // the right image was resampled
}

TEST(Rectifier, ErrorsNameTheFileAndTheEntry) {
  TempDir dir;
  const std::string path = write_calibration(dir, ideal(320, 240, 300.0, 0.4), false);
  const auto missing = Rectifier::load(path, 320, 240);
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find(path + ": image_width"), std::string::npos)
      << missing.error().message;

  const std::string sized = write_calibration(dir, ideal(320, 240, 300.0, 0.4));
  const auto wrong_size = Rectifier::load(sized, 640, 480);
  ASSERT_FALSE(wrong_size);
  EXPECT_NE(wrong_size.error().message.find("calibrated for 320x240 images, the cameras deliver 640x480"),
            std::string::npos)
      << wrong_size.error().message;

  StereoCalibration swapped = ideal(320, 240, 300.0, 0.4);
  swapped.T.at<double>(0) = 0.4;
  EXPECT_FALSE(Rectifier::from_calibration(swapped));

  const auto absent = Rectifier::load(dir / "nothing.yaml", 320, 240);
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);
}

TEST(Rectifier, KittiCalibMeansAlreadyRectified) {
  TempDir dir;
  const std::string path = dir.write("calib.txt",
                                     "P0: 700 0 480 0 0 700 270 0 0 0 1 0\n"
                                     "P1: 700 0 480 -700 0 700 270 0 0 0 1 0\n");
  const auto r = Rectifier::load(path, 960, 540);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_FALSE(r->remaps());
  EXPECT_EQ(r->camera().width, 960);
  EXPECT_NEAR(r->camera().baseline_m, 1.0, 1e-12);
  cv::Mat img(540, 960, CV_8UC1, cv::Scalar(7));
  EXPECT_FALSE(r->rectify(img, cv::Mat(10, 10, CV_8UC1)));
}

}  // namespace
}  // namespace sitepose::drivers::aravis
