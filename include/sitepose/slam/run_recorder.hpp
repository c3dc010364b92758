#pragma once
// Collects the per-frame reports of a run and writes what FORMATS.md "Per-
// frame outputs of a run" asks for: the trajectory (TUM) and stats.json
// (frames, frames OK, per-stage p50/p99, mar per frame, pixel-mask calls,
// features per frame for pass 1 / pass 2, matches and those old keyframes
// observe per frame, peak RSS).

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/io/json_fwd.hpp"
#include "sitepose/io/trajectory.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::slam {

struct StageSummary {
  double p50_ms = 0.0;
  double p99_ms = 0.0;
  double mean_ms = 0.0;
  double max_ms = 0.0;
};

// p50/p99/mean/max of samples (nearest-rank percentiles); zeros when empty.
StageSummary summarize(std::vector<double> samples_ms);

// Peak resident set size of this process (VmHWM), bytes; 0 if unknown.
std::int64_t peak_rss_bytes();
// Current resident set size (VmRSS), bytes; 0 if unknown.
std::int64_t current_rss_bytes();

// One row of --states-out (FORMATS.md "Per-frame outputs of a run").
struct StateRow {
  std::int64_t frame = 0;
  std::uint16_t instance = 0;
  std::string class_name;
  dynamic::MotionState state = dynamic::MotionState::kUnknown;
  double score = 0.0;
  int points = 0;
  dynamic::UnknownReason reason = dynamic::UnknownReason::kNone;  // why state is unknown
};

class RunRecorder {
 public:
  // Records the pose and stage times; reports of the dynamic layer
  // (report.dynamic_layer) also add mar, the pixel-mask call, the dynamic
  // stages (detect, mask, classify, pass2) and one state row per object.
  void add(const FrameReport& report);
  // Extra per-frame figures from the dynamic layer, for callers that run
  // masking outside SlamSystem (add() records them itself otherwise).
  void add_dynamic(double masked_area_ratio, bool pixel_mask_used);

  int frames() const { return static_cast<int>(poses_.size()); }
  int frames_ok() const;
  const std::vector<PoseEstimate>& poses() const { return poses_; }
  std::map<std::string, StageSummary> stage_summaries() const;
  double frames_per_second() const;  // 1000 / mean whole-frame time

  // Poses that are not LOST, as TUM (t in seconds).
  Status write_tum(const std::string& path) const;
  // The same poses in `format` (io::write_trajectory).
  Status write_trajectory(const std::string& path, io::TrajectoryFormat format) const;
  // The frames write_trajectory writes, each at its pose in `final_poses`
  // (SlamSystem::poses_in_final_map of poses(), one per frame); a frame
  // without one is left out. Returns how many poses were written and how
  // many frames were left out.
  struct FinalTrajectoryCounts {
    int poses = 0;
    int left_out = 0;
  };
  Expected<FinalTrajectoryCounts> write_final_trajectory(
      const std::string& path, io::TrajectoryFormat format,
      const std::vector<std::optional<SE3>>& final_poses) const;
  // header frame,t_s,state; one row per frame tracked, LOST ones included,
  // so RECOVERING poses in the trajectory can be told from OK ones.
  Status write_tracking_states_csv(const std::string& path) const;
  // frames, frames_ok, per-stage times, per-frame features, states and mar.
  io::Json stats_json() const;
  // stats_json() with `extra_fields` (an object) added, to `path`.
  Status write_stats_json(const std::string& path, const io::Json& extra_fields) const;
  Status write_stats_json(const std::string& path) const;
  // header frame,instance,class,state,score,points,reason; one row per
  // object per frame of mode full (state = the smoothed state the run used;
  // reason = dynamic::to_string(UnknownReason), empty unless unknown).
  Status write_states_csv(const std::string& path) const;

  const std::vector<StateRow>& state_rows() const { return state_rows_; }
  const std::vector<double>& masked_area_ratios() const { return masked_area_ratio_; }
  int pixel_mask_calls() const { return pixel_mask_calls_; }
  // Frames whose pass 2 disagreed with pass 1 and was not used.
  int pass2_rejections() const { return pass2_rejections_; }
  int map_check_remasks() const { return map_check_remasks_; }
  // Sum over frames of each stage (ms), for time shares.
  double stage_total_ms(const std::string& stage) const;

 private:
  // The frames that are not LOST, at their tracked pose, or at
  // (*final_poses)[i] when given (a frame without one is counted in
  // *left_out and skipped).
  io::Trajectory trajectory(const std::vector<std::optional<SE3>>* final_poses = nullptr,
                            int* left_out = nullptr) const;

  std::vector<PoseEstimate> poses_;
  std::map<std::string, std::vector<double>> stage_ms_;
  std::vector<double> masked_area_ratio_;
  int pixel_mask_calls_ = 0;
  int pass2_rejections_ = 0;
  int map_check_remasks_ = 0;
  std::vector<StateRow> state_rows_;
};

}  // namespace sitepose::slam
