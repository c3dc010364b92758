#include "sitepose/sim/renderer.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "sitepose/testing/cameras.hpp"

namespace sitepose::sim {
namespace {

TexturePtr flat(int level) {
  return std::make_shared<const Texture>(cv::Mat(4, 4, CV_8UC1, cv::Scalar(level)), TextureWrap::kClamp);
}

StereoCamera small_camera() { return testing::centred_camera(320, 180, 300.0, 1.0); }

// A camera looking along site -y, pitched down, away from the origin: the
// tests must not pass only for an identity pose.
SE3 test_pose() {
  const double th = 12.0 * M_PI / 180.0;
  Eigen::Matrix3d R;
  R.col(2) = Eigen::Vector3d(0, -std::cos(th), -std::sin(th));
  R.col(1) = Eigen::Vector3d(0, std::sin(th), -std::cos(th));
  R.col(0) = R.col(1).cross(R.col(2));
  return SE3(R, Eigen::Vector3d(3.7, 1.2, 2.0));
}

// Intensity-weighted centroid of pixels brighter than `threshold`.
Eigen::Vector2d bright_centroid(const cv::Mat& radiance, float threshold) {
  double su = 0, sv = 0, sw = 0;
  for (int v = 0; v < radiance.rows; ++v)
    for (int u = 0; u < radiance.cols; ++u) {
      const float w = radiance.at<float>(v, u) - threshold;
      if (w <= 0) continue;
      su += w * u;
      sv += w * v;
      sw += w;
    }
  EXPECT_GT(sw, 0.0);
  return {su / sw, sv / sw};
}

TEST(Renderer, MarkerLandsWherePinholeModelProjects) {
  const StereoCamera cam = small_camera();
  const SE3 T_world_cam = test_pose();
  const Renderer renderer{RenderOptions{}};
  // Marker: a disc of 6 cm radius facing the camera, in front of a dark wall.
  for (const Eigen::Vector3d& p_cam : {Eigen::Vector3d(0.37, -0.21, 6.3), Eigen::Vector3d(-1.13, 0.52, 4.9)}) {
    const Eigen::Vector3d p_world = T_world_cam * p_cam;
    const Eigen::Matrix3d R = T_world_cam.rotation_matrix();
    auto mesh = std::make_shared<Mesh>();
    Patch disc;
    disc.shape = Shape::kEllipse;
    disc.origin = p_world;
    disc.axis_u = R * Eigen::Vector3d(0, 0.06, 0);  // u x v points to the camera
    disc.axis_v = R * Eigen::Vector3d(0.06, 0, 0);
    disc.texture = flat(250);
    mesh->patches.push_back(disc);
    Patch wall;
    wall.origin = T_world_cam * Eigen::Vector3d(-20, -20, 12);
    wall.axis_u = R * Eigen::Vector3d(0, 40, 0);
    wall.axis_v = R * Eigen::Vector3d(40, 0, 0);
    wall.texture = flat(20);
    mesh->patches.push_back(wall);
    Scene scene;
    scene.instances.push_back({mesh, SE3::identity(), 3});

    RenderBuffers left, right;
    renderer.render(scene, cam, T_world_cam, left);
    const SE3 T_world_right = T_world_cam * SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(cam.baseline_m, 0, 0));
    renderer.render(scene, cam, T_world_right, right);

    const Eigen::Vector2d expected_left = cam.project(p_cam);
    const Eigen::Vector2d got_left = bright_centroid(left.radiance, 100.0f);
    EXPECT_NEAR(got_left.x(), expected_left.x(), 0.5);
    EXPECT_NEAR(got_left.y(), expected_left.y(), 0.5);
    const Eigen::Vector2d got_right = bright_centroid(right.radiance, 100.0f);
    EXPECT_NEAR(got_right.x(), cam.project_right_u(p_cam), 0.5);
    EXPECT_NEAR(got_right.y(), expected_left.y(), 0.5);
    // The marker's pixel (round of the projection) carries its instance.
    EXPECT_EQ(left.instance.at<std::uint16_t>(static_cast<int>(std::lround(expected_left.y())),
                                              static_cast<int>(std::lround(expected_left.x()))),
              3);
    // Tight: sub-pixel agreement, not just the 0.5 px bound.
    EXPECT_LT((got_left - expected_left).norm(), 0.15);
  }
}

TEST(Renderer, GroundDepthAndDisparityMatchTheAnalyticPlane) {
  const StereoCamera cam = small_camera();
  const SE3 T_world_cam = test_pose();
  auto mesh = std::make_shared<Mesh>();
  Patch ground;
  ground.origin = Eigen::Vector3d(-500, -500, 0);
  ground.axis_u = Eigen::Vector3d(1000, 0, 0);
  ground.axis_v = Eigen::Vector3d(0, 1000, 0);
  ground.texture = flat(128);
  mesh->patches.push_back(ground);
  Scene scene;
  scene.instances.push_back({mesh, SE3::identity(), 0});
  RenderBuffers out;
  Renderer{RenderOptions{}}.render(scene, cam, T_world_cam, out);

  const Eigen::Matrix3d R = T_world_cam.rotation_matrix();
  const double height = T_world_cam.translation().z();
  int checked = 0, sky = 0;
  for (int v = 0; v < cam.height; v += 3) {
    for (int u = 0; u < cam.width; u += 3) {
      const Eigen::Vector3d ray_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
      const double down = -(R * ray_cam).z();
      const float depth = out.depth_m.at<float>(v, u);
      if (down <= height / 400.0) {  // beyond the 500 m ground edge or above the horizon
        if (down <= 0.0) {
          EXPECT_TRUE(std::isinf(depth)) << u << "," << v;
          ++sky;
        }
        continue;
      }
      const double expected_depth = height / down;  // z, since ray_cam.z = 1
      EXPECT_NEAR(depth, expected_depth, 1e-4 * expected_depth) << u << "," << v;
      EXPECT_NEAR(cam.disparity_from_depth(depth), cam.bf() / expected_depth, 1e-3);
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
  EXPECT_GT(sky, 50);  // the view must include the horizon for the test to mean anything
}

TEST(Renderer, NearerPatchWinsAndOneSidedBackFacesAreCulled) {
  const StereoCamera cam = small_camera();
  auto mesh = std::make_shared<Mesh>();
  Patch far_patch;  // z = 10, facing the camera (u x v = -z)
  far_patch.origin = Eigen::Vector3d(-5, -5, 10);
  far_patch.axis_u = Eigen::Vector3d(0, 10, 0);
  far_patch.axis_v = Eigen::Vector3d(10, 0, 0);
  far_patch.texture = flat(40);
  Patch near_patch = far_patch;  // z = 5, smaller
  near_patch.origin = Eigen::Vector3d(-1, -1, 5);
  near_patch.axis_u = Eigen::Vector3d(0, 2, 0);
  near_patch.axis_v = Eigen::Vector3d(2, 0, 0);
  near_patch.texture = flat(200);
  Patch back_facing = near_patch;  // z = 3, facing away: invisible
  back_facing.origin = Eigen::Vector3d(-1, -1, 3);
  back_facing.axis_u = Eigen::Vector3d(2, 0, 0);
  back_facing.axis_v = Eigen::Vector3d(0, 2, 0);
  mesh->patches = {far_patch, near_patch, back_facing};
  Scene scene;
  scene.instances.push_back({mesh, SE3::identity(), 7});
  RenderBuffers out;
  Renderer{RenderOptions{}}.render(scene, cam, SE3::identity(), out);
  EXPECT_NEAR(out.depth_m.at<float>(90, 160), 5.0f, 1e-4);
  EXPECT_NEAR(out.radiance.at<float>(90, 160) / 200.0f, 1.0f, 0.3f);  // shade factor only
  EXPECT_NEAR(out.depth_m.at<float>(10, 10), 10.0f, 1e-3);
  EXPECT_EQ(out.instance.at<std::uint16_t>(90, 160), 7);
}

}  // namespace
}  // namespace sitepose::sim
