// The built-in `labels` detector on a small simulated sequence written by
// the test (crowded scenario, 320x180, 4 frames).

#include <chrono>

#include <gtest/gtest.h>

#include "sitepose/detect/create_detector.hpp"
#include "sitepose/detect/plugin_loader.hpp"
#include "sitepose/io/sequence.hpp"
#include "sitepose/sim/sequence_writer.hpp"
#include "sitepose/testing/simulated.hpp"
#include "test_util.hpp"

namespace sitepose::detect {
namespace {

class LabelsPlugin : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs the cases of this suite in parallel
    // processes, each with its own SetUpTestSuite.
    tmp_ = new testing::TempDir("labels-sequence");
    dir_ = new std::string((tmp_->path() / "seq").string());
    auto simulator = testing::small_simulator("crowded", 320, 180, 4);
    ASSERT_TRUE(simulator) << simulator.error().message;
    ASSERT_TRUE(sim::write_sequence(*simulator, *dir_));
    auto seq = io::open_sequence(*dir_);
    ASSERT_TRUE(seq) << seq.error().message;
    sequence_ = seq->release();
  }
  static void TearDownTestSuite() {
    delete sequence_;
    delete dir_;
    delete tmp_;
  }

  static Expected<std::unique_ptr<Detector>> make(const config::DetectorConfig& c) {
    DetectorContext context;
    context.sequence_dir = *dir_;
    return create_detector(c, context);
  }
  static StereoFrame frame(std::size_t i) {
    auto f = sequence_->read_frame(i);
    SITEPOSE_CHECK(f.has_value());
    return *f;
  }

  static testing::TempDir* tmp_;
  static std::string* dir_;
  static io::Sequence* sequence_;
};
testing::TempDir* LabelsPlugin::tmp_ = nullptr;
std::string* LabelsPlugin::dir_ = nullptr;
io::Sequence* LabelsPlugin::sequence_ = nullptr;

TEST_F(LabelsPlugin, ReturnsTheLabelledBoxesWithClassesAndIds) {
  auto d = make(config::DetectorConfig{});
  ASSERT_TRUE(d) << d.error().message;
  EXPECT_TRUE((*d)->capabilities().tracks_ids);
  EXPECT_TRUE((*d)->capabilities().has_segmentation);
  std::size_t total = 0;
  for (std::size_t i = 0; i < sequence_->size(); ++i) {
    auto dets = (*d)->detect(frame(i));
    ASSERT_TRUE(dets) << dets.error().message;
    const auto truth = sequence_->boxes_for_frame(i);
    ASSERT_EQ(dets->size(), truth.size()) << "frame " << i;
    for (std::size_t k = 0; k < truth.size(); ++k) {
      EXPECT_EQ((*dets)[k].class_name, truth[k].class_name);
      EXPECT_EQ((*dets)[k].instance, truth[k].instance);
      EXPECT_EQ((*dets)[k].box, truth[k].box);
      EXPECT_EQ((*dets)[k].score, 1.0);
    }
    total += truth.size();
  }
  EXPECT_GT(total, 4u);  // the crowded scenario shows machines from frame 0
  EXPECT_EQ((*d)->health().dropped_detections, 0);
}

TEST_F(LabelsPlugin, SegmentGivesTheStoredMasksOfTheGivenDetections) {
  auto d = make(config::DetectorConfig{});
  ASSERT_TRUE(d) << d.error().message;
  const StereoFrame f = frame(2);
  auto dets = (*d)->detect(f);
  ASSERT_TRUE(dets);
  ASSERT_FALSE(dets->empty());
  // Only the first detection: the others must stay background.
  const std::vector<Detection> one{dets->front()};
  auto mask = (*d)->segment(f, one);
  ASSERT_TRUE(mask) << mask.error().message;
  auto truth = sequence_->read_instance_mask(2);
  ASSERT_TRUE(truth);
  const cv::Mat expected = (*truth == one[0].instance);
  EXPECT_EQ(cv::countNonZero(*mask != 0), cv::countNonZero(expected));
  EXPECT_EQ(cv::countNonZero((*mask == one[0].instance) != expected), 0);
  EXPECT_EQ((*d)->health().cleared_mask_pixels, 0);
}

TEST_F(LabelsPlugin, MissProbabilityOneMissesEverything) {
  config::DetectorConfig c;
  c.labels_miss_probability = 1.0;
  auto d = make(c);
  ASSERT_TRUE(d) << d.error().message;
  auto dets = (*d)->detect(frame(0));
  ASSERT_TRUE(dets);
  EXPECT_TRUE(dets->empty());
}

