#include "sitepose/slam/slam_system.hpp"

#include <chrono>

#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/features/stereo_matcher.hpp"

namespace sitepose::slam {
namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}
}  // namespace

Expected<std::unique_ptr<SlamSystem>> SlamSystem::create(const StereoCamera& camera,
                                                         const config::SiteposeConfig& config,
                                                         const SlamOptions& options) {
  SITEPOSE_TRY_STATUS(camera.validate());
  SITEPOSE_TRY_STATUS(features::validate(config.orb));
  SITEPOSE_TRY_STATUS(features::validate(config.stereo));
  return std::unique_ptr<SlamSystem>(new SlamSystem(camera, config, options));
}

SlamSystem::SlamSystem(const StereoCamera& camera, const config::SiteposeConfig& config,
                       const SlamOptions& options)
    : config_(config),
      options_(options),
      map_(map::ScalePyramid{config.orb.scale_factor, config.orb.n_levels}) {
  mapper_ = std::make_unique<mapping::LocalMapper>(camera, config.mapping, config.tracking, map_);
  tracking::MapperLink link;
  if (config.mapping.enabled) {
    link.enqueue = [this](map::KeyFrameId id) { mapper_->enqueue(id); };
    link.queue_size = [this] { return static_cast<int>(mapper_->queue_size()); };
    link.is_idle = [this] { return mapper_->is_idle(); };
  }
  tracker_ = std::make_unique<tracking::Tracker>(camera, config, map_, std::move(link));
  if (options_.mapper_thread && config.mapping.enabled) mapper_->start();
}

SlamSystem::~SlamSystem() { finish(); }

void SlamSystem::finish() {
  if (mapper_->running()) {
    mapper_->wait_until_idle();
    mapper_->stop();
  }
}

Expected<FrameReport> SlamSystem::process(const StereoFrame& frame) {
  const auto start = Clock::now();
  SITEPOSE_TRY(tracking::PreparedFrame prepared, tracker_->prepare(frame));
  const std::vector<std::uint8_t> usable(prepared.size(), 1);
  const tracking::PassResult result = tracker_->estimate(prepared, usable);
  FrameReport report;
  report.pose = tracker_->commit(prepared, result, usable);
  report.timings.extract_left_ms = prepared.timings.extract_left_ms;
  report.timings.extract_right_ms = prepared.timings.extract_right_ms;
  report.timings.stereo_match_ms = prepared.timings.stereo_match_ms;
  report.timings.prepare_ms = prepared.timings.total_ms;
  report.timings.motion_model_ms = result.timings.motion_model_ms;
  report.timings.local_map_ms = result.timings.local_map_ms;
  report.timings.motion_ba_ms = result.timings.motion_ba_ms;
  report.timings.total_ms = ms_since(start);
  if (!options_.mapper_thread && config_.mapping.enabled) {
    const auto mapping_start = Clock::now();
    if (auto st = mapper_->process_pending(); !st) return Unexpected{st.error()};
    report.timings.mapping_inline_ms = ms_since(mapping_start);
  }
  return report;
}

std::size_t SlamSystem::keyframe_count() const {
  return map_.read([](const map::MapData& map) { return map.keyframe_count(); });
}

std::size_t SlamSystem::point_count() const {
  return map_.read([](const map::MapData& map) { return map.point_count(); });
}

}  // namespace sitepose::slam
