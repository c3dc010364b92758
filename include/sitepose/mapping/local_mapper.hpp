#pragma once
// The local mapper (ORB-SLAM2 LocalMapping, written for sitepose). For each
// keyframe the tracker hands over, in order:
//   1. process it: refresh descriptor, normal and scale range of the points
//      it tracked, its covisibility; the points created with it become
//      "recent";
//   2. cull recent points: found_ratio < 0.25, or observation weight
//      (map_data.hpp, stereo counts 2) <= mapping.min_point_observations
//      once 2 keyframes have passed since creation; a point leaves the recent
//      list after 3 keyframes;
//   3. triangulate new points with its best 10 covisible keyframes (stops
//      after the first when another keyframe is waiting) whose centres are
//      at least one stereo baseline away (new_points.hpp);
//   4. fuse duplicates with its neighbours (10 best covisible and their 5
//      best; with mapping.site_culling also its 10 nearest keyframes of the
//      site, site_culling.hpp) both ways (fuse.hpp);
//   5. local BA when no other keyframe is waiting (local_ba_problem.hpp):
//      copied out under read(), solved unlocked, aborted when a keyframe is
//      enqueued, written back under write();
//   6. cull redundant keyframes of the BA window (keyframe_culling.hpp), and
//      with mapping.site_culling those of the whole map near the keyframe
//      (site_culling.hpp), also only when no other keyframe is waiting; then,
//      always, purge bad points so memory stays bounded.
//
// Contract with the tracker: it inserts the keyframe and its new stereo
// points with MapData::add_keyframe / add_point under SharedMap::write(),
// then calls enqueue(id). Keyframes covisible with the one being processed
// (with site culling: any near it) may be removed (step 6), never the map's
// first keyframe nor one still waiting in the queue (with site culling nor
// the tracker's, MapData::tracker_keyframes); bad points are purged at the end of each keyframe,
// so the tracker must look its points up again (MapData::good_point) after
// every frame rather than keep pointers.
//
// Threading: start(), stop() and the destructor belong to the owner's
// thread; every other member may be called from any thread. Two ways to run
// (keyframe_worker.hpp):
//   * start() runs the steps on a thread named "sp-mapping" (std::jthread)
//     that waits on a condition variable for keyframes; stop() ends it
//     after the keyframe in progress (aborting its BA); keyframes still
//     queued stay queued. The destructor calls stop().
//   * process_pending() runs everything queued on the caller's thread
//     (deterministic tests, `sitepose run --deterministic`); it must not
//     be called while the thread runs.
// Locks: neither the queue's nor the stats' mutex is held while the
// SharedMap lock is taken,
// and the map lock is held only to copy out and to apply results (the
// searches and the Ceres solve run unlocked), per shared_map.hpp.
// Ownership: the camera and configs are copied; `map` must outlive the
// mapper.

#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/mapping/fuse.hpp"
#include "sitepose/mapping/keyframe_worker.hpp"
#include "sitepose/mapping/new_points.hpp"
#include "sitepose/mapping/site_culling.hpp"
#include "sitepose/optim/local_ba.hpp"

