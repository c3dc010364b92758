#include "sitepose/sim/simulator.hpp"
#include "sitepose/testing/simulated.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

namespace sitepose::sim {
namespace {

// Small and short: one truck that starts late and stops, one parked roller,
// a cone, all close enough to be in view.
Scenario small_scenario() {
  auto s = parse_scenario(R"(name: unit
description: "unit test"
fps: 6
duration_s: 3
seed: 11
ego:
  segments: [{speed_mps: 0.6, duration_s: 3}]
machines:
  - {class: roller, x_m: -3, y_m: -7, yaw_deg: 10}
  - class: truck
    waypoints: [[4, -9], [30, -9]]
    speed_mps: 1.0
    accel_mps2: 2.0
    start_s: 0.6
    stops: [{at_s: 1.6, duration_s: 1.0}]
cones:
  - {x_m: 1, y_m: -4.5}
)",
                          "unit.yaml");
  SITEPOSE_CHECK(s.has_value());
  return *s;
}

SimOptions small_options() {
  SimOptions o;
  o.width = 320;
  o.height = 180;
  return o;
}

struct SmallSite {
  static Scenario scenario() { return small_scenario(); }
  static SimOptions options() { return small_options(); }
};
using SimulatorTest = testing::RenderedScenarioTest<SmallSite>;

TEST_F(SimulatorTest, ImagesHaveTheRequestedSizeAndScaledIntrinsics) {
  EXPECT_EQ(sim_->frame_count(), 18);
  EXPECT_DOUBLE_EQ(sim_->camera().fx, 700.0 / 3.0);
  EXPECT_DOUBLE_EQ(sim_->camera().cx, 160.0);
  const SimFrame& f = frames_[0];
  EXPECT_EQ(f.left.size(), cv::Size(320, 180));
  EXPECT_EQ(f.left.type(), CV_8UC1);
  EXPECT_EQ(f.right.type(), CV_8UC1);
  EXPECT_EQ(f.instance_mask.type(), CV_16UC1);
}

TEST_F(SimulatorTest, BoxesAreTheTightBoundsOfTheInstanceMask) {
  int visible = 0;
  for (const SimFrame& f : frames_) {
    for (const ObjectTruth& o : f.objects) {
      cv::Mat pixels = f.instance_mask == o.instance;
      const int count = cv::countNonZero(pixels);
      EXPECT_EQ(o.visible, count > 0);
      EXPECT_EQ(o.pixels, count);
      if (count == 0) continue;
      ++visible;
      EXPECT_EQ(o.box, cv::boundingRect(pixels)) << "frame " << f.index << " instance " << o.instance;
    }
    const double covered = cv::countNonZero(f.instance_mask) / static_cast<double>(f.instance_mask.total());
    EXPECT_DOUBLE_EQ(f.occlusion_ratio, covered);
  }
  EXPECT_GT(visible, 2 * static_cast<int>(frames_.size()));  // the test must see objects
}

TEST_F(SimulatorTest, MovingIsSetExactlyWhenTheWorldPoseChanged) {
  int moving = 0, still = 0;
  for (size_t k = 0; k < frames_.size(); ++k) {
    const size_t other = k == 0 ? 1 : k - 1;
    for (size_t i = 0; i < frames_[k].objects.size(); ++i) {
      const SE3& a = frames_[k].objects[i].T_site_obj;
      const SE3& b = frames_[other].objects[i].T_site_obj;
      const bool changed = a.matrix() != b.matrix();
      EXPECT_EQ(frames_[k].objects[i].moving, changed) << "frame " << k << " object " << i;
      if (frames_[k].objects[i].class_name == "truck") {
        (changed ? moving : still)++;
      } else {
        EXPECT_FALSE(frames_[k].objects[i].moving);
      }
    }
  }
  // The truck waits (frames 0-3), drives, stops, drives again.
  EXPECT_GE(moving, 5);
  EXPECT_GE(still, 5);
}

TEST_F(SimulatorTest, PosesStartAtIdentityAndLookSideways) {
  EXPECT_TRUE(frames_[0].T_world_cam.matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-12));
  for (const SimFrame& f : frames_) {
    const Eigen::Vector3d axis = f.T_site_cam.rotation_matrix().col(2);
    EXPECT_NEAR(axis.x(), 0.0, 0.01);  // perpendicular to travel (+x), up to vibration
    EXPECT_LT(axis.z(), -0.1);         // pitched down
    EXPECT_NEAR(f.T_site_cam.translation().z(), 2.0, 0.01);
  }
  EXPECT_GT(frames_.back().T_site_cam.translation().x() - frames_[0].T_site_cam.translation().x(), 0.5);
}

