// Built-in detector `labels`: the paper's protocol, where boxes and masks are
// computed beforehand (METHOD.md: YOLO boxes and Mask R-CNN masks stored on
// disk). Reads labels/boxes.csv and labels/masks/ of a sitepose sequence.
//
// Config (YAML mapping):
//   sequence_dir: DIR        required; the sequence being run
//   classes: [truck, ...]    optional; only these classes are returned.
//                            Absent or empty = every labelled class (the
//                            masker then filters by dynamic.dynamic_classes)
//   latency_ms: 0            simulated detector latency (sleep per detect)
//   miss_probability: 0      probability that a box is missed, per box
//   jitter_px: 0             std dev of the Gaussian shift of each box edge
//   seed: 1                  noise seed
// Noise is a pure function of (seed, frame, instance): the same run gives the
// same boxes regardless of call order. The frame is identified by `seq`
// (the frame index in the sequence).

#include <chrono>
#include <cmath>
#include <random>
#include <set>
#include <thread>

#include "plugin_support.hpp"
#include "sitepose/io/sequence.hpp"

namespace sitepose::detect::plugin {
namespace {

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

class LabelsPlugin final : public PluginImpl {
 public:
  struct Options {
    std::string sequence_dir;
    std::vector<std::string> classes;
    double latency_ms = 0.0;
    double miss_probability = 0.0;
    double jitter_px = 0.0;
    int seed = 1;
  };

  LabelsPlugin(Options options, std::unique_ptr<io::Sequence> sequence)
      : options_(std::move(options)),
        sequence_(std::move(sequence)),
        classes_(options_.classes.begin(), options_.classes.end()) {}

  std::uint32_t capabilities() const override {
    return SP_DETECTOR_CAP_TRACKS_IDS | (sequence_->has_masks() ? SP_DETECTOR_CAP_SEGMENTATION : 0u);
  }

  Expected<std::vector<sp_detection>> detect(const cv::Mat& left, const cv::Mat&, std::int64_t,
                                             std::int64_t seq) override {
    SITEPOSE_TRY_STATUS(check_frame(left, seq));
    if (options_.latency_ms > 0.0) {
      std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(options_.latency_ms));
    }
    std::vector<sp_detection> out;
    for (const io::LabelBox& b : sequence_->boxes_for_frame(static_cast<std::size_t>(seq))) {
      if (!classes_.empty() && classes_.count(b.class_name) == 0) continue;
      std::mt19937_64 rng(
          mix(mix(static_cast<std::uint64_t>(options_.seed)) ^
              mix(static_cast<std::uint64_t>(seq) * 65537u + static_cast<std::uint64_t>(b.instance))));
      if (options_.miss_probability > 0.0 &&
          std::uniform_real_distribution<double>(0.0, 1.0)(rng) < options_.miss_probability) {
        continue;
      }
      cv::Rect box = b.box;
      if (options_.jitter_px > 0.0) {
        std::normal_distribution<double> shift(0.0, options_.jitter_px);
        const int x0 = box.x + static_cast<int>(std::lround(shift(rng)));
        const int y0 = box.y + static_cast<int>(std::lround(shift(rng)));
        const int x1 = box.br().x + static_cast<int>(std::lround(shift(rng)));
        const int y1 = box.br().y + static_cast<int>(std::lround(shift(rng)));
        // Keep a jittered box valid (>= 1 px, inside the image): noise is not garbage.
        box = cv::Rect(cv::Point(std::min(x0, x1 - 1), std::min(y0, y1 - 1)),
                       cv::Point(std::max(x1, x0 + 1), std::max(y1, y0 + 1))) &
              cv::Rect(0, 0, left.cols, left.rows);
        if (box.empty()) continue;
      }
      out.push_back(make_detection(b.class_name, 1.0f, box, static_cast<std::uint16_t>(b.instance)));
    }
    return out;
  }

  Status segment(const cv::Mat& left, const cv::Mat&, std::int64_t, std::int64_t seq,
                 const std::vector<sp_detection>& detections, cv::Mat& mask) override {
    SITEPOSE_TRY_STATUS(check_frame(left, seq));
    SITEPOSE_TRY(cv::Mat labels, sequence_->read_instance_mask(static_cast<std::size_t>(seq)));
    for (const sp_detection& d : detections) {
      const cv::Rect box = cv::Rect(d.x, d.y, d.w, d.h) & cv::Rect(0, 0, mask.cols, mask.rows);
      if (box.empty()) continue;
      cv::Mat object = labels(box) == d.instance;
      mask(box).setTo(d.instance, object);
    }
    return ok_status();
  }

 private:
  Status check_frame(const cv::Mat& left, std::int64_t seq) const {
    if (seq < 0 || static_cast<std::size_t>(seq) >= sequence_->size()) {
      return make_error(ErrorCode::kInvalidArgument, "labels: frame " + std::to_string(seq) + " is not in " +
                                                         options_.sequence_dir + " (" +
                                                         std::to_string(sequence_->size()) + " frames)");
    }
    const StereoCamera& cam = sequence_->camera();
    if (left.cols != cam.width || left.rows != cam.height) {
      return make_error(ErrorCode::kInvalidArgument,
                        "labels: image " + std::to_string(left.cols) + "x" + std::to_string(left.rows) +
                            " but the labels of " + options_.sequence_dir + " are for " +
                            std::to_string(cam.width) + "x" + std::to_string(cam.height));
    }
    return ok_status();
  }

  Options options_;
  std::unique_ptr<io::Sequence> sequence_;
  std::set<std::string> classes_;
};

}  // namespace

Expected<std::unique_ptr<PluginImpl>> make_plugin(const YAML::Node& config) {
  OptionReader reader(config, "labels");
  LabelsPlugin::Options o;
  SITEPOSE_TRY_STATUS(reader.read("sequence_dir", o.sequence_dir, true));
  SITEPOSE_TRY_STATUS(reader.read("classes", o.classes));
  SITEPOSE_TRY_STATUS(reader.read("latency_ms", o.latency_ms));
  SITEPOSE_TRY_STATUS(reader.read("miss_probability", o.miss_probability));
  SITEPOSE_TRY_STATUS(reader.read("jitter_px", o.jitter_px));
  SITEPOSE_TRY_STATUS(reader.read("seed", o.seed));
  SITEPOSE_TRY_STATUS(reader.finish());
  SITEPOSE_TRY_STATUS(reader.require_non_negative("latency_ms", o.latency_ms));
  SITEPOSE_TRY_STATUS(reader.require_unit_interval("miss_probability", o.miss_probability));
  SITEPOSE_TRY_STATUS(reader.require_non_negative("jitter_px", o.jitter_px));
  SITEPOSE_TRY(auto sequence, io::open_sequence(o.sequence_dir));
  if (!sequence->has_labels()) {
    return make_error(ErrorCode::kNotFound, "labels: " + o.sequence_dir + " has no labels/boxes.csv");
  }
  return std::unique_ptr<PluginImpl>(new LabelsPlugin(std::move(o), std::move(sequence)));
}

}  // namespace sitepose::detect::plugin