TEST_F(LabelsPlugin, NoiseIsSeededAndDeterministic) {
  config::DetectorConfig c;
  c.labels_miss_probability = 0.3;
  c.labels_jitter_px = 3.0;
  c.labels_seed = 5;
  auto a = make(c);
  auto b = make(c);
  c.labels_seed = 6;
  auto other = make(c);
  ASSERT_TRUE(a && b && other);
  int differs_from_truth = 0, differs_from_other_seed = 0;
  // Reverse order for b: noise depends on (seed, frame, instance) only.
  std::vector<std::vector<Detection>> out_a, out_b(sequence_->size());
  for (std::size_t i = 0; i < sequence_->size(); ++i) out_a.push_back(*(*a)->detect(frame(i)));
  for (std::size_t i = sequence_->size(); i-- > 0;) out_b[i] = *(*b)->detect(frame(i));
  for (std::size_t i = 0; i < sequence_->size(); ++i) {
    ASSERT_EQ(out_a[i].size(), out_b[i].size());
    for (std::size_t k = 0; k < out_a[i].size(); ++k) {
      EXPECT_EQ(out_a[i][k].box, out_b[i][k].box);
      EXPECT_EQ(out_a[i][k].instance, out_b[i][k].instance);
    }
    const auto truth = sequence_->boxes_for_frame(i);
    for (const Detection& det : out_a[i]) {
      for (const auto& t : truth) {
        if (t.instance != det.instance) continue;
        differs_from_truth += det.box != t.box;
        // 3 px std dev per edge: 6 sigma bounds every edge.
        EXPECT_LE(std::abs(det.box.x - t.box.x), 18);
        EXPECT_LE(std::abs(det.box.br().y - t.box.br().y), 18);
      }
    }
    const auto o = *(*other)->detect(frame(i));
    differs_from_other_seed += o.size() != out_a[i].size() ||
                               (!o.empty() && o[0].box != out_a[i][0].box);
  }
  EXPECT_GT(differs_from_truth, 0);
  EXPECT_GT(differs_from_other_seed, 0);
}

TEST_F(LabelsPlugin, SimulatedLatencyDelaysDetect) {
  config::DetectorConfig c;
  c.labels_latency_ms = 40.0;
  auto d = make(c);
  ASSERT_TRUE(d) << d.error().message;
  const StereoFrame f = frame(1);
  const auto start = std::chrono::steady_clock::now();
  ASSERT_TRUE((*d)->detect(f));
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(ms, 40.0);
}

TEST_F(LabelsPlugin, FrameNotInTheSequenceIsAnError) {
  auto d = make(config::DetectorConfig{});
  ASSERT_TRUE(d);
  StereoFrame f = frame(0);
  f.seq = 1000;
  auto dets = (*d)->detect(f);
  ASSERT_FALSE(dets);
  EXPECT_NE(dets.error().message.find("frame 1000 is not in"), std::string::npos)
      << dets.error().message;
  StereoFrame small = test::gray_frame(160, 90, 0);
  auto wrong_size = (*d)->detect(small);
  ASSERT_FALSE(wrong_size);
  EXPECT_NE(wrong_size.error().message.find("160x90"), std::string::npos)
      << wrong_size.error().message;
  EXPECT_EQ((*d)->health().failed_calls, 2);
}

TEST_F(LabelsPlugin, ClassListKeepsOnlyThoseClasses) {
  auto path = builtin_plugin_path("labels");
  ASSERT_TRUE(path) << path.error().message;
  auto d = load_detector_plugin(*path, "{sequence_dir: '" + *dir_ + "', classes: [truck]}");
  ASSERT_TRUE(d) << d.error().message;
  std::size_t others = 0;
  for (std::size_t i = 0; i < sequence_->size(); ++i) {
    auto dets = (*d)->detect(frame(i));
    ASSERT_TRUE(dets);
    for (const auto& det : *dets) EXPECT_EQ(det.class_name, "truck");
    std::size_t trucks = 0;
    for (const auto& t : sequence_->boxes_for_frame(i)) {
      trucks += t.class_name == "truck";
      others += t.class_name != "truck";
    }
    EXPECT_EQ(dets->size(), trucks) << "frame " << i;
  }
  EXPECT_GT(others, 0u);  // the filter had something to remove
}

TEST_F(LabelsPlugin, BadConfigsAreRefusedWithTheKey) {
  auto path = builtin_plugin_path("labels");
  ASSERT_TRUE(path);
  auto unknown = load_detector_plugin(*path, "{sequence_dir: '" + *dir_ + "', jiter_px: 2}");
  ASSERT_FALSE(unknown);
  EXPECT_NE(unknown.error().message.find("jiter_px: unknown key"), std::string::npos)
      << unknown.error().message;
  auto missing = load_detector_plugin(*path, "{latency_ms: 3}");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().message.find("sequence_dir: required"), std::string::npos)
      << missing.error().message;
  auto bad_p = load_detector_plugin(*path, "{sequence_dir: '" + *dir_ + "', miss_probability: 2}");
  ASSERT_FALSE(bad_p);
  EXPECT_NE(bad_p.error().message.find("miss_probability"), std::string::npos);
  auto no_dir = load_detector_plugin(*path, "{sequence_dir: /nonexistent/seq}");
  ASSERT_FALSE(no_dir);
  EXPECT_NE(no_dir.error().message.find("/nonexistent/seq"), std::string::npos)
      << no_dir.error().message;
}

}  // namespace
}  // namespace sitepose::detect
