#pragma once
// Runs the positioning core over a simulated scenario (rendered in-process,
// nothing written to disk) or a recorded sequence, and scores it against
// ground truth. Shared by the regression tests, `sitepose demo` and
// `sitepose bench track`, so they all measure the same thing.

#include <functional>
#include <optional>
#include <string>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/eval/evaluate.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/slam/run_recorder.hpp"

namespace sitepose::experiment {

struct TrackRunOptions {
  int frames = 0;                 // 0 = the whole scenario / sequence
  std::optional<int> seed;        // simulated scenarios only
  std::optional<int> width;       // simulated scenarios only (fx scales along)
  std::optional<int> height;
  bool mapper_thread = false;     // false = reproducible inline mapping
  // Called after every frame with (index, count, report); may print progress.
  std::function<void(int, int, const slam::FrameReport&)> on_frame;
  // Called after every frame with the process's resident set (bytes).
  std::function<void(int, std::int64_t)> on_memory;
};

struct TrackRunResult {
  std::string name;          // scenario or sequence directory
  int frames = 0;
  double fps_data = 0.0;     // frame rate of the data
  slam::RunRecorder recorder;
  io::Trajectory ground_truth;
  io::Trajectory estimate;   // poses not LOST
  std::optional<eval::EvalResult> evaluation;  // when ground truth exists and >= 3 poses
  std::string evaluation_error;                // why evaluation is empty
  std::size_t keyframes = 0;
  std::size_t points = 0;
  double render_ms_total = 0.0;  // simulated: rendering time (excluded from tracking times)

  double coverage_ok() const;  // frames tracked OK / frames
};

// `scenario`: a name in config/scenarios or a path to a scenario YAML.
Expected<TrackRunResult> track_scenario(const std::string& scenario,
                                        const config::SiteposeConfig& config,
                                        const TrackRunOptions& options = {});

// `directory`: a sequence readable by io::open_sequence.
Expected<TrackRunResult> track_sequence(const std::string& directory,
                                        const config::SiteposeConfig& config,
                                        const TrackRunOptions& options = {});

}  // namespace sitepose::experiment
