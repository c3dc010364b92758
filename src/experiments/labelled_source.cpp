#include "sitepose/experiments/labelled_source.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <vector>

#include "sitepose/io/sequence.hpp"
#include "sitepose/sim/scenario.hpp"
#include "sitepose/sim/sequence_writer.hpp"
#include "sitepose/sim/simulator.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::experiments {
namespace fs = std::filesystem;
namespace {

dynamic::PixelSegmenter segmenter_of(const cv::Mat& mask) {
  if (mask.empty()) return {};
  return [mask](const std::vector<dynamic::ObjectBox>&) -> Expected<cv::Mat> { return mask; };
}

class SimulatedSource final : public LabelledSource {
 public:
  explicit SimulatedSource(sim::Simulator simulator, std::string name)
      : simulator_(std::move(simulator)), name_(std::move(name)) {}
  const std::string& name() const override { return name_; }
  int size() const override { return simulator_.frame_count(); }
  double fps() const override { return simulator_.fps(); }
  const StereoCamera& camera() const override { return simulator_.camera(); }
  Expected<LabelledFrame> read(int i) const override {
    if (i < 0 || i >= size()) {
      return make_error(ErrorCode::kInvalidArgument,
                        name_ + ": frame " + std::to_string(i) + " out of range");
    }
    sim::SimFrame f = simulator_.render(i);
    LabelledFrame out;
    out.frame.seq = i;
    out.frame.t_left_ns = f.t_ns;
    out.frame.t_right_ns = f.t_ns;
    out.frame.left = f.left;
    out.frame.right = f.right;
    out.frame.source_id = name_;
    out.instance_mask = f.instance_mask;
    out.T_world_cam_gt = f.T_world_cam;
    for (const sim::ObjectTruth& o : f.objects) {
      if (!o.visible) continue;
      out.objects.boxes.push_back({o.instance, o.class_name, 1.0, o.box});
      out.moving[o.instance] = o.moving;
    }
    out.objects.segment = segmenter_of(out.instance_mask);
    return out;
  }

 private:
  sim::Simulator simulator_;
  std::string name_;
};

class SequenceSource final : public LabelledSource {
 public:
  SequenceSource(std::unique_ptr<io::Sequence> sequence, double fps)
      : sequence_(std::move(sequence)), fps_(fps) {}
  const std::string& name() const override { return sequence_->directory(); }
  int size() const override { return static_cast<int>(sequence_->size()); }
  double fps() const override { return fps_; }
  const StereoCamera& camera() const override { return sequence_->camera(); }
  Expected<LabelledFrame> read(int i) const override {
    SITEPOSE_TRY(StereoFrame frame, sequence_->read_frame(static_cast<std::size_t>(i)));
    LabelledFrame out;
    out.frame = std::move(frame);
    if (sequence_->has_masks()) {
      SITEPOSE_TRY(cv::Mat mask, sequence_->read_instance_mask(static_cast<std::size_t>(i)));
      out.instance_mask = mask;
    }
    if (sequence_->has_gt()) out.T_world_cam_gt = sequence_->gt_poses()[i];
    for (const io::LabelBox& b : sequence_->boxes_for_frame(static_cast<std::size_t>(i))) {
      out.objects.boxes.push_back({static_cast<std::uint16_t>(b.instance), b.class_name, 1.0, b.box});
      if (b.moving) out.moving[static_cast<std::uint16_t>(b.instance)] = *b.moving;
    }
    out.objects.segment = segmenter_of(out.instance_mask);
    return out;
  }

 private:
  std::unique_ptr<io::Sequence> sequence_;
  double fps_;
};

class CachedSource final : public LabelledSource {
 public:
  explicit CachedSource(std::unique_ptr<LabelledSource> inner)
      : inner_(std::move(inner)), cache_(inner_->size()) {}
  const std::string& name() const override { return inner_->name(); }
  int size() const override { return inner_->size(); }
  double fps() const override { return inner_->fps(); }
  const StereoCamera& camera() const override { return inner_->camera(); }
  Expected<LabelledFrame> read(int i) const override {
    if (i >= 0 && i < size() && cache_[i]) return *cache_[i];
    SITEPOSE_TRY(LabelledFrame frame, inner_->read(i));
    cache_[i] = frame;
    return frame;
  }

