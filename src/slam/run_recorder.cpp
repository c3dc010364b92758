#include "sitepose/slam/run_recorder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numeric>
#include <sstream>

#include "sitepose/io/json_file.hpp"
#include "sitepose/io/trajectory.hpp"

namespace sitepose::slam {

StageSummary summarize(std::vector<double> samples_ms) {
  StageSummary s;
  if (samples_ms.empty()) return s;
  std::sort(samples_ms.begin(), samples_ms.end());
  const auto rank = [&](double q) {
    const std::size_t index = static_cast<std::size_t>(std::ceil(q * samples_ms.size())) - 1;
    return samples_ms[std::min(index, samples_ms.size() - 1)];
  };
  s.p50_ms = rank(0.50);
  s.p99_ms = rank(0.99);
  s.mean_ms = std::accumulate(samples_ms.begin(), samples_ms.end(), 0.0) / samples_ms.size();
  s.max_ms = samples_ms.back();
  return s;
}

namespace {
std::int64_t read_status_kb(const char* key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  const std::string prefix = std::string(key) + ":";
  while (std::getline(status, line)) {
    if (line.rfind(prefix, 0) == 0) {
      std::istringstream in(line.substr(prefix.size()));
      std::int64_t kb = 0;
      in >> kb;
      return kb;
    }
  }
  return 0;
}
}  // namespace

std::int64_t peak_rss_bytes() { return read_status_kb("VmHWM") * 1024; }
std::int64_t current_rss_bytes() { return read_status_kb("VmRSS") * 1024; }

void RunRecorder::add(const FrameReport& report) {
  poses_.push_back(report.pose);
  const FrameTimings& t = report.timings;
  stage_ms_["extract_left"].push_back(t.extract_left_ms);
  stage_ms_["extract_right"].push_back(t.extract_right_ms);
  stage_ms_["stereo_match"].push_back(t.stereo_match_ms);
  stage_ms_["track_motion_model"].push_back(t.motion_model_ms);
  stage_ms_["track_local_map"].push_back(t.local_map_ms);
  stage_ms_["motion_only_ba"].push_back(t.motion_ba_ms);
  stage_ms_["mapping_inline"].push_back(t.mapping_inline_ms);
  stage_ms_["whole_frame"].push_back(t.total_ms);
  if (!report.dynamic_layer) return;
  pass2_rejections_ += report.pass2_rejected ? 1 : 0;
  map_check_remasks_ += report.remasked_by_map_check;
  stage_ms_["detect"].push_back(t.detect_ms);
  stage_ms_["mask"].push_back(t.mask_ms);
  stage_ms_["segment"].push_back(t.segment_ms);
  stage_ms_["mask_overrun"].push_back(t.mask_overrun_ms);
  // Our share of the frame: a detector plugin's own time varies with it.
  // Its segmentation runs beside the pyramids; only the part the frame
  // waited for counts as the detector's.
  stage_ms_["frame_excl_detector"].push_back(t.total_ms - t.detect_ms -
                                             std::min(t.segment_ms, t.mask_overrun_ms));
  stage_ms_["classify"].push_back(t.classify_ms);
  stage_ms_["pass2"].push_back(t.pass2_ms);
  add_dynamic(report.mar, report.pixel_mask_used);
  for (const auto& o : report.objects) {
    state_rows_.push_back({report.pose.seq, o.verdict.instance, o.verdict.class_name, o.verdict.state,
                           o.verdict.score, o.verdict.points, o.verdict.unknown_reason});
  }
}

double RunRecorder::stage_total_ms(const std::string& stage) const {
  const auto it = stage_ms_.find(stage);
  if (it == stage_ms_.end()) return 0.0;
  return std::accumulate(it->second.begin(), it->second.end(), 0.0);
}

Status RunRecorder::write_states_csv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path);
  out << "frame,instance,class,state,score,points,reason\n";
  char score[32];
  for (const StateRow& r : state_rows_) {
    std::snprintf(score, sizeof(score), "%.4f", r.score);
    out << r.frame << ',' << r.instance << ',' << r.class_name << ',' << dynamic::to_string(r.state) << ','
        << score << ',' << r.points << ',' << dynamic::to_string(r.reason) << '\n';
  }
  out.close();  // the buffered rest is written here: a full disk shows only now
  if (!out) return make_error(ErrorCode::kIoError, "write failed: " + path);
  return ok_status();
}

void RunRecorder::add_dynamic(double masked_area_ratio, bool pixel_mask_used) {
  masked_area_ratio_.push_back(masked_area_ratio);
  pixel_mask_calls_ += pixel_mask_used ? 1 : 0;
}

int RunRecorder::frames_ok() const {
  return static_cast<int>(std::count_if(poses_.begin(), poses_.end(),
                                        [](const PoseEstimate& p) { return p.state == TrackingState::kOk; }));
}

