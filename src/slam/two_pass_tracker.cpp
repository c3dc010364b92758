#include "sitepose/slam/two_pass_tracker.hpp"

#include "sitepose/core/stopwatch.hpp"

namespace sitepose::slam {
namespace {

// The map check's search radius: a machine that has started moving is pixels
// off its map points, more than the local map search allows (1 px); 7 px,
// times 2.5 for points seen head-on (the local map search's scaling).
constexpr double kMapCheckRadiusPx = 7.0;

}  // namespace

TwoPassTracker::TwoPassTracker(tracking::Tracker& tracker, const StereoCamera& camera,
                               const config::SiteposeConfig& config, double fps, bool trace)
    : tracker_(tracker),
      config_(config.dynamic),
      trace_(trace),
      classifier_(camera, config.dynamic, fps, config.orb.scale_factor, config.orb.n_levels) {}

Expected<FrameReport> TwoPassTracker::process(const StereoFrame& frame,
                                              const dynamic::FrameObjects& objects) {
  const auto start = SteadyClock::now();
  FrameReport report;
  report.dynamic_layer = true;
  // The mask (the detector's segmentation) is made while the pyramids are
  // built, on this thread.
  dynamic::MaskResult mask;
  SITEPOSE_TRY(const tracking::PreparedFrame prepared,
               tracker_.prepare(frame, [&]() -> Expected<tracking::FrameMasks> {
                 SITEPOSE_TRY(mask, build_mask(frame, objects, report));
                 return tracking::FrameMasks{mask.instance_labels, dynamic::extraction_mask(mask)};
               }));
  Passes passes = track_pass1(prepared, report);
  std::optional<dynamic::ObjectFeatures> current;
  if (full() && passes.pass1.valid) {
    const auto t_classify = SteadyClock::now();
    current = classify(prepared, mask, passes.pass1, report);
    const dynamic::InstanceSet static_objects = check_against_map(prepared, passes.pass1, *current, report);
    report.timings.classify_ms = ms_since(t_classify);
    track_pass2(prepared, static_objects, passes, report);
  } else if (full()) {
    report.objects = dynamic::unclassified_objects(mask.dynamic_boxes);
  }
  commit(prepared, passes, report);
  if (full()) remember(prepared, mask, passes.final_pass(), std::move(current), report.pose);
  copy_stage_timings(prepared, passes.pass1, report.timings);
  report.timings.total_ms = ms_since(start);
  if (trace_) fill_trace(prepared, mask, passes, report);
  return report;
}

void TwoPassTracker::fill_trace(const tracking::PreparedFrame& prepared, const dynamic::MaskResult& mask,
                                const Passes& passes, FrameReport& report) const {
  const auto start = SteadyClock::now();
  const bool pass2_ran = !passes.usable2.empty();
  report.trace.boxes = mask.dynamic_boxes;
  report.trace.pass2_ran = pass2_ran;
  report.trace.pass2_used = passes.pass2_used;
  report.trace.keypoints = trace_keypoints(prepared, passes.usable1, passes.pass1);
  for (std::size_t k = 0; pass2_ran && k < report.trace.keypoints.size(); ++k) {
    auto& keypoint = report.trace.keypoints[k];
    if (passes.usable2[k] != 0) keypoint.flags |= KeypointTrace::kUsablePass2;
    if (k < passes.pass2.point_of_keypoint.size() && passes.pass2.point_of_keypoint[k] != map::kNoPoint) {
      keypoint.flags |= KeypointTrace::kInlierPass2;
    }
  }
  report.trace.fill_ms = ms_since(start);
}

Expected<dynamic::MaskResult> TwoPassTracker::build_mask(const StereoFrame& frame,
                                                         const dynamic::FrameObjects& objects,
                                                         FrameReport& report) const {
  const auto start = SteadyClock::now();
  SITEPOSE_TRY(dynamic::MaskResult mask,
               dynamic::build_mask(config_.mode, objects, frame.left.size(), config_));
  report.timings.mask_ms = ms_since(start);
  report.timings.segment_ms = mask.segment_ms;
  report.mar = mask.mar;
  report.masked_ratio = mask.masked_ratio;
  report.pixel_mask_used = mask.pixel_mask_used;
  return mask;
}

TwoPassTracker::Passes TwoPassTracker::track_pass1(const tracking::PreparedFrame& prepared,
                                                   FrameReport& report) const {
  Passes passes;
  passes.usable1 = dynamic::background_keypoints(prepared);
  passes.pass1 = tracker_.estimate(prepared, passes.usable1);
  if (!full() || passes.pass1.valid || passes.pass1.needs_initialisation) return passes;
  // The background alone is too small (a static machine fills the view).
  const dynamic::InstanceSet known_static(classifier_.static_instances());
  if (known_static.empty()) return passes;
  dynamic::KeypointMask fallback = dynamic::with_keypoints_of(passes.usable1, prepared, known_static);
  tracking::PassResult retry = tracker_.estimate(prepared, fallback);
  if (!retry.valid) return passes;
  passes.pass1 = std::move(retry);
  passes.usable1 = std::move(fallback);
  report.pass1_with_known_static = true;
  return passes;
}

dynamic::ObjectFeatures TwoPassTracker::classify(const tracking::PreparedFrame& prepared,
                                                 const dynamic::MaskResult& mask,
                                                 const tracking::PassResult& pass1, FrameReport& report) {
  dynamic::ObjectFeatures current = dynamic::make_object_features(
      prepared, mask.dynamic_boxes, pass1.T_cam_world.inverse(), pass1.covariance_world_cam,
      pass1.variance_factor, classifier_.max_depth_m());
  report.objects = classifier_.classify(current);
  return current;
}

dynamic::InstanceSet TwoPassTracker::check_against_map(const tracking::PreparedFrame& prepared,
                                                       const tracking::PassResult& pass1,
                                                       const dynamic::ObjectFeatures& current,
                                                       FrameReport& report) {
  dynamic::InstanceSet static_objects = dynamic::static_objects(report.objects);
  // The paper has no such test.
  if (static_objects.empty() || config_.classifier == config::ClassifierMode::kPaper) return static_objects;
  // Pass 1's own local map (listed around its motion-model matches), not
  // listed again.
  const auto map_point_of_keypoint =
      tracker_.matched_map_points(prepared, dynamic::keypoints_of(prepared, static_objects), pass1,
                                  kMapCheckRadiusPx, pass1.local_map.get());
  const std::vector<dynamic::MapCheck> checks =
      classifier_.check_against_map(prepared, map_point_of_keypoint, current, static_objects.ids());
  report.remasked_by_map_check = dynamic::apply_map_checks(checks, report.objects, static_objects);
  return static_objects;
}

void TwoPassTracker::track_pass2(const tracking::PreparedFrame& prepared,
                                 const dynamic::InstanceSet& static_objects, Passes& passes,
                                 FrameReport& report) const {
  passes.static_objects = static_objects.size();
  if (static_objects.empty()) return;
  const auto start = SteadyClock::now();
  passes.usable2 = dynamic::with_keypoints_of(passes.usable1, prepared, static_objects);
  passes.pass2 = tracker_.estimate(prepared, passes.usable2, &passes.pass1, passes.pass1.local_map.get());
  if (passes.pass2.valid) {
    if (dynamic::pass2_agrees_with_pass1(passes.pass1, passes.pass2)) {
      tracker_.carry_over_matches(prepared, passes.pass1, passes.pass2);
      passes.pass2_used = true;
    } else {
      // Pass 1's pose stands; the unmasked objects keep their state (static
      // machines trip this gate now and then; the map check is the test for
      // motion).
      report.pass2_rejected = true;
    }
  }
  report.timings.pass2_ms = ms_since(start);
}

void TwoPassTracker::commit(const tracking::PreparedFrame& prepared, const Passes& passes,
                            FrameReport& report) {
  report.pose = tracker_.commit(prepared, passes.final_pass(), passes.final_usable());
  report.pose.counters.features_used_pass1 = passes.pass1.n_inliers;
  report.pose.counters.features_used = passes.final_pass().n_inliers;
  report.pose.counters.static_objects_unmasked = passes.pass2_used ? passes.static_objects : 0;
  report.pose.counters.masked_area_ratio = report.mar;
}

void TwoPassTracker::remember(const tracking::PreparedFrame& prepared, const dynamic::MaskResult& mask,
                              const tracking::PassResult& final_pass,
                              std::optional<dynamic::ObjectFeatures> current, const PoseEstimate& pose) {
  if (pose.state == TrackingState::kLost) return;
  if (!current) {
    current = dynamic::make_object_features(prepared, mask.dynamic_boxes, pose.T_world_cam, pose.covariance,
                                            final_pass.variance_factor, classifier_.max_depth_m());
  }
  current->T_world_cam = pose.T_world_cam;
  current->covariance = pose.covariance;
  current->variance_factor = final_pass.variance_factor;
  classifier_.remember(std::move(*current));
}

}  // namespace sitepose::slam
