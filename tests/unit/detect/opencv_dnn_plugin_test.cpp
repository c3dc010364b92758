// The built-in `opencv-dnn` detector with a tiny Darknet network the test
// writes itself. PLUMBING ONLY: the "network" is one 1x1 convolution whose
// weights are chosen by hand so a bright 8x8 patch yields one YOLO box; it
// checks model loading, the forward pass, YOLO output parsing, class names,
// box scaling and NMS — not detection quality of any real model.

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>

#include "sitepose/detect/create_detector.hpp"
#include "test_util.hpp"

namespace sitepose::detect {
namespace {

constexpr int kClasses = 2;
constexpr int kChannelsOut = 5 + kClasses;  // one anchor: tx ty tw th obj c0 c1

// [net] 8x8x3 -> 1x1 conv (linear) -> [yolo] with one 4x4 px anchor.
void write_tiny_darknet(const std::filesystem::path& cfg, const std::filesystem::path& weights) {
  std::ofstream(cfg) << "[net]\nwidth=8\nheight=8\nchannels=3\n\n"
                        "[convolutional]\nfilters=" << kChannelsOut
                     << "\nsize=1\nstride=1\npad=0\nactivation=linear\n\n"
                        "[yolo]\nmask=0\nanchors=4,4\nclasses=" << kClasses << "\nnum=1\n";
  std::ofstream out(weights, std::ios::binary);
  const std::int32_t header[3] = {0, 2, 0};  // major, minor, revision
  const std::uint64_t seen = 0;
  out.write(reinterpret_cast<const char*>(header), sizeof(header));
  out.write(reinterpret_cast<const char*>(&seen), sizeof(seen));
  // Biases: centred in its cell, w = h = exp(ln 0.5) * 4 px of an 8 px input
  // = a quarter of the image, objectness -10 (off) unless the pixel is
  // bright, class 0 on, class 1 off.
  const float biases[kChannelsOut] = {0.0f, 0.0f, std::log(0.5f), std::log(0.5f), -10.0f, 6.0f, -6.0f};
  out.write(reinterpret_cast<const char*>(biases), sizeof(biases));
  // Weights [out][in]: objectness += 20/3 per channel of the 0..1 input.
  float w[kChannelsOut][3] = {};
  for (float& v : w[4]) v = 20.0f / 3.0f;
  out.write(reinterpret_cast<const char*>(w), sizeof(w));
}

class OpencvDnnPlugin : public ::testing::Test {
 protected:
  void SetUp() override {
    write_tiny_darknet(dir_ / "tiny.cfg", dir_ / "tiny.weights");
    std::ofstream(dir_ / "names.txt") << "truck\nperson\n";
    config_.name = "opencv-dnn";
    config_.model_config = (dir_ / "tiny.cfg").string();
    config_.model_weights = (dir_ / "tiny.weights").string();
    config_.dnn_classes_file = (dir_ / "names.txt").string();
    config_.dnn_input_width_px = 8;
    config_.dnn_input_height_px = 8;
    config_.score_threshold = 0.5;
  }
  testing::TempDir tmp_;
  const std::filesystem::path dir_ = tmp_.path();
  config::DetectorConfig config_;
};

TEST_F(OpencvDnnPlugin, TinyDarknetNetworkGivesTheBoxOfTheBrightCell) {
  auto detector = create_detector(config_, {});
  ASSERT_TRUE(detector) << detector.error().message;
  EXPECT_FALSE((*detector)->capabilities().has_segmentation);
  // 64x64 image, 8x8 grid of 8 px cells; the bright cell is column 3, row 5.
  StereoFrame frame = test::gray_frame(64, 64);
  frame.left.setTo(0);
  frame.left(cv::Rect(24, 40, 8, 8)).setTo(255);
  auto dets = (*detector)->detect(frame);
  ASSERT_TRUE(dets) << dets.error().message;
  ASSERT_EQ(dets->size(), 1u);
  const Detection& d = dets->front();
  EXPECT_EQ(d.class_name, "truck");
  EXPECT_GT(d.score, 0.9);
  EXPECT_EQ(d.instance, 1);
  // Centre of cell (3, 5) = (28, 44) px, size a quarter of 64 px.
  EXPECT_NEAR(d.box.x + d.box.width / 2.0, 28.0, 1.0);
  EXPECT_NEAR(d.box.y + d.box.height / 2.0, 44.0, 1.0);
  EXPECT_NEAR(d.box.width, 16, 1);
  EXPECT_NEAR(d.box.height, 16, 1);

  // Move the patch: the box follows the image content.
  frame.left.setTo(0);
  frame.left(cv::Rect(0, 0, 8, 8)).setTo(255);
  dets = (*detector)->detect(frame);
  ASSERT_TRUE(dets) << dets.error().message;
  ASSERT_EQ(dets->size(), 1u);
  EXPECT_EQ(dets->front().box, cv::Rect(0, 0, 12, 12));  // clipped at the image corner
  // A dark image has no object.
  frame.left.setTo(0);
  dets = (*detector)->detect(frame);
  ASSERT_TRUE(dets);
  EXPECT_TRUE(dets->empty());
  EXPECT_EQ((*detector)->health().dropped_detections, 0);
}

TEST_F(OpencvDnnPlugin, OnnxAndBadModelFilesAreRefused) {
  config::DetectorConfig onnx = config_;
  onnx.model_weights = (dir_ / "model.onnx").string();
  auto refused = create_detector(onnx, {});
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("ONNX models are not supported"), std::string::npos)
      << refused.error().message;

  config::DetectorConfig missing = config_;
  missing.model_weights = (dir_ / "absent.weights").string();
  auto not_found = create_detector(missing, {});
  ASSERT_FALSE(not_found);
  EXPECT_NE(not_found.error().message.find("absent.weights"), std::string::npos);

  std::ofstream(dir_ / "broken.cfg") << "[net]\nwidth=8\n[nonsense_layer]\n";
  config::DetectorConfig broken = config_;
  broken.model_config = (dir_ / "broken.cfg").string();
  auto bad = create_detector(broken, {});
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("broken.cfg"), std::string::npos) << bad.error().message;
}

}  // namespace
}  // namespace sitepose::detect
