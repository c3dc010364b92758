// The weight-free `stereo-geometric` detector on simulated frames (480x270):
// recall of the visible machines against the simulator's ground-truth boxes
// and false positives on the machine-free `static` scenario.

#include <chrono>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "sitepose/detect/create_detector.hpp"
#include "sitepose/sim/simulator.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose::detect {
namespace {

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

struct Score {
  int machines = 0;        // visible machines of at least kMinMachineFraction
  int found = 0;           // of those, matched by a detection with IoU >= 0.5
  int detections = 0;
  int false_positives = 0;  // detections touching no ground-truth object
  int frames = 0;
  double ms_per_frame = 0.0;
  std::int64_t mask_pixels = 0;     // pixels of the detections' masks
  std::int64_t mask_on_object = 0;  // of those, on a ground-truth object
  double mask_precision() const {
    return mask_pixels > 0 ? static_cast<double>(mask_on_object) / mask_pixels : 0.0;
  }
};

// "Visible machine": at least 1 % of the image (a few hundred pixels at
// 480x270); slivers at the border are not expected to be found.
constexpr double kMinMachineFraction = 0.01;

Expected<Score> run(const std::string& scenario_name, int width, int height,
                    const std::vector<int>& frames, int* id_switches = nullptr) {
  SITEPOSE_TRY(auto simulator, testing::small_simulator(scenario_name, width, height));
  config::DetectorConfig c;
  c.name = "stereo-geometric";
  DetectorContext context;
  context.camera = simulator.camera();
  SITEPOSE_TRY(auto detector, create_detector(c, context));
  Score score;
  double total_ms = 0.0;
  std::map<std::uint16_t, std::uint16_t> id_of_truth;  // sim instance -> detector id
  for (int k : frames) {
    const sim::SimFrame f = simulator.render(k);
    const StereoFrame frame = testing::stereo_frame(f);
    const auto start = std::chrono::steady_clock::now();
    SITEPOSE_TRY(auto dets, detector->detect(frame));
    SITEPOSE_TRY(cv::Mat mask, detector->segment(frame, dets));
    total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    ++score.frames;
    score.mask_pixels += cv::countNonZero(mask);
    score.mask_on_object += cv::countNonZero((mask != 0) & (f.instance_mask != 0));
    for (const auto& d : dets) {  // pixel masks stay inside their boxes
      const cv::Mat inside = mask(d.box) == d.instance;
      if (cv::countNonZero(mask == d.instance) != cv::countNonZero(inside)) {
        return make_error(ErrorCode::kRuntime, "mask pixels outside a box");
      }
    }
    score.detections += static_cast<int>(dets.size());
    for (const auto& d : dets) {
      bool touches = false;
      for (const auto& t : f.objects) touches = touches || (t.visible && (t.box & d.box).area() > 0);
      score.false_positives += !touches;
    }
    for (const auto& t : f.objects) {
      if (!t.visible || t.class_name == "cone" || t.pixels < kMinMachineFraction * width * height) continue;
      ++score.machines;
      const Detection* best = nullptr;
      for (const auto& d : dets) {
        if (iou(d.box, t.box) >= 0.5 && (!best || iou(d.box, t.box) > iou(best->box, t.box))) best = &d;
      }
      if (best == nullptr) continue;
      ++score.found;
      if (id_switches != nullptr) {
        auto [it, inserted] = id_of_truth.emplace(t.instance, best->instance);
        if (!inserted && it->second != best->instance) {
          ++*id_switches;
          it->second = best->instance;
        }
      }
    }
  }
  score.ms_per_frame = total_ms / std::max(1, score.frames);
  std::printf("%s %dx%d: frames %d, machines %d, found %d (recall %.2f), detections %d, false "
              "positives %d, mask precision %.2f, %.1f ms/frame (detect + segment)\n",
              scenario_name.c_str(), width, height, score.frames, score.machines, score.found,
              score.machines ? static_cast<double>(score.found) / score.machines : 0.0,
              score.detections, score.false_positives, score.mask_precision(),
              score.ms_per_frame);
  return score;
}

std::vector<int> every(int first, int step, int count) {
  std::vector<int> v;
  for (int i = 0; i < count; ++i) v.push_back(first + i * step);
  return v;
}

TEST(StereoGeometric, FindsMostVisibleMachinesOnCrowded) {
  int switches = 0;
  auto s = run("crowded", 480, 270, every(0, 3, 20), &switches);
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_GT(s->machines, 15);
  EXPECT_GE(static_cast<double>(s->found) / s->machines, 0.7);
  EXPECT_LE(s->false_positives, s->frames / 4);
  EXPECT_GE(s->mask_precision(), 0.8);
  std::printf("crowded: %d id switches over consecutive frames 3 apart\n", switches);
}

TEST(StereoGeometric, FindsParkedMachines) {
  auto s = run("parked", 480, 270, every(30, 12, 20));
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_GT(s->machines, 10);
  EXPECT_GE(static_cast<double>(s->found) / s->machines, 0.7);
  EXPECT_LE(s->false_positives, s->frames / 4);
}

TEST(StereoGeometric, FewFalsePositivesOnStatic) {
  auto s = run("static", 480, 270, every(0, 18, 20));
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_LE(s->false_positives, s->frames / 5);
}

TEST(StereoGeometric, InstanceIdsStayStableFrameToFrame) {
  int switches = 0;
  auto s = run("crowded", 480, 270, every(40, 1, 12), &switches);
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_GT(s->found, 5);
  EXPECT_LE(switches, 1);
}

}  // namespace
}  // namespace sitepose::detect

namespace sitepose::detect {
namespace {

// Full size: the time per frame the issue asks for (printed; wall time on a
// shared machine is not asserted) and the same recall requirement.
TEST(StereoGeometric, FullSize960x540) {
  auto s = run("crowded", 960, 540, every(20, 10, 5));
  ASSERT_TRUE(s) << s.error().message;
  ASSERT_GT(s->machines, 3);
  EXPECT_GE(static_cast<double>(s->found) / s->machines, 0.7);
  EXPECT_GE(s->mask_precision(), 0.8);
}

}  // namespace
}  // namespace sitepose::detect
