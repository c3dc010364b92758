#pragma once
// One run of the positioning core over a LabelledSource in a given masking
// mode, scored against ground truth: ATE (eval module), coverage, the
// motion-state samples with their ground-truth flags (ROC: roc.hpp,
// re-masking latency). Shared by the regression tests, the ablations and
// `sitepose bench dynamic`. Inline mapping: reproducible.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/eval/evaluate.hpp"
#include "sitepose/experiments/labelled_source.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/loop/loop_closer.hpp"
#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/placerec/vocabulary.hpp"
#include "sitepose/slam/run_recorder.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::experiments {

struct DynamicRunOptions {
  int frames = 0;  // 0 = all of the source
  // Local mapping on its own thread as in the daemon; false = inline after
  // each frame, which makes runs reproducible.
  bool mapper_thread = false;
  // Changes a frame before tracking (e.g. the occlusion sweep paints a
  // fake occluder and its box into it).
  std::function<void(LabelledFrame&)> alter;
  std::function<void(int, int, const slam::FrameReport&)> on_frame;
  // Polled before each frame; true ends the run there (result.partial).
  std::function<bool()> stop;
  // When set, its detections replace the source's labels (e.g. the
  // weight-free stereo-geometric detector); motion-state samples then carry
  // no ground truth (its instance ids are not the labels').
  detect::Detector* detector = nullptr;
  // Fill FrameReport::trace for the views (slam::SlamOptions::trace).
  bool trace = false;
  // Place recognition (slam::SlamOptions::vocabulary); with
  // config.mapping.loop_closing it also runs the loop closer.
  std::shared_ptr<const placerec::Vocabulary> vocabulary;
};

// A classified object with its ground truth, for ROC and latency figures.
struct ObjectSample {
  std::int64_t frame = 0;
  std::optional<bool> moving_gt;
  dynamic::ClassifiedObject object;
};

struct DynamicRunResult {
  std::string name;
  config::MaskingMode mode = config::MaskingMode::kNone;
  int frames = 0;        // frames tracked
  bool partial = false;  // DynamicRunOptions::stop ended the run early
  slam::RunRecorder recorder;
  io::Trajectory ground_truth;
  io::Trajectory estimate;  // poses not LOST
  std::optional<eval::EvalResult> evaluation;
  std::string evaluation_error;
  std::vector<ObjectSample> samples;  // mode full only
  double max_masked_ratio = 0.0;      // largest masked pixel fraction of a frame
  double max_mar = 0.0;
  std::size_t keyframes = 0;  // in the map at the end of the run
  std::size_t points = 0;
  std::optional<loop::LoopClosingStats> loop_stats;  // when the loop closer ran
  tracking::TrackerCounters tracker_counters;        // at the end of the run
  mapping::MappingStats mapping;                     // at the end of the run

  double coverage_ok() const;  // frames OK / frames
  double ate_m() const;        // RMSE, NaN without evaluation
  double ate_max_m() const;    // largest error, NaN without evaluation
};

Expected<DynamicRunResult> run_dynamic(const LabelledSource& source, const config::SiteposeConfig& config,
                                       const DynamicRunOptions& options = {});

// Latency (frames) from the first ground-truth moving frame of each instance
// that was static in every earlier frame to the first frame its state is not
// static (masked again); one entry per such start, -1 = never re-masked
// while visible.
struct RemaskEvent {
  std::uint16_t instance = 0;
  std::int64_t start_frame = 0;
  int latency_frames = -1;
};
std::vector<RemaskEvent> remask_latencies(const std::vector<ObjectSample>& samples);

// The other direction: from the first ground-truth static frame after a
// moving one (a machine stops) to the first frame its state is static
// (unmasked, usable in pass 2). One entry per stop; the stop lasts until the
// instance's next ground-truth moving frame or its last sample.
struct UnmaskEvent {
  std::uint16_t instance = 0;
  std::string class_name;
  std::int64_t stop_frame = 0;
  int stop_frames = 0;      // frames from the stop to its end (or the last sample)
  int testable_frames = 0;  // stop samples up to the unmasking one with >= min_points matched points
  int latency_frames = -1;  // -1 = still masked when the stop ended
};
std::vector<UnmaskEvent> unmask_latencies(const std::vector<ObjectSample>& samples, int min_points);

// State changes of objects that are static in the ground truth for the
// whole run, after their first static verdict (flicker). A change to
// unknown in a frame where the object has fewer than `min_points` matched
// points is not counted: the machine left the view or is hidden, and there
// is nothing left to test (it is counted again if it turns static anew).
int static_flips(const std::vector<ObjectSample>& samples, int min_points);

}  // namespace sitepose::experiments