 private:
  std::unique_ptr<LabelledSource> inner_;
  mutable std::vector<std::optional<LabelledFrame>> cache_;
};

}  // namespace

Expected<std::unique_ptr<LabelledSource>> open_simulated(const std::string& scenario_name, int frames,
                                                         std::optional<int> seed, std::optional<int> width,
                                                         std::optional<int> height,
                                                         std::optional<double> fps) {
  SITEPOSE_TRY(sim::Scenario scenario, sim::load_scenario(scenario_name));
  sim::SimOptions options;
  if (frames > 0) options.frames = frames;
  options.seed = seed;
  options.width = width;
  options.height = height;
  options.fps = fps;
  SITEPOSE_TRY(sim::Simulator simulator, sim::Simulator::create(scenario, options));
  if (simulator.distorted()) {
    return make_error(ErrorCode::kUnsupported, "scenario " + scenario_name +
                                                   " renders distorted images; write it with `sitepose "
                                                   "sim` and run the sequence instead");
  }
  return std::unique_ptr<LabelledSource>(new SimulatedSource(std::move(simulator), scenario.name));
}

Expected<std::unique_ptr<LabelledSource>> open_labelled_sequence(const std::string& directory,
                                                                 bool require_labels) {
  SITEPOSE_TRY(auto sequence, io::open_sequence(directory));
  if (require_labels && !sequence->has_labels()) {
    return make_error(ErrorCode::kInvalidArgument,
                      directory + ": no labels/boxes.csv; the dynamic layer's ablations need object labels");
  }
  double fps = io::mean_frame_rate_hz(*sequence);
  if (!(fps > 0.0)) fps = slam::SlamOptions{}.fps;
  return std::unique_ptr<LabelledSource>(new SequenceSource(std::move(sequence), fps));
}

std::unique_ptr<LabelledSource> cache_frames(std::unique_ptr<LabelledSource> source) {
  return std::make_unique<CachedSource>(std::move(source));
}

Status check_fps_for_source(bool from_sequence, std::optional<double> fps) {
  if (from_sequence && fps) {
    return make_error(
        ErrorCode::kInvalidArgument,
        "--fps renders a scenario at another rate; a recorded sequence (--sequence) keeps its own");
  }
  return ok_status();
}

Expected<std::unique_ptr<LabelledSource>> open_ablation_source(const SourceRequest& request,
                                                               std::string* written_dir) {
  if (request.sequence.empty() == request.scenario.empty()) {
    return make_error(ErrorCode::kInvalidArgument, "give exactly one of --sequence DIR and --scenario NAME");
  }
  SITEPOSE_TRY_STATUS(check_fps_for_source(!request.sequence.empty(), request.fps));
  std::string dir = request.sequence;
  if (!request.scenario.empty()) {
    SITEPOSE_TRY(sim::Scenario scenario, sim::load_scenario(request.scenario));
    sim::SimOptions options;
    if (request.frames > 0) options.frames = request.frames;
    options.fps = request.fps;
    SITEPOSE_TRY(sim::Simulator simulator, sim::Simulator::create(scenario, options));
    const fs::path base = request.temp_dir.empty()
                              ? fs::temp_directory_path() / ("sitepose-ablate-" + std::to_string(::getpid()))
                              : fs::path(request.temp_dir);
    dir = (base / scenario.name).string();
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) return make_error(ErrorCode::kIoError, "cannot create " + dir + ": " + ec.message());
    std::fprintf(stderr, "simulating %s (%d frames at %g frames/s) into %s\n", scenario.name.c_str(),
                 simulator.frame_count(), simulator.fps(), dir.c_str());
    SITEPOSE_TRY(sim::WriteSummary summary, sim::write_sequence(simulator, dir));
    (void)summary;
  }
  if (written_dir != nullptr) *written_dir = request.scenario.empty() ? "" : dir;
  SITEPOSE_TRY(auto source, open_labelled_sequence(dir));
  return cache_frames(std::move(source));
}

}  // namespace sitepose::experiments
