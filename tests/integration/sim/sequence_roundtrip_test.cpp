// A simulated sequence written to disk reads back through the foundation
// reader (io::open_sequence) with the same images, camera, poses and labels;
// and the `sitepose sim` command keeps its contract.

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "sitepose/io/json_file.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/sim/sequence_writer.hpp"
#include "sitepose/sim/simulator.hpp"
#include "sitepose/testing/files.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose::sim {
namespace {

namespace fs = std::filesystem;

Simulator small_crowded(int frames) {
  auto sim = testing::small_simulator("crowded", 320, 180, frames, SITEPOSE_SOURCE_DIR "/config/scenarios");
  SITEPOSE_CHECK(sim.has_value());
  return std::move(*sim);
}

TEST(SimSequence, WrittenSequenceReadsBackThroughTheFoundationReader) {
  const Simulator sim = small_crowded(6);
  const testing::TempDir tmp;
  const fs::path dir = tmp.path() / "seq";
  auto summary = write_sequence(sim, dir.string());
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->frames, 6);

  auto seq = io::open_sequence(dir.string());
  ASSERT_TRUE(seq) << seq.error().message;
  const io::Sequence& s = **seq;
  ASSERT_EQ(s.size(), 6u);
  EXPECT_NEAR(s.camera().fx, sim.camera().fx, 1e-9);
  EXPECT_NEAR(s.camera().cx, sim.camera().cx, 1e-9);
  EXPECT_NEAR(s.camera().baseline_m, 1.0, 1e-9);
  EXPECT_EQ(s.camera().width, 320);
  ASSERT_TRUE(s.has_gt());
  ASSERT_TRUE(s.has_labels());
  ASSERT_TRUE(s.has_masks());
  for (size_t k = 0; k < s.size(); ++k) {
    const SimFrame f = sim.render(static_cast<int>(k));
    EXPECT_EQ(s.time_ns(k), f.t_ns);
    auto frame = s.read_frame(k);
    ASSERT_TRUE(frame) << frame.error().message;
    EXPECT_EQ(cv::norm(frame->left, f.left, cv::NORM_INF), 0.0) << "frame " << k;
    EXPECT_EQ(cv::norm(frame->right, f.right, cv::NORM_INF), 0.0) << "frame " << k;
    ASSERT_TRUE(s.gt_poses()[k].has_value());
    EXPECT_TRUE(s.gt_poses()[k]->matrix().isApprox(f.T_world_cam.matrix(), 1e-9)) << "frame " << k;
    auto mask = s.read_instance_mask(k);
    ASSERT_TRUE(mask) << mask.error().message;
    EXPECT_EQ(cv::norm(*mask, f.instance_mask, cv::NORM_INF), 0.0);
    // boxes.csv: exactly the visible objects, tight bounds of the mask read back.
    const auto boxes = s.boxes_for_frame(k);
    size_t visible = 0;
    for (const ObjectTruth& o : f.objects) visible += o.visible ? 1 : 0;
    EXPECT_EQ(boxes.size(), visible);
    for (const io::LabelBox& b : boxes) {
      cv::Mat pixels = *mask == b.instance;
      EXPECT_EQ(b.box, cv::boundingRect(pixels)) << "frame " << k << " instance " << b.instance;
      ASSERT_TRUE(b.moving.has_value());
      for (const ObjectTruth& o : f.objects) {
        if (o.instance == b.instance) {
          EXPECT_EQ(*b.moving, o.moving);
          EXPECT_EQ(b.class_name, o.class_name);
        }
      }
    }
  }
  const std::string meta = testing::read_text((dir / "meta.json").string());
  EXPECT_NE(meta.find("\"scenario\": \"crowded\""), std::string::npos);
  EXPECT_NE(meta.find("\"occlusion_ratio\": ["), std::string::npos);
}

