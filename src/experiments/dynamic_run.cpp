#include "sitepose/experiments/dynamic_run.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "sitepose/slam/detector_objects.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::experiments {

double DynamicRunResult::coverage_ok() const {
  return frames > 0 ? static_cast<double>(recorder.frames_ok()) / frames : 0.0;
}

double DynamicRunResult::ate_m() const {
  return evaluation ? evaluation->ate_m.rmse : std::numeric_limits<double>::quiet_NaN();
}

double DynamicRunResult::ate_max_m() const {
  return evaluation ? evaluation->ate_m.max : std::numeric_limits<double>::quiet_NaN();
}

Expected<DynamicRunResult> run_dynamic(const LabelledSource& source, const config::SiteposeConfig& config,
                                       const DynamicRunOptions& options) {
  slam::SlamOptions slam_options;
  slam_options.fps = source.fps();
  slam_options.mapper_thread = options.mapper_thread;
  slam_options.trace = options.trace;
  slam_options.vocabulary = options.vocabulary;
  SITEPOSE_TRY(auto system, slam::SlamSystem::create(source.camera(), config, slam_options));
  DynamicRunResult result;
  result.name = source.name();
  result.mode = config.dynamic.mode;
  result.frames = options.frames > 0 ? std::min(options.frames, source.size()) : source.size();
  for (int i = 0; i < result.frames; ++i) {
    if (options.stop && options.stop()) {
      result.frames = i;
      result.partial = true;
      break;
    }
    SITEPOSE_TRY(LabelledFrame frame, source.read(i));
    if (options.alter) options.alter(frame);
    if (options.detector != nullptr) {
      SITEPOSE_TRY(frame.objects, slam::detect_objects(*options.detector, frame.frame));
      frame.moving.clear();
    }
    SITEPOSE_TRY(slam::FrameReport report, system->process(frame.frame, frame.objects));
    result.recorder.add(report);
    result.max_masked_ratio = std::max(result.max_masked_ratio, report.masked_ratio);
    result.max_mar = std::max(result.max_mar, report.mar);
    if (frame.T_world_cam_gt) {
      result.ground_truth.push_back({static_cast<double>(frame.frame.t_ns()) * 1e-9, *frame.T_world_cam_gt});
    }
    if (report.pose.state != TrackingState::kLost) {
      result.estimate.push_back({static_cast<double>(report.pose.t_ns) * 1e-9, report.pose.T_world_cam});
    }
    for (const auto& o : report.objects) {
      ObjectSample s;
      s.frame = frame.frame.seq;
      if (const auto it = frame.moving.find(o.verdict.instance); it != frame.moving.end())
        s.moving_gt = it->second;
      s.object = o;
      result.samples.push_back(std::move(s));
    }
    if (options.on_frame) options.on_frame(i, result.frames, report);
  }
  system->finish();
  result.keyframes = system->keyframe_count();
  result.points = system->point_count();
  result.loop_stats = system->loop_stats();
  result.tracker_counters = system->tracker_counters();
  result.mapping = system->mapping_stats();
  if (result.ground_truth.size() < 3 || result.estimate.size() < 3) {
    result.evaluation_error = "fewer than 3 ground-truth or estimated poses";
    return result;
  }
  auto evaluation = eval::evaluate(result.ground_truth, result.estimate, eval::EvalOptions{});
  if (evaluation) {
    result.evaluation = std::move(*evaluation);
  } else {
    result.evaluation_error = evaluation.error().message;
  }
  return result;
}

std::vector<RemaskEvent> remask_latencies(const std::vector<ObjectSample>& samples) {
  std::map<std::uint16_t, std::vector<const ObjectSample*>> by_instance;
  for (const auto& s : samples) by_instance[s.object.verdict.instance].push_back(&s);
  std::vector<RemaskEvent> out;
  for (const auto& [instance, list] : by_instance) {
    bool was_static_gt = false;
    bool open = false;
    RemaskEvent event;
    for (const ObjectSample* s : list) {
      if (!s->moving_gt) continue;
      if (!open && !*s->moving_gt) {
        was_static_gt = true;
        continue;
      }
      if (!open && *s->moving_gt && was_static_gt) {
        open = true;
        event = {instance, s->frame, -1};
      }
      if (open && s->object.verdict.state != dynamic::MotionState::kStatic) {
        event.latency_frames = static_cast<int>(s->frame - event.start_frame);
        break;
      }
    }
    if (open) out.push_back(event);
  }
  return out;
}

std::vector<UnmaskEvent> unmask_latencies(const std::vector<ObjectSample>& samples, int min_points) {
  std::map<std::uint16_t, std::vector<const ObjectSample*>> by_instance;
  for (const auto& s : samples) {
    if (s.moving_gt) by_instance[s.object.verdict.instance].push_back(&s);
  }
  std::vector<UnmaskEvent> out;
  for (const auto& [instance, list] : by_instance) {
    bool was_moving = false;
    std::optional<UnmaskEvent> open;
    for (const ObjectSample* s : list) {
      if (*s->moving_gt) {
        if (open) {
          out.push_back(*open);
          open.reset();
        }
        was_moving = true;
        continue;
      }
      if (!was_moving) continue;  // parked from the start: not a stop
      if (!open) open = UnmaskEvent{instance, s->object.verdict.class_name, s->frame, 0, 0, -1};
      open->stop_frames = static_cast<int>(s->frame - open->stop_frame) + 1;
      if (open->latency_frames >= 0) continue;
      open->testable_frames += s->object.verdict.matched_points >= min_points ? 1 : 0;
      if (s->object.verdict.state == dynamic::MotionState::kStatic) {
        open->latency_frames = static_cast<int>(s->frame - open->stop_frame);
      }
    }
    if (open) out.push_back(*open);
  }
  return out;
}

int static_flips(const std::vector<ObjectSample>& samples, int min_points) {
  std::map<std::uint16_t, std::vector<const ObjectSample*>> by_instance;
  std::map<std::uint16_t, bool> ever_moving;
  for (const auto& s : samples) {
    by_instance[s.object.verdict.instance].push_back(&s);
    if (s.moving_gt && *s.moving_gt) ever_moving[s.object.verdict.instance] = true;
  }
  int flips = 0;
  for (const auto& [instance, list] : by_instance) {
    if (ever_moving[instance]) continue;
    bool seen_static = false;
    dynamic::MotionState last = dynamic::MotionState::kUnknown;
    for (const ObjectSample* s : list) {
      const dynamic::MotionState state = s->object.verdict.state;
      const bool evidence_gone =
          state == dynamic::MotionState::kUnknown && s->object.verdict.points < min_points;
      if (seen_static && state != last && !evidence_gone) ++flips;
      if (state == dynamic::MotionState::kStatic) seen_static = true;
      last = state;
    }
  }
  return flips;
}

}  // namespace sitepose::experiments