namespace sitepose::mapping {

// Wall time of the steps of process_keyframe, summed over keyframes (what
// the mapper costs per keyframe, and where: `sitepose bench track|dynamic`).
struct MappingStepTimes {
  double new_points_ms = 0.0;  // step 3: epipolar search and triangulation
  double fuse_ms = 0.0;        // step 4
  double local_ba_ms = 0.0;    // step 5: building, solving and applying the problem
  double culling_ms = 0.0;     // steps 2 and 6: recent points, then keyframes (both rules)
};

struct MappingStats {
  std::int64_t keyframes_processed = 0;
  std::int64_t keyframes_missing = 0;        // enqueued but gone from the map when their turn came
  std::int64_t points_triangulated = 0;      // step 3
  std::int64_t points_culled = 0;            // step 2
  std::int64_t fuse_observations_added = 0;  // step 4
  std::int64_t fuse_points_merged = 0;       // step 4
  std::int64_t ba_runs = 0;
  std::int64_t ba_aborted = 0;   // stopped early by an enqueue or stop()
  std::int64_t ba_failures = 0;  // optim::LocalBa returned an error (logged)
  std::int64_t ba_outliers_erased = 0;
  std::int64_t keyframes_culled = 0;          // step 6, both rules
  std::int64_t keyframes_culled_by_site = 0;  // step 6, of those by the site rule
  std::int64_t points_purged = 0;             // bad points reclaimed
  int last_ba_keyframes = 0;                  // size of the last solved window: free + fixed keyframes,
  int last_ba_points = 0;                     // points
  int last_ba_observations = 0;               // and observations
  double last_ba_ms = 0.0;                    // wall time of the last solve (unlocked part)
  double last_ba_cpu_ms = 0.0;                // CPU time of the mapping thread in that solve
  double total_ba_ms = 0.0;
  double last_keyframe_ms = 0.0;  // wall time of all steps for the last keyframe
  double total_keyframe_ms = 0.0;
  MappingStepTimes total_steps;  // of total_keyframe_ms
};

// Who else keeps a per-keyframe index (the place-recognition database):
// told after a keyframe is processed (step 1, with its descriptors) and
// after it is culled (step 6), outside the map lock. Called on the thread
// processing keyframes.
struct KeyFrameListener {
  std::function<void(map::KeyFrameId, const std::vector<map::Descriptor>&)> added;
  std::function<void(map::KeyFrameId)> removed;
  // After all steps, when the keyframe is still in the map (the loop
  // closer's hand-over, ORB-SLAM2 LoopCloser::InsertKeyFrame).
  std::function<void(map::KeyFrameId)> processed;
};

class LocalMapper {
 public:
  // Reads mapping.{local_ba_keyframes, local_ba_iterations,
  // keyframe_redundancy, min_point_observations, site_culling,
  // site_radius_m, site_angle_deg} and
  // tracking.{chi2_mono, chi2_stereo, close_depth_baselines}.
  LocalMapper(const StereoCamera& camera, const config::MappingConfig& mapping,
              const config::TrackingConfig& tracking, map::SharedMap& map);
  ~LocalMapper();
  LocalMapper(const LocalMapper&) = delete;
  LocalMapper& operator=(const LocalMapper&) = delete;

  // Queues a keyframe already inserted into the map; a running local BA is
  // asked to stop so the new keyframe is handled sooner.
  void enqueue(map::KeyFrameId keyframe);

  // Runs all queued keyframes on the calling thread. Fails (kRuntime) when
  // the thread is running, or with the first error of a step (the rest of
  // the queue is still processed).
  Status process_pending();

  // Only before start() (or between stop() and start()).
  void set_keyframe_listener(KeyFrameListener listener) { listener_ = std::move(listener); }

  void start();
  void stop();
  bool running() const;

  // The loop closer's and the tracker's hold (ORB-SLAM2 RequestStop /
  // Release; KeyFrameWorker::hold, which nests): pause()
  // aborts a running local BA and returns once the keyframe in progress is
  // finished; no further keyframe is taken from the queue until resume().
  // The tracker may still enqueue. No effect on process_pending().
  void pause();
  void resume();

  // Blocks until the queue is empty and no keyframe is in progress; returns
  // at once when the thread is not running.
  void wait_until_idle();
  // No keyframe queued or in progress.
  bool is_idle() const;
  // False while a keyframe is in progress (ORB-SLAM2 AcceptKeyFrames): the
  // tracker then inserts only when its own rules insist, and holds back when
  // queue_size() >= 3.
  bool accepts_keyframes() const;
  std::size_t queue_size() const;
  MappingStats stats() const;

 private:
  Status process_keyframe(map::KeyFrameId keyframe);
  bool process_new_keyframe(map::KeyFrameId keyframe);
  void cull_recent_points(map::KeyFrameId keyframe);
  void create_new_points(map::KeyFrameId keyframe);
  void fuse_neighbours(map::KeyFrameId keyframe);
  Status local_bundle_adjustment(map::KeyFrameId keyframe);
  void cull_keyframes(map::KeyFrameId keyframe);
  void cull_site_keyframes(map::KeyFrameId keyframe);
  // Removes, on the live map one at a time, the candidates `may_cull` still
  // allows; tells the listener and counts them (by_site: by the site rule).
  void remove_keyframes(const std::vector<map::KeyFrameId>& candidates,
                        const std::function<bool(const map::MapData&, map::KeyFrameId)>& may_cull,
                        bool by_site);
  SiteNeighbourhood site_neighbourhood() const;
  bool queue_empty() const;

  StereoCamera camera_;
  config::MappingConfig mapping_;
  config::TrackingConfig tracking_;
  map::SharedMap& map_;
  optim::LocalBa local_ba_;
  NewPointParams new_point_params_;
  FuseParams fuse_params_;
  double close_depth_m_;

  KeyFrameListener listener_;
  // Touched only by the thread processing keyframes (worker or the caller of
  // process_pending, never both).
  std::vector<map::PointId> recent_points_;

  mutable std::mutex mutex_;
  MappingStats stats_;  // guarded by mutex_
  // Last: the thread it runs calls process_keyframe, so it stops first.
  KeyFrameWorker worker_;
};

}  // namespace sitepose::mapping
