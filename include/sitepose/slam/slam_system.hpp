#pragma once
// The positioning core as one object: tracker + local mapper + the dynamic
// layer. `sitepose run`, `sitepose bench track`, the demo and the daemon's
// track stage all drive it the same way: process() once per frame, in
// order, from one thread.
//
// Modes (config.dynamic.mode; ARCHITECTURE.md "Inside the track stage"):
//   none          plain stereo SLAM on every keypoint (process(frame)).
//   bbox | pixel | hierarchical
//                 Algorithm 1 mask; one pass on the unmasked keypoints.
//   full          hierarchical mask; pass 1 on the background, motion states
//                 of the objects (Algorithm 2, with pass 1's pose), the
//                 static ones checked against their map points (sitepose
//                 mode; a failed check masks the object again), pass 2
//                 from pass 1's pose with static objects' keypoints added
//                 (used only if it agrees with pass 1 within pass 1's
//                 uncertainty);
//                 new map points from the background and static objects.
//                 When the background alone gives no pose, pass 1 is rerun
//                 with the objects static up to the last frame (fallback).
// Keypoints are extracted once per frame and tagged with the instance under
// them; pass 1 leaves no trace in the tracker (Tracker::estimate is const).
// The masking modes run in TwoPassTracker.
//
// Extraction threading: the tracker's extraction jobs run on
// SlamOptions::extraction_pool or on the system's own pool (see there).
//
// Mapper threading: with `mapper_thread` the local mapper runs on its own
// thread (the daemon); without it, queued keyframes are processed on the
// caller's thread right after the frame that created them, which makes runs
// reproducible (tests, regression thresholds, ablations).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/dynamic/masking.hpp"
#include "sitepose/dynamic/motion_classifier.hpp"
#include "sitepose/features/task_pool.hpp"
#include "sitepose/loop/loop_closer.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/placerec/keyframe_database.hpp"
#include "sitepose/slam/frame_report.hpp"
#include "sitepose/slam/two_pass_tracker.hpp"
#include "sitepose/tracking/tracker.hpp"

namespace sitepose::slam {

struct SlamOptions {
  bool mapper_thread = false;
  // Frame rate of the source; sets the motion classifier's reference offset
  // (paper mode, when dynamic.reference_offset_frames = 0) and ring length.
  double fps = 6.0;
  // Fill FrameReport::trace (keypoints, boxes, map size) for the views.
  bool trace = false;
  // Worker threads for feature extraction, lent by the caller (it must
  // outlive the system). nullptr: the system owns a pool of one worker, so
  // the two images of a pair are extracted concurrently.
  features::TaskPool* extraction_pool = nullptr;
  // Place recognition for relocalisation: with a vocabulary, a keyframe
  // database (placerec) that the local mapper keeps, queried by bag of
  // words; without one (the default), the exact nearest-point vote over
  // the whole map (tracking/place_recognition.hpp). Needs mapping.enabled
  // (create() refuses it otherwise): keyframes enter the database when the
  // mapper has processed them.
  std::shared_ptr<const placerec::Vocabulary> vocabulary;
  // Loop closing runs when config.mapping.loop_closing is set and there is
  // a vocabulary (its keyframe database); on its own thread with
  // mapper_thread, else inline after the mapper (reproducible runs).

  // Keep a link for every keyframe the mapper removes
  // (map::MapData::keep_removed_keyframe_links), so that every frame can be
  // re-expressed in the final map (poses_in_final_map). For runs over a
  // recording (`sitepose run --final-out`); the daemon leaves it off.
  bool keep_removed_keyframe_links = false;
};

class SlamSystem {
 public:
  static Expected<std::unique_ptr<SlamSystem>> create(const StereoCamera& camera,
                                                      const config::SiteposeConfig& config,
                                                      const SlamOptions& options = {});
  ~SlamSystem();
  SlamSystem(const SlamSystem&) = delete;
  SlamSystem& operator=(const SlamSystem&) = delete;