// issue 21: meta.json was not valid JSON (T_site_world without commas); the
// ground truth is also written as TUM; the sequence is written beside the
// folder and moved in, --force replacing only the sequence's own files.
TEST(SimSequence, MetaIsJsonGroundTruthAlsoTumAndForceReplaces) {
  const Simulator sim = small_crowded(4);
  const testing::TempDir tmp;
  const fs::path dir = tmp.path() / "seq";
  ASSERT_TRUE(write_sequence(sim, dir.string()));
  auto meta = io::read_json_file((dir / "meta.json").string());
  ASSERT_TRUE(meta) << meta.error().message;
  EXPECT_EQ((*meta)["frames"].get<int>(), 4);
  EXPECT_FALSE((*meta)["partial"].get<bool>());
  ASSERT_EQ((*meta)["T_site_world"].size(), 12u);
  const Eigen::Matrix<double, 3, 4> T = sim.T_site_world().matrix3x4();
  EXPECT_DOUBLE_EQ((*meta)["T_site_world"][7].get<double>(), T(1, 3));
  EXPECT_EQ((*meta)["occlusion_ratio"].size(), 4u);

  auto tum = io::read_tum_trajectory((dir / "poses_tum.txt").string());
  auto kitti = io::read_kitti_trajectory((dir / "poses.txt").string(), (dir / "times.txt").string());
  ASSERT_TRUE(tum && kitti);
  ASSERT_EQ(tum->size(), 4u);
  for (std::size_t k = 0; k < tum->size(); ++k) {
    EXPECT_NEAR((*tum)[k].t_s, (*kitti)[k].t_s, 1e-9);
    EXPECT_LT(((*tum)[k].T_world_cam.matrix() - (*kitti)[k].T_world_cam.matrix()).cwiseAbs().maxCoeff(),
              1e-8);
  }

  testing::write_file((dir / "notes.txt").string(), "kept\n");
  WriteOptions no_force;
  EXPECT_FALSE(write_sequence(small_crowded(2), dir.string(), no_force));
  WriteOptions force;
  force.force = true;
  ASSERT_TRUE(write_sequence(small_crowded(2), dir.string(), force));
  EXPECT_EQ(testing::read_text((dir / "notes.txt").string()), "kept\n");
  EXPECT_FALSE(fs::exists(dir / "image_0" / "000003.png"));  // no stale frame
  EXPECT_TRUE(fs::exists(dir / "image_0" / "000001.png"));
  for (const auto& entry : fs::directory_iterator(tmp.path())) {
    EXPECT_EQ(entry.path().filename().string().find(".partial-"), std::string::npos) << entry.path();
  }
}

TEST(SimSequence, FullSizeFrameCarriesManyOrbCornersOverTheWholeView) {
  auto scenario = load_scenario("static", std::string(SITEPOSE_SOURCE_DIR) + "/config/scenarios");
  ASSERT_TRUE(scenario);
  auto sim = Simulator::create(*scenario);
  ASSERT_TRUE(sim);
  const SimFrame f = sim->render(40);
  std::vector<cv::KeyPoint> keypoints;
  cv::ORB::create(3000)->detect(f.left, keypoints);
  EXPECT_GE(keypoints.size(), 1500u);
  // Spread: every cell of a 4x3 grid holds corners.
  int counts[3][4] = {};
  for (const auto& kp : keypoints) counts[static_cast<int>(kp.pt.y * 3 / 540)][static_cast<int>(kp.pt.x * 4 / 960)]++;
  for (auto& row : counts)
    for (int c : row) EXPECT_GT(c, 20);
}

int run(const std::string& args) {
  const std::string cmd = std::string(SITEPOSE_SITEPOSE_EXE) + " " + args + " > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(SimCommand, FollowsTheCommandContract) {
  if (!fs::exists(SITEPOSE_SITEPOSE_EXE)) GTEST_SKIP() << "build the `sitepose` target first";
  const testing::TempDir tmp;
  const fs::path dir = tmp.path() / "seq";
  EXPECT_EQ(run("sim --list"), 0);
  EXPECT_EQ(run("sim --scenario no_such_scenario --out " + dir.string()), 2);
  EXPECT_EQ(run("sim --scenario static --out " + dir.string() + " --frames 2 --width 160 --height 90"), 0);
  EXPECT_TRUE(fs::exists(dir / "image_1" / "000001.png"));
  EXPECT_FALSE(fs::exists(dir / "image_1" / "000002.png"));
  // Non-empty output refused without --force; --force replaces the sequence.
  EXPECT_EQ(run("sim --scenario static --out " + dir.string() + " --frames 1 --width 160 --height 90"), 2);
  EXPECT_EQ(run("sim --scenario static --out " + dir.string() + " --frames 1 --width 160 --height 90 --force"), 0);
  EXPECT_FALSE(fs::exists(dir / "image_1" / "000001.png"));
  const fs::path bad = dir / "bad.yaml";
  std::ofstream(bad) << "name: bad\ndescription: d\nduration_s: 1\nego: {speed: 3}\n";
  EXPECT_EQ(run("sim --scenario " + bad.string() + " --out " + (dir / "x").string()), 2);
}

}  // namespace
}  // namespace sitepose::sim
