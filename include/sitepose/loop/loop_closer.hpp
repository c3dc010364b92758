#pragma once
// The loop closer (ORB-SLAM2 LoopClosing, stereo: SE(3)). For each keyframe
// the local mapper has processed (mapping::KeyFrameListener::processed):
//   1. detection (loop_detector.hpp): database candidates outside the
//      keyframe's covisible set, kept when consistent over 3 keyframes; not
//      before the map has 10 keyframes nor within 10 keyframe ids of the
//      last loop (ORB-SLAM2);
//   2. verification of each consistent candidate (loop_verifier.hpp), the
//      first accepted one is the loop;
//   3. correction (loop_correction.hpp) with the local mapper paused: the
//      group moved and fused, then the essential graph optimised on a copy
//      and applied. The map's write lock is held for the two updates only.
//      The correction of the newest keyframe is left for the tracker
//      (take_tracker_correction), so its last pose moves with the map;
//   4. a global BA (global_ba.hpp) on a copy of the whole map, solved
//      without any lock while the mapper runs, applied with the mapper
//      paused (params.global_ba; the next keyframes wait in the queue).
//
// Threading (as mapping::LocalMapper, both mapping::KeyFrameWorker):
// start() runs the steps on a thread "sp-loop" that waits for keyframes;
// stop() ends it after the keyframe in progress; process_pending() runs the
// queue on the caller's thread (deterministic runs) and must not be called
// while the thread runs.
// start(), stop() and the destructor belong to the owner's thread, the rest
// may be called from any thread.
// Locks: the queue's and the stats' mutexes, the database's and the map's
// are never held together; the mapper's pause() is called with none of
// them held.
// Ownership: `map` and `database` must outlive the closer.

#include <atomic>
#include <functional>
#include <mutex>
#include <optional>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/loop/loop_correction.hpp"
#include "sitepose/loop/loop_detector.hpp"
#include "sitepose/loop/loop_verifier.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/mapping/keyframe_worker.hpp"
#include "sitepose/placerec/keyframe_database.hpp"

namespace sitepose::loop {

struct LoopCloserParams {
  int consistency = 3;             // ORB-SLAM2 mnCovisibilityConsistencyTh
  int min_map_keyframes = 10;      // no detection in a smaller map
  int keyframes_after_loop = 10;   // no detection within this many keyframe ids of the last loop
  int essential_min_weight = 100;  // covisibility edges of the essential graph
  bool global_ba = true;           // step 4
  int global_ba_iterations = 10;   // ORB-SLAM2's; the Huber stage runs half of them
  LoopVerifierParams verifier;
};

struct LoopClosingStats {
  std::int64_t keyframes_checked = 0;
  std::int64_t consistent_candidates = 0;  // verified
  std::int64_t loops_refused = 0;          // consistent candidates verification refused
  std::int64_t loops_closed = 0;
  double total_detection_ms = 0.0;  // wall times
  double max_detection_ms = 0.0;
  double total_verification_ms = 0.0;
  double max_verification_ms = 0.0;
  double last_correction_ms = 0.0;    // group correction and fusion (copy, plan, apply)
  double last_optimisation_ms = 0.0;  // the pose-graph solve, unlocked
  double max_write_lock_ms = 0.0;     // the longest single update under the map's write lock
  double total_correction_ms = 0.0;   // all of step 3, mapper paused
  int last_graph_nodes = 0;
  int last_graph_edges = 0;
  double last_graph_initial_cost = 0.0;
  double last_graph_final_cost = 0.0;
  int last_matches = 0;                // matches of the last accepted loop
  std::int64_t global_ba_runs = 0;     // applied
  std::int64_t global_ba_stopped = 0;  // ended early by stop(), applied as far as they got
  double last_global_ba_ms = 0.0;      // the solve, unlocked
  int last_global_ba_keyframes = 0;
  int last_global_ba_points = 0;
  double last_global_ba_initial_cost = 0.0;
  double last_global_ba_final_cost = 0.0;
};

struct MapperPause {
  std::function<void()> pause;  // both empty when the mapper runs inline
  std::function<void()> resume;
};

class LoopCloser {
 public:
  LoopCloser(const StereoCamera& camera, map::SharedMap& map, const placerec::KeyFrameDatabase& database,
             MapperPause mapper, LoopCloserParams params = {});
  ~LoopCloser();
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  void enqueue(map::KeyFrameId keyframe);
  Status process_pending();
  void start();
  void stop();
  bool running() const { return worker_.running(); }
  void wait_until_idle();

  // T_world' * T_world^-1 of the newest keyframe after a correction, once
  // (nullopt when there was none since the last call).
  std::optional<SE3> take_tracker_correction();
  LoopClosingStats stats() const;
  // (current, loop) keyframes of every closed loop.
  std::vector<KeyFramePair> loops() const;

 private:
  Status process_keyframe(map::KeyFrameId keyframe);
  std::vector<map::KeyFrameId> detect(map::KeyFrameId keyframe);
  std::optional<VerifiedLoop> verify(map::KeyFrameId keyframe, const std::vector<map::KeyFrameId>& candidates,
                                     std::vector<mapping::PointSnapshot>& loop_points);
  Status correct(map::KeyFrameId keyframe, const VerifiedLoop& loop,
                 const std::vector<mapping::PointSnapshot>& loop_points);
  Status optimise_essential_graph(map::KeyFrameId keyframe, const GroupCopy& group,
                                  const GroupCorrection& plan, const GroupApplied& applied);
  Status run_global_ba(map::KeyFrameId keyframe);
  void note_write_lock(double ms);

  StereoCamera camera_;
  map::SharedMap& map_;
  const placerec::KeyFrameDatabase& database_;
  MapperPause mapper_;
  LoopCloserParams params_;

  // The processing thread's (worker or caller of process_pending).
  LoopConsistency consistency_;
  map::KeyFrameId last_loop_keyframe_ = map::kNoKeyFrame;
  // Raised by stop(): a global BA in progress ends at its last iterate.
  std::atomic<bool> stop_global_ba_{false};

  mutable std::mutex mutex_;
  LoopClosingStats stats_;                 // guarded by mutex_
  std::vector<KeyFramePair> loops_;        // guarded by mutex_
  std::optional<SE3> tracker_correction_;  // guarded by mutex_
  // Last: the thread it runs calls process_keyframe, so it stops first.
  mapping::KeyFrameWorker worker_;
};

}  // namespace sitepose::loop
