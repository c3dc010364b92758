#include "sitepose/slam/slam_system.hpp"

#include <cmath>

#include "sitepose/core/stopwatch.hpp"
#include "sitepose/features/orb_extractor.hpp"
#include "sitepose/features/stereo_matcher.hpp"

namespace sitepose::slam {
namespace {

// Candidate places tried per relocalisation (as many as the exact vote's
// default, tracking::PlaceQuery::max_candidates).
constexpr int kMaxRelocalisationCandidates = 5;

}  // namespace

Expected<std::unique_ptr<SlamSystem>> SlamSystem::create(const StereoCamera& camera,
                                                         const config::SiteposeConfig& config,
                                                         const SlamOptions& options) {
  SITEPOSE_TRY_STATUS(camera.validate());
  SITEPOSE_TRY_STATUS(features::validate(config.orb));
  SITEPOSE_TRY_STATUS(features::validate(config.stereo));
  if (!(options.fps > 0.0)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "slam options: fps = " + std::to_string(options.fps) + ": must be > 0");
  }
  if (options.vocabulary && !config.mapping.enabled) {
    // Keyframes enter the database when the mapper has processed them:
    // without it relocalisation would never find a candidate.
    return make_error(ErrorCode::kInvalidArgument,
                      "slam options: a place-recognition vocabulary needs mapping.enabled: true");
  }
  return std::unique_ptr<SlamSystem>(new SlamSystem(camera, config, options));
}

SlamSystem::SlamSystem(const StereoCamera& camera, const config::SiteposeConfig& config,
                       const SlamOptions& options)
    : config_(config),
      options_(options),
      map_(map::ScalePyramid{config.orb.scale_factor, config.orb.n_levels}) {
  if (options.keep_removed_keyframe_links)
    map_.write([](map::MapData& map) { map.keep_removed_keyframe_links(true); });
  mapper_ = std::make_unique<mapping::LocalMapper>(camera, config.mapping, config.tracking, map_);
  if (options.vocabulary) {
    database_ = std::make_unique<placerec::KeyFrameDatabase>(options.vocabulary);
    mapping::KeyFrameListener listener{
        [this](map::KeyFrameId id, const std::vector<map::Descriptor>& d) { database_->add(id, d); },
        [this](map::KeyFrameId id) { database_->erase(id); }, nullptr};
    if (config.mapping.loop_closing) {
      loop::MapperPause pause;
      if (options_.mapper_thread) {
        pause.pause = [this] { mapper_->pause(); };
        pause.resume = [this] { mapper_->resume(); };
      }
      closer_ = std::make_unique<loop::LoopCloser>(camera, map_, *database_, std::move(pause));
      listener.processed = [this](map::KeyFrameId id) { closer_->enqueue(id); };
    }
    mapper_->set_keyframe_listener(std::move(listener));
  }
  tracking::MapperLink link;
  if (config.mapping.enabled) {
    link.enqueue = [this](map::KeyFrameId id) { mapper_->enqueue(id); };
    link.queue_size = [this] { return static_cast<int>(mapper_->queue_size()); };
    link.is_idle = [this] { return mapper_->is_idle(); };
    if (options_.mapper_thread) {
      link.pause = [this] { mapper_->pause(); };
      link.resume = [this] { mapper_->resume(); };
    }
    if (database_) link.removed = [this](map::KeyFrameId id) { database_->erase(id); };
  }
  features::TaskPool* pool = options.extraction_pool;
  if (pool == nullptr) {
    own_pool_ = std::make_unique<features::TaskPool>(1);
    pool = own_pool_.get();
  }
  tracker_ = std::make_unique<tracking::Tracker>(camera, config, map_, std::move(link), pool);
  if (database_) {
    tracker_->set_place_source([this](const map::SharedMap& map, const cv::Mat& descriptors,
                                      const std::vector<std::uint8_t>& usable, map::KeyFrameId only_before) {
      std::vector<map::KeyFrameId> candidates = placerec::relocalisation_candidates(
          *database_, map, descriptors, usable, kMaxRelocalisationCandidates, {}, only_before);
      ++place_queries_.queries;
      place_queries_.candidates += static_cast<long>(candidates.size());
      return candidates;
    });
  }
  two_pass_ = std::make_unique<TwoPassTracker>(*tracker_, camera, config, options.fps, options.trace);
  if (options_.mapper_thread && config.mapping.enabled) {
    mapper_->start();
    if (closer_) closer_->start();
  }
}

SlamSystem::~SlamSystem() { finish(); }

void SlamSystem::finish() {
  if (mapper_->running()) {
    mapper_->wait_until_idle();
    if (closer_) closer_->wait_until_idle();  // it may pause the mapper: stopped after it
    mapper_->stop();
  }
  if (closer_ && closer_->running()) closer_->stop();
}

std::optional<loop::LoopClosingStats> SlamSystem::loop_stats() const {
  if (!closer_) return std::nullopt;
  return closer_->stats();
}

void SlamSystem::take_loop_correction() {
  if (!closer_) return;
  if (const std::optional<SE3> correction = closer_->take_tracker_correction(); correction) {
    tracker_->apply_map_correction(*correction);
  }
}

