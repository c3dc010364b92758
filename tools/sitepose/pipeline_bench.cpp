#include "pipeline_bench.hpp"

#include <algorithm>
#include <chrono>

#include "sitepose/io/sequence.hpp"
#include "sitepose/pipeline/detect_stage.hpp"

namespace sitepose::cli {

Expected<MemorySequence> load_memory_sequence(const std::string& dir, std::size_t max_frames) {
  SITEPOSE_TRY(auto sequence, io::open_sequence(dir));
  const std::size_t n = max_frames > 0 ? std::min(max_frames, sequence->size()) : sequence->size();
  MemorySequence loaded;
  for (std::size_t i = 0; i < n; ++i) {
    SITEPOSE_TRY(auto frame, sequence->read_frame(i));
    loaded.frames.push_back(std::move(frame));
  }
  loaded.camera = sequence->camera();
  loaded.recorded_fps = io::mean_frame_rate_hz(*sequence, n);
  return loaded;
}

Expected<std::unique_ptr<pipeline::Pipeline>> make_bench_pipeline(
    const config::SiteposeConfig& config, const StereoCamera& camera, const std::string& sequence_dir,
    std::unique_ptr<pipeline::FrameSource> source, std::unique_ptr<pipeline::SlamPoseTracker> tracker,
    std::unique_ptr<pipeline::PoseOutput> output) {
  SITEPOSE_TRY(auto detect_hook, pipeline::make_detect_hook(config, {sequence_dir, camera}));
  std::vector<std::unique_ptr<pipeline::PoseOutput>> outputs;
  outputs.push_back(std::move(output));
  return pipeline::Pipeline::create(pipeline::PipelineOptions{}, std::move(source), std::move(detect_hook),
                                    std::move(tracker), std::move(outputs));
}

double publish_latency_ms(const pipeline::PosePacket& packet) {
  return std::chrono::duration<double, std::milli>(pipeline::SteadyClock::now() - packet.captured).count();
}

}  // namespace sitepose::cli