TEST_F(SimulatorTest, SameSeedGivesIdenticalBytesAndAnotherSeedDiffers) {
  auto again = Simulator::create(small_scenario(), small_options());
  ASSERT_TRUE(again);
  const SimFrame f = again->render(7);
  EXPECT_EQ(cv::norm(f.left, frames_[7].left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(f.right, frames_[7].right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(f.instance_mask, frames_[7].instance_mask, cv::NORM_INF), 0.0);
  SimOptions other = small_options();
  other.seed = 12;
  auto different = Simulator::create(small_scenario(), other);
  ASSERT_TRUE(different);
  const SimFrame g = different->render(7);
  EXPECT_GT(cv::norm(g.left, frames_[7].left, cv::NORM_L1) / g.left.total(), 5.0);
}

TEST_F(SimulatorTest, StereoPairIsConsistentWithTheDepth) {
  // A textured left patch matches the right image at the disparity the
  // depth buffer implies better than 4 px beside it (normalised
  // cross-correlation of 9x9 patches; noise and exposure are on).
  const SimFrame& f = frames_[5];
  const StereoCamera& cam = sim_->camera();
  auto ncc = [&](int u, int v, int ur) {
    cv::Mat a, b, score;
    f.left(cv::Rect(u - 4, v - 4, 9, 9)).convertTo(a, CV_32F);
    f.right(cv::Rect(ur - 4, v - 4, 9, 9)).convertTo(b, CV_32F);
    cv::matchTemplate(a, b, score, cv::TM_CCOEFF_NORMED);
    return score.at<float>(0, 0);
  };
  int wins = 0, tried = 0;
  for (int v = 20; v < 160; v += 10) {
    for (int u = 60; u < 300; u += 10) {
      const float z = f.depth_m.at<float>(v, u);
      if (!std::isfinite(z) || z > 30.0f) continue;
      const int ur = static_cast<int>(std::lround(u - cam.bf() / z));
      if (ur < 9 || ur > 310) continue;
      ++tried;
      if (ncc(u, v, ur) > std::max(ncc(u, v, ur - 4), ncc(u, v, ur + 4))) ++wins;
    }
  }
  ASSERT_GT(tried, 100);
  EXPECT_GT(wins, tried * 0.85) << wins << " of " << tried;
}

TEST(Simulator, ACoveredLensGivesNearBlackFramesWhileTheTruthGoesOn) {
  Scenario s = small_scenario();
  s.realism.lens_covered = {LensCoverSpec{1.0, 1.0, 0.03}};  // frames 6-11 of 18
  auto covered = Simulator::create(s, small_options());
  auto open = Simulator::create(small_scenario(), small_options());
  ASSERT_TRUE(covered && open);
  for (int k : {5, 6, 11, 12}) {
    const SimFrame fc = covered->render(k), fo = open->render(k);
    const bool dark = k >= 6 && k <= 11;
    EXPECT_EQ(cv::mean(fc.left)[0] < 10.0 && cv::mean(fc.right)[0] < 10.0, dark) << "frame " << k;
    if (!dark) {
      EXPECT_EQ(cv::norm(fc.left, fo.left, cv::NORM_INF), 0.0) << "frame " << k;
    }
    EXPECT_TRUE(fc.T_world_cam.translation().isApprox(fo.T_world_cam.translation())) << "frame " << k;
  }
}

TEST(Simulator, DistortedOutputMovesPixelsOutwardButKeepsTheCentre) {
  Scenario s = small_scenario();
  s.realism.distorted = true;
  s.realism.distortion = {-0.2, 0.05, 0.0, 0.0};
  s.realism.noise_sigma = 0.0;
  s.realism.exposure_variation = 0.0;
  auto sim = Simulator::create(s, small_options());
  ASSERT_TRUE(sim) << sim.error().message;
  Scenario r = s;
  r.realism.distorted = false;
  auto rect = Simulator::create(r, small_options());
  ASSERT_TRUE(rect);
  const SimFrame fd = sim->render(2), fr = rect->render(2);
  const cv::Rect centre(155, 85, 11, 11);
  EXPECT_NEAR(cv::mean(fd.left(centre))[0], cv::mean(fr.left(centre))[0], 2.0);
  EXPECT_GT(cv::norm(fd.left, fr.left, cv::NORM_L1) / fd.left.total(), 2.0);
  // Barrel distortion (k1 < 0): the mask's objects shrink towards the centre.
  EXPECT_LE(cv::countNonZero(fd.instance_mask), cv::countNonZero(fr.instance_mask));
}

// An ego with waypoints drives the rounded path with its heading along it:
// clockwise round a block, the right-hand camera's axis points into the
// block, so over the loop it points along -y, -x, +y and +x in turn, and
// the camera stays on the path (its lateral offset from the body is small).
TEST(Simulator, AnEgoWithWaypointsDrivesThePathLookingIntoTheBlock) {
  auto s = parse_scenario(R"(name: unit
description: "unit test"
fps: 6
duration_s: 60
ego:
  turn_radius_m: 3
  waypoints: [[0, 0], [12, 0], [12, -8], [0, -8], [0, 0]]
  segments: [{speed_mps: 1.0, duration_s: 60}]
)",
                          "unit.yaml");
  ASSERT_TRUE(s.has_value()) << s.error().message;
  auto sim = Simulator::create(*s, small_options());
  ASSERT_TRUE(sim.has_value()) << sim.error().message;
  bool looked[4] = {false, false, false, false};  // -y, -x, +y, +x
  const Eigen::Vector2d directions[4] = {{0, -1}, {-1, 0}, {0, 1}, {1, 0}};
  for (double t = 0.0; t < 36.0; t += 0.5) {
    const SE3 T = sim->T_site_cam(t);
    const Eigen::Vector2d p = T.translation().head<2>();
    EXPECT_GT(p.x(), -1.0) << t;
    EXPECT_LT(p.x(), 13.0) << t;
    EXPECT_GT(p.y(), -9.0) << t;
    EXPECT_LT(p.y(), 1.0) << t;
    const Eigen::Vector2d axis = (T.rotation() * Eigen::Vector3d::UnitZ()).head<2>().normalized();
    for (int k = 0; k < 4; ++k) looked[k] = looked[k] || axis.dot(directions[k]) > std::cos(0.1);
  }
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(looked[k]) << k;
}

TEST(Simulator, BadOverridesAreRejected) {
  SimOptions o;
  o.frames = 0;
  auto a = Simulator::create(small_scenario(), o);
  ASSERT_FALSE(a);
  EXPECT_NE(a.error().message.find("frames"), std::string::npos);
  SimOptions w;
  w.width = 4;
  EXPECT_FALSE(Simulator::create(small_scenario(), w));
}

}  // namespace
}  // namespace sitepose::sim
