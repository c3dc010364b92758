#include "sitepose/calib/rectifier.hpp"

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "sitepose/testing/files.hpp"

namespace sitepose::calib {
namespace {

using testing::TempDir;

// An ideal pair: same K, no distortion, no rotation, right camera at +b.
StereoCalibration ideal(int w, int h, double f, double b) {
  StereoCalibration c;
  c.image_size = {w, h};
  c.K1 = (cv::Mat_<double>(3, 3) << f, 0, w / 2.0, 0, f, h / 2.0, 0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -b, 0, 0);  // x_right = R x_left + T
  return c;
}

cv::Mat noise(int w, int h) {
  cv::Mat m(h, w, CV_8UC1);
  cv::randu(m, 0, 256);
  return m;
}

TEST(StereoRectifier, IdealPairGivesItsOwnCameraAndIdentityMaps) {
  TempDir dir;
  const std::string path = dir / "stereo.yaml";
  ASSERT_TRUE(write_stereo_calibration(path, ideal(320, 240, 300.0, 0.4)));
  const auto r = load_stereo_rectifier(path, {320, 240});
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(r->remaps());
  EXPECT_NEAR(r->camera().fx, 300.0, 1e-3);
  EXPECT_NEAR(r->camera().cx, 160.0, 1e-3);
  EXPECT_NEAR(r->camera().baseline_m, 0.4, 1e-9);
  const cv::Mat left = noise(320, 240), right = noise(320, 240);
  cv::Mat left_out, right_out;
  ASSERT_TRUE(r->rectify(left, right, left_out, right_out));
  // Exactly the input: the camera sources' fake-camera tests compare images.
  EXPECT_EQ(cv::norm(left_out, left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(right_out, right, cv::NORM_INF), 0.0);
}

TEST(StereoRectifier, RotatedPairIsStraightened) {
  StereoCalibration c = ideal(320, 240, 300.0, 0.4);
  cv::Rodrigues(cv::Vec3d(0.0, 0.02, 0.01), c.R);  // right camera yawed and rolled
  const auto r = StereoRectifier::create(c);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_NEAR(r->camera().baseline_m, 0.4, 1e-3);  // |T| is the baseline
  const cv::Mat img = noise(320, 240);
  cv::Mat left_out, right_out;
  ASSERT_TRUE(r->rectify(img, img, left_out, right_out));
  EXPECT_GT(cv::norm(right_out, img, cv::NORM_L1), 0.0);  // the right image was resampled
}

TEST(StereoRectifier, ErrorsNameTheFileAndTheSize) {
  TempDir dir;
  const std::string path = dir / "stereo.yaml";
  ASSERT_TRUE(write_stereo_calibration(path, ideal(320, 240, 300.0, 0.4)));
  const auto wrong_size = load_stereo_rectifier(path, {640, 480});
  ASSERT_FALSE(wrong_size);
  EXPECT_NE(wrong_size.error().message.find(path + " is for 320x240 images, the cameras deliver 640x480"),
            std::string::npos)
      << wrong_size.error().message;

  StereoCalibration swapped = ideal(320, 240, 300.0, 0.4);
  swapped.T.at<double>(0) = 0.4;  // right camera left of the left one
  EXPECT_FALSE(StereoRectifier::create(swapped));

  const auto absent = load_stereo_rectifier(dir / "nothing.yaml", {320, 240});
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().code, ErrorCode::kNotFound);

  const auto bad_kitti = load_stereo_rectifier(dir.write("bad.txt", "P0: 1 2 3\n"), {320, 240});
  ASSERT_FALSE(bad_kitti);
  EXPECT_NE(bad_kitti.error().message.find("bad.txt"), std::string::npos) << bad_kitti.error().message;
}

TEST(StereoRectifier, KittiCalibMeansAlreadyRectified) {
  TempDir dir;
  const std::string path = dir.write("calib.txt",
                                     "P0: 700 0 480 0 0 700 270 0 0 0 1 0\n"
                                     "P1: 700 0 480 -700 0 700 270 0 0 0 1 0\n");
  const auto r = load_stereo_rectifier(path, {960, 540});
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_FALSE(r->remaps());
  EXPECT_EQ(r->camera().width, 960);
  EXPECT_NEAR(r->camera().baseline_m, 1.0, 1e-12);
  const cv::Mat img(540, 960, CV_8UC1, cv::Scalar(7));
  cv::Mat left_out, right_out;
  ASSERT_TRUE(r->rectify(img, img, left_out, right_out));
  EXPECT_EQ(left_out.data, img.data);  // passed through, not copied
  EXPECT_FALSE(r->rectify(img, cv::Mat(10, 10, CV_8UC1), left_out, right_out));
}

}  // namespace
}  // namespace sitepose::calib
