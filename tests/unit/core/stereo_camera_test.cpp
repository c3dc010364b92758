#include "sitepose/core/stereo_camera.hpp"

#include <gtest/gtest.h>

#include <limits>

#include "sitepose/testing/cameras.hpp"

namespace sitepose {
namespace {

using testing::test_camera;

TEST(StereoCamera, ProjectUnprojectRoundTrip) {
  const StereoCamera cam = test_camera();
  for (double u = 0.5; u < 960; u += 97.3) {
    for (double v = 0.5; v < 540; v += 61.7) {
      for (double depth : {0.5, 3.0, 40.0}) {
        const Eigen::Vector3d p = cam.unproject({u, v}, depth);
        EXPECT_DOUBLE_EQ(p.z(), depth);
        const Eigen::Vector2d uv = cam.project(p);
        EXPECT_NEAR(uv.x(), u, 1e-9);
        EXPECT_NEAR(uv.y(), v, 1e-9);
      }
    }
  }
}

TEST(StereoCamera, DisparityDepthInverse) {
  const StereoCamera cam = test_camera();
  EXPECT_DOUBLE_EQ(cam.depth_from_disparity(70.0), 10.0);  // 700 px * 1 m / 70 px
  EXPECT_DOUBLE_EQ(cam.disparity_from_depth(10.0), 70.0);
  const Eigen::Vector3d p(1.5, -0.4, 7.0);
  const Eigen::Vector3d uvr = cam.project_stereo(p);
  EXPECT_NEAR(uvr.x() - uvr.z(), cam.disparity_from_depth(7.0), 1e-12);
  const auto back = cam.triangulate(uvr.head<2>(), uvr.z());
  ASSERT_TRUE(back.has_value());
  EXPECT_LT((*back - p).norm(), 1e-9);
}

TEST(StereoCamera, TriangulateRejectsNonPositiveDisparity) {
  const StereoCamera cam = test_camera();
  EXPECT_FALSE(cam.triangulate({100.0, 100.0}, 100.0).has_value());
  EXPECT_FALSE(cam.triangulate({100.0, 100.0}, 120.0).has_value());
}

TEST(StereoCamera, ValidateNamesTheProblem) {
  StereoCamera cam = test_camera();
  EXPECT_TRUE(cam.validate().has_value());
  cam.baseline_m = -1.0;
  const auto st = cam.validate();
  ASSERT_FALSE(st.has_value());
  EXPECT_NE(st.error().message.find("baseline_m"), std::string::npos);
  cam = test_camera();
  cam.cx = 2000;
  ASSERT_FALSE(cam.validate().has_value());
  EXPECT_NE(cam.validate().error().message.find("cx"), std::string::npos);
}

// issue 20: fx = 1e300 or a 1e10 m baseline passed, and the run reported
// identity or 1e9 m poses as OK.
TEST(StereoCamera, ValidateRejectsImplausibleRigs) {
  const auto message = [](const StereoCamera& cam) {
    const Status st = cam.validate();
    return st ? std::string() : st.error().message;
  };
  StereoCamera cam = test_camera();
  cam.fx = 1e300;
  EXPECT_NE(message(cam).find("fx=1e+300"), std::string::npos) << message(cam);
  EXPECT_NE(message(cam).find("implausible"), std::string::npos);
  cam = test_camera();
  cam.fy = std::numeric_limits<double>::infinity();
  EXPECT_NE(message(cam).find("fy=inf"), std::string::npos) << message(cam);
  cam = test_camera();
  cam.fx = cam.fy = 1.0;  // 1 px focal length on a 960 px wide image
  EXPECT_NE(message(cam).find("implausible"), std::string::npos) << message(cam);
  cam = test_camera();
  cam.baseline_m = 1e10;
  EXPECT_NE(message(cam).find("baseline_m=1e+10 implausible"), std::string::npos) << message(cam);
  cam.baseline_m = 0.001;
  EXPECT_NE(message(cam).find("baseline_m=0.001 implausible"), std::string::npos) << message(cam);
  cam = test_camera();
  cam.baseline_m = 0.01;
  cam.fx = cam.fy = 0.05 * cam.width;
  EXPECT_EQ(message(cam), "");  // the limits themselves are plausible
}

}  // namespace
}  // namespace sitepose