Expected<FrameReport> SlamSystem::process(const StereoFrame& frame) {
  take_loop_correction();
  const auto start = SteadyClock::now();
  SITEPOSE_TRY(tracking::PreparedFrame prepared, tracker_->prepare(frame));
  const std::vector<std::uint8_t> usable(prepared.size(), 1);
  const tracking::PassResult result = tracker_->estimate(prepared, usable);
  FrameReport report;
  report.pose = tracker_->commit(prepared, result, usable);
  copy_stage_timings(prepared, result, report.timings);
  report.timings.total_ms = ms_since(start);
  if (options_.trace) {
    const auto trace_start = SteadyClock::now();
    report.trace.keypoints = trace_keypoints(prepared, usable, result);
    report.trace.fill_ms = ms_since(trace_start);
  }
  SITEPOSE_TRY_STATUS(run_inline_mapping(report));
  fill_map_trace(report);
  return report;
}

void SlamSystem::fill_map_trace(FrameReport& report) const {
  if (!options_.trace) return;
  const auto start = SteadyClock::now();
  report.trace.keyframes_in_map = keyframe_count();
  report.trace.points_in_map = point_count();
  report.trace.keyframes_created = tracker_->counters().keyframes_created;
  report.trace.fill_ms += ms_since(start);
}

Status SlamSystem::run_inline_mapping(FrameReport& report) {
  if (!options_.mapper_thread && config_.mapping.enabled) {
    const auto mapping_start = SteadyClock::now();
    if (auto st = mapper_->process_pending(); !st) return Unexpected{st.error()};
    if (closer_) {
      if (auto st = closer_->process_pending(); !st) return Unexpected{st.error()};
      take_loop_correction();
    }
    report.timings.mapping_inline_ms = ms_since(mapping_start);
  }
  return ok_status();
}

Expected<FrameReport> SlamSystem::process(const StereoFrame& frame, const dynamic::FrameObjects& objects) {
  if (config_.dynamic.mode == config::MaskingMode::kNone) {
    SITEPOSE_TRY(FrameReport report, process(frame));
    report.dynamic_layer = true;
    // Nothing is masked, but mar is reported as in the other modes.
    SITEPOSE_TRY(const dynamic::MaskResult mask, dynamic::build_mask(config::MaskingMode::kNone, objects,
                                                                     frame.left.size(), config_.dynamic));
    report.mar = mask.mar;
    report.pose.counters.masked_area_ratio = report.mar;
    if (options_.trace) report.trace.boxes = mask.dynamic_boxes;
    return report;
  }
  take_loop_correction();
  SITEPOSE_TRY(FrameReport report, two_pass_->process(frame, objects));
  SITEPOSE_TRY_STATUS(run_inline_mapping(report));
  fill_map_trace(report);
  return report;
}

Status SlamSystem::load_map(map::MapData loaded) {
  if (tracker_->counters().frames > 0) {
    return make_error(ErrorCode::kInvalidArgument, "a map can be loaded only before the first frame");
  }
  const map::ScalePyramid expected{config_.orb.scale_factor, config_.orb.n_levels};
  const map::ScalePyramid& got = loaded.pyramid();
  if (got.n_levels != expected.n_levels || std::abs(got.scale_factor - expected.scale_factor) > 1e-9) {
    return make_error(ErrorCode::kInvalidArgument,
                      "the map was built with an ORB pyramid of " + std::to_string(got.n_levels) +
                          " levels, factor " + std::to_string(got.scale_factor) +
                          "; this configuration has " + std::to_string(expected.n_levels) +
                          " levels, factor " + std::to_string(expected.scale_factor));
  }
  if (database_) database_->rebuild(loaded);  // not under the map lock (a leaf lock)
  loaded.keep_removed_keyframe_links(options_.keep_removed_keyframe_links);
  map_.write([&](map::MapData& map) { map = std::move(loaded); });
  return ok_status();
}

std::string SlamSystem::vocabulary_id() const { return database_ ? database_->vocabulary().id() : ""; }

map::MapData SlamSystem::copy_map() const {
  return map_.read([](const map::MapData& map) { return map; });
}

std::size_t SlamSystem::keyframe_count() const {
  return map_.read([](const map::MapData& map) { return map.keyframe_count(); });
}

std::size_t SlamSystem::point_count() const {
  return map_.read([](const map::MapData& map) { return map.point_count(); });
}

std::vector<std::optional<SE3>> SlamSystem::poses_in_final_map(const std::vector<PoseEstimate>& poses) const {
  return map_.read([&](const map::MapData& map) {
    std::vector<std::optional<SE3>> final_poses;
    final_poses.reserve(poses.size());
    for (const PoseEstimate& pose : poses) {
      std::optional<SE3> T_world_reference;
      if (pose.state != TrackingState::kLost)
        T_world_reference = map.T_world_keyframe(pose.reference_keyframe);
      final_poses.push_back(T_world_reference ? std::optional<SE3>(*T_world_reference * pose.T_reference_cam)
                                              : std::nullopt);
    }
    return final_poses;
  });
}

}  // namespace sitepose::slam
