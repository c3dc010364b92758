#pragma once
// What the benches that run the daemon's pipeline (bench pipeline, bench
// soak) share: the recorded sequence held in memory, the pipeline put
// together as siteposed does, and the latency they measure.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/pipeline/pipeline.hpp"
#include "sitepose/pipeline/slam_tracker.hpp"

namespace sitepose::cli {

// Decoded frames, so that PNG decoding is not part of what is timed.
struct MemorySequence {
  std::vector<StereoFrame> frames;
  StereoCamera camera;        // the sequence's calibration
  double recorded_fps = 0.0;  // mean frame rate of the frames held
};

// The first `max_frames` frames of the sequence in `dir` (0 = all). Errors
// are the sequence's (the folder, or the frame that cannot be read).
Expected<MemorySequence> load_memory_sequence(const std::string& dir, std::size_t max_frames);

// The pipeline over `source` with `tracker`, the detector of `config` (its
// labels from `sequence_dir`) and `output` as the only output.
Expected<std::unique_ptr<pipeline::Pipeline>> make_bench_pipeline(
    const config::SiteposeConfig& config, const StereoCamera& camera, const std::string& sequence_dir,
    std::unique_ptr<pipeline::FrameSource> source, std::unique_ptr<pipeline::SlamPoseTracker> tracker,
    std::unique_ptr<pipeline::PoseOutput> output);

// Frame-to-publish latency of a pose being published: from the source's
// hand-over of its frame to now.
double publish_latency_ms(const pipeline::PosePacket& packet);

}  // namespace sitepose::cli