std::map<std::string, StageSummary> RunRecorder::stage_summaries() const {
  std::map<std::string, StageSummary> out;
  for (const auto& [name, samples] : stage_ms_) out[name] = summarize(samples);
  return out;
}

double RunRecorder::frames_per_second() const {
  const auto it = stage_ms_.find("whole_frame");
  if (it == stage_ms_.end() || it->second.empty()) return 0.0;
  const double mean = summarize(it->second).mean_ms;
  return mean > 0.0 ? 1000.0 / mean : 0.0;
}

Status RunRecorder::write_tum(const std::string& path) const {
  return write_trajectory(path, io::TrajectoryFormat::kTum);
}

io::Trajectory RunRecorder::trajectory(const std::vector<std::optional<SE3>>* final_poses,
                                       int* left_out) const {
  io::Trajectory trajectory;
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    const PoseEstimate& p = poses_[i];
    if (p.state == TrackingState::kLost) continue;
    if (final_poses != nullptr && !(*final_poses)[i]) {
      ++*left_out;
      continue;
    }
    trajectory.push_back(
        {static_cast<double>(p.t_ns) * 1e-9, final_poses != nullptr ? *(*final_poses)[i] : p.T_world_cam});
  }
  return trajectory;
}

Status RunRecorder::write_trajectory(const std::string& path, io::TrajectoryFormat format) const {
  return io::write_trajectory(path, trajectory(), format);
}

Expected<RunRecorder::FinalTrajectoryCounts> RunRecorder::write_final_trajectory(
    const std::string& path, io::TrajectoryFormat format,
    const std::vector<std::optional<SE3>>& final_poses) const {
  if (final_poses.size() != poses_.size()) {
    return make_error(ErrorCode::kInvalidArgument, "final trajectory: " + std::to_string(final_poses.size()) +
                                                       " final poses for " + std::to_string(poses_.size()) +
                                                       " frames");
  }
  FinalTrajectoryCounts counts;
  const io::Trajectory final_trajectory = trajectory(&final_poses, &counts.left_out);
  counts.poses = static_cast<int>(final_trajectory.size());
  SITEPOSE_TRY_STATUS(io::write_trajectory(path, final_trajectory, format));
  return counts;
}

Status RunRecorder::write_tracking_states_csv(const std::string& path) const {
  std::ofstream out(path);
  if (!out) return make_error(ErrorCode::kIoError, "cannot write " + path);
  out << "frame,t_s,state\n";
  char t_s[32];
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    std::snprintf(t_s, sizeof(t_s), "%.9f", static_cast<double>(poses_[i].t_ns) * 1e-9);
    out << i << ',' << t_s << ',' << to_string(poses_[i].state) << '\n';
  }
  out.close();  // the buffered rest is written here: a full disk shows only now
  if (!out) return make_error(ErrorCode::kIoError, "write failed: " + path);
  return ok_status();
}

namespace {
// Four decimals, as the figures mean no more (and the file stays short).
double round4(double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 : v; }
}  // namespace

io::Json RunRecorder::stats_json() const {
  io::Json stages = io::Json::object();
  for (const auto& [name, s] : stage_summaries()) {
    stages[name] = {{"p50", round4(s.p50_ms)},
                    {"p99", round4(s.p99_ms)},
                    {"mean", round4(s.mean_ms)},
                    {"max", round4(s.max_ms)}};
  }
  io::Json pass1 = io::Json::array(), pass2 = io::Json::array(), states = io::Json::array(),
           mar = io::Json::array(), matches = io::Json::array(), old_matches = io::Json::array();
  for (const PoseEstimate& p : poses_) {
    pass1.push_back(p.counters.features_used_pass1);
    pass2.push_back(p.counters.features_used);
    states.push_back(to_string(p.state));
    matches.push_back(p.counters.matches);
    old_matches.push_back(p.counters.matches_from_old_keyframes);
  }
  for (double r : masked_area_ratio_) mar.push_back(round4(r));
  return io::Json{{"frames", frames()},
                  {"frames_ok", frames_ok()},
                  {"frames_per_second", round4(frames_per_second())},
                  {"stages_ms", stages},
                  {"features_pass1", pass1},
                  {"features_pass2", pass2},
                  {"matches", matches},
                  {"matches_from_old_keyframes", old_matches},
                  {"states", states},
                  {"mar", mar},
                  {"pixel_mask_calls", pixel_mask_calls_},
                  {"pass2_rejected", pass2_rejections_},
                  {"remasked_by_map_check", map_check_remasks_},
                  {"peak_rss_bytes", peak_rss_bytes()}};
}

Status RunRecorder::write_stats_json(const std::string& path) const {
  return io::write_json_file(path, stats_json());
}

Status RunRecorder::write_stats_json(const std::string& path, const io::Json& extra_fields) const {
  io::Json json = stats_json();
  for (const auto& [key, value] : extra_fields.items()) json[key] = value;
  return io::write_json_file(path, json);
}

}  // namespace sitepose::slam