  // Plain stereo SLAM on every keypoint (mode none), whatever
  // config.dynamic.mode says. Frames must come in order of time. Errors are
  // bad input (wrong image size or type); tracking failure is a state in
  // the report, not an error.
  Expected<FrameReport> process(const StereoFrame& frame);

  // The frame with its detections, in config.dynamic.mode (see above).
  // objects.segment is called (at most once, during this call) when the
  // mode needs a pixel mask. Errors: those of process(frame), a pixel mask
  // needed without a segmenter (kUnsupported), the segmenter's own error.
  Expected<FrameReport> process(const StereoFrame& frame, const dynamic::FrameObjects& objects);

  config::MaskingMode mode() const { return config_.dynamic.mode; }

  // Lets the mapper finish its queue (and stops its thread).
  void finish();

  // Starts from a saved map (map files) instead of an empty one: the first
  // frames relocalise in it and tracking continues in its frame. The
  // keyframe database (if any) is rebuilt from its keyframes' descriptors,
  // so a map saved with another vocabulary, or none, works the same. Only
  // before the first frame; kInvalidArgument when the map was built with
  // another scale pyramid (its points' scale ranges would not fit).
  Status load_map(map::MapData map);
  // A copy of the map, taken under its read lock (no more than the copy
  // holds the tracker and the mapper back): what a save writes.
  map::MapData copy_map() const;

  // The vocabulary's id (map files), or "" without one.
  std::string vocabulary_id() const;
  // The keyframe database, or nullptr without a vocabulary.
  const placerec::KeyFrameDatabase* keyframe_database() const { return database_.get(); }
  // Relocalisation queries answered by the keyframe database, and the
  // candidates they named (0 without a vocabulary). Read on the thread
  // that calls process().
  struct PlaceQueries {
    long queries = 0;
    long candidates = 0;
  };
  PlaceQueries place_queries() const { return place_queries_; }

  const tracking::TrackerCounters& tracker_counters() const { return tracker_->counters(); }
  mapping::MappingStats mapping_stats() const { return mapper_->stats(); }
  // nullopt when loop closing is off.
  std::optional<loop::LoopClosingStats> loop_stats() const;
  std::size_t keyframe_count() const;
  std::size_t point_count() const;

  // Each pose re-expressed in the map as it is now: its reference
  // keyframe's pose now (map::MapData::T_world_keyframe) composed with the
  // pose relative to it when tracked, so corrections made after the frame
  // (loop closing, global BA, a provisional map joined) move it too; call
  // after finish(). nullopt where the pose is LOST or its keyframe can no
  // longer be placed (dropped with a provisional map, or removed without
  // SlamOptions::keep_removed_keyframe_links).
  std::vector<std::optional<SE3>> poses_in_final_map(const std::vector<PoseEstimate>& poses) const;

 private:
  SlamSystem(const StereoCamera& camera, const config::SiteposeConfig& config, const SlamOptions& options);

  Status run_inline_mapping(FrameReport& report);
  // Moves the tracker's last pose with a map the loop closer corrected.
  void take_loop_correction();
  void fill_map_trace(FrameReport& report) const;

  config::SiteposeConfig config_;
  SlamOptions options_;
  map::SharedMap map_;
  std::unique_ptr<placerec::KeyFrameDatabase> database_;  // before the mapper, which feeds it
  PlaceQueries place_queries_;                            // the tracker's thread
  std::unique_ptr<loop::LoopCloser> closer_;              // fed by the mapper: stopped after it (finish())
  std::unique_ptr<mapping::LocalMapper> mapper_;
  std::unique_ptr<features::TaskPool> own_pool_;  // when options.extraction_pool is nullptr
  std::unique_ptr<tracking::Tracker> tracker_;
  std::unique_ptr<TwoPassTracker> two_pass_;  // the masking modes
};

}  // namespace sitepose::slam
