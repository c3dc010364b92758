#include "sitepose/experiment/track_run.hpp"

#include <chrono>

#include "sitepose/io/sequence.hpp"
#include "sitepose/sim/scenario.hpp"
#include "sitepose/sim/simulator.hpp"
#include "sitepose/slam/slam_system.hpp"

namespace sitepose::experiment {
namespace {

using Clock = std::chrono::steady_clock;

// Frames come from a callback so simulated and recorded data share the loop.
struct FrameProvider {
  int count = 0;
  std::function<Expected<StereoFrame>(int)> frame;
  std::function<std::optional<SE3>(int)> gt_T_world_cam;
};

Expected<TrackRunResult> run(const FrameProvider& provider, const StereoCamera& camera,
                             const config::SiteposeConfig& config, const TrackRunOptions& options,
                             TrackRunResult result) {
  SITEPOSE_TRY(auto system, slam::SlamSystem::create(camera, config, {options.mapper_thread}));
  result.frames = provider.count;
  for (int i = 0; i < provider.count; ++i) {
    const auto render_start = Clock::now();
    SITEPOSE_TRY(StereoFrame frame, provider.frame(i));
    result.render_ms_total +=
        std::chrono::duration<double, std::milli>(Clock::now() - render_start).count();
    SITEPOSE_TRY(slam::FrameReport report, system->process(frame));
    result.recorder.add(report);
    if (auto gt = provider.gt_T_world_cam(i)) {
      result.ground_truth.push_back({static_cast<double>(frame.t_ns()) * 1e-9, *gt});
    }
    if (report.pose.state != TrackingState::kLost) {
      result.estimate.push_back({static_cast<double>(report.pose.t_ns) * 1e-9, report.pose.T_world_cam});
    }
    if (options.on_frame) options.on_frame(i, provider.count, report);
    if (options.on_memory) options.on_memory(i, slam::current_rss_bytes());
  }
  system->finish();
  result.keyframes = system->keyframe_count();
  result.points = system->point_count();
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

}  // namespace

double TrackRunResult::coverage_ok() const {
  return frames > 0 ? static_cast<double>(recorder.frames_ok()) / frames : 0.0;
}

Expected<TrackRunResult> track_scenario(const std::string& scenario_name,
                                        const config::SiteposeConfig& config,
                                        const TrackRunOptions& options) {
  SITEPOSE_TRY(sim::Scenario scenario, sim::load_scenario(scenario_name));
  sim::SimOptions sim_options;
  if (options.frames > 0) sim_options.frames = options.frames;
  sim_options.seed = options.seed;
  sim_options.width = options.width;
  sim_options.height = options.height;
  SITEPOSE_TRY(sim::Simulator simulator, sim::Simulator::create(scenario, sim_options));
  if (simulator.distorted()) {
    return make_error(ErrorCode::kUnsupported,
                      "scenario " + scenario_name +
                          " renders distorted images; track it from a written sequence instead");
  }
  FrameProvider provider;
  provider.count = simulator.frame_count();
  // The simulator renders frame i once; keep its pose for the ground truth.
  auto last_pose = std::make_shared<std::optional<SE3>>();
  provider.frame = [&simulator, last_pose, &scenario_name](int i) -> Expected<StereoFrame> {
    sim::SimFrame sim_frame = simulator.render(i);
    *last_pose = sim_frame.T_world_cam;
    StereoFrame frame;
    frame.seq = i;
    frame.t_left_ns = sim_frame.t_ns;
    frame.t_right_ns = sim_frame.t_ns;
    frame.left = sim_frame.left;
    frame.right = sim_frame.right;
    frame.source_id = "sim:" + scenario_name;
    return frame;
  };
  provider.gt_T_world_cam = [last_pose](int) { return *last_pose; };
  TrackRunResult result;
  result.name = scenario_name;
  result.fps_data = simulator.fps();
  return run(provider, simulator.camera(), config, options, std::move(result));
}

Expected<TrackRunResult> track_sequence(const std::string& directory,
                                        const config::SiteposeConfig& config,
                                        const TrackRunOptions& options) {
  SITEPOSE_TRY(auto sequence, io::open_sequence(directory));
  FrameProvider provider;
  provider.count = static_cast<int>(sequence->size());
  if (options.frames > 0) provider.count = std::min(provider.count, options.frames);
  const io::Sequence* seq = sequence.get();
  provider.frame = [seq](int i) { return seq->read_frame(static_cast<std::size_t>(i)); };
  provider.gt_T_world_cam = [seq](int i) -> std::optional<SE3> {
    if (!seq->has_gt()) return std::nullopt;
    return seq->gt_poses()[static_cast<std::size_t>(i)];
  };
  TrackRunResult result;
  result.name = directory;
  if (seq->size() > 1) {
    result.fps_data = 1e9 * static_cast<double>(seq->size() - 1) /
                      static_cast<double>(seq->time_ns(seq->size() - 1) - seq->time_ns(0));
  }
  StereoCamera camera = seq->camera();
  if (config.camera.stereo) camera = *config.camera.stereo;
  return run(provider, camera, config, options, std::move(result));
}

}  // namespace sitepose::experiment
