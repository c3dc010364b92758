#pragma once
// siteposed's site map on disk (issue 19; mapping.map_file,
// mapping.checkpoint_interval_s): loaded once before the first frame, saved
// by a checkpoint thread every interval and once more at stop.
//
// Loading never stops the daemon: a missing file starts a new map; a file
// that is refused (truncated, corrupted, another format version, built with
// another ORB pyramid, anchored to another site frame) is logged with the
// reason, renamed aside to <file>.bad-<n> so it is kept for inspection and
// never overwritten, and a new map starts.
//
// Saving copies the map under its read lock (the only moment a checkpoint
// holds the tracker back: the copy, measured in the stats) and encodes and
// writes the copy without any lock, atomically (mapfile: temp file + rename),
// on the checkpoint thread. An empty map is not saved: it would replace a
// file that still holds a site.
//
// Threads: construction, start(), stop() and save_now() on the supervising
// thread; the checkpoint thread calls `copy` (which must be safe from any
// thread: SlamPoseTracker::copy_map) and save; stats() from any thread.

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "sitepose/core/expected.hpp"
#include "sitepose/daemon/daemon_config.hpp"
#include "sitepose/map/map_data.hpp"
#include "sitepose/mapfile/map_file.hpp"
#include "sitepose/pipeline/packets.hpp"

namespace sitepose::daemon {

// The site anchor a map is saved with and checked against: geo.mode fixed's
// origin and T_site_slam; none in the other modes.
std::optional<mapfile::SiteAnchorRecord> site_anchor_record(const GeoConfig& geo);

// What loading the map file did.
struct MapLoadOutcome {
  bool loaded = false;        // the run starts in the saved map
  std::string refused_why;    // non-empty: the file was refused for this reason
  std::string moved_to;       // where the refused file now is (empty when it could not be moved)
  std::size_t keyframes = 0;  // of the loaded map
  std::size_t points = 0;
};

// Loads `path` through `load` (SlamPoseTracker::load_map, before the first
// frame), checking the site anchor against `anchor`. Logs what it did.
MapLoadOutcome load_site_map(const std::string& path, const std::optional<mapfile::SiteAnchorRecord>& anchor,
                             const std::function<Status(map::MapData)>& load);

struct MapStoreStats {
  std::uint64_t saves = 0;     // periodic checkpoints and the save at stop
  std::uint64_t failures = 0;  // saves that failed (last_error says why)
  std::optional<pipeline::SteadyTime> last_save;
  double last_copy_ms = 0.0;  // map copied under its read lock
  double max_copy_ms = 0.0;
  double last_write_ms = 0.0;  // encoded and written, no lock held
  std::size_t keyframes = 0;   // in the last save
  std::size_t points = 0;
  std::string last_error;
};

class MapStore {
 public:
  using CopyMap = std::function<map::MapData()>;

  // `copy` must stay callable until stop() returned.
  MapStore(MapPersistenceConfig config, std::optional<mapfile::SiteAnchorRecord> anchor, CopyMap copy);
  ~MapStore();
  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;

  // Starts the checkpoint thread (none when checkpoint_interval_s is 0).
  void start();
  // Stops and joins it (a save in progress completes first).
  void stop();
  // One save on the calling thread (the one at stop). Ok when the map was
  // written or was empty.
  Status save_now();
  // Saving stays off (a refused file could not be moved aside: writing
  // would destroy it).
  void disable(std::string why);

  MapStoreStats stats() const;

 private:
  void checkpoint_loop(const std::stop_token& stop);

  const MapPersistenceConfig config_;
  const std::optional<mapfile::SiteAnchorRecord> anchor_;
  const CopyMap copy_;
  std::mutex save_mutex_;  // one save at a time (the thread's and save_now's)
  mutable std::mutex mutex_;
  MapStoreStats stats_;       // guarded by mutex_
  std::string disabled_why_;  // guarded by mutex_
  std::condition_variable_any wake_;
  std::jthread thread_;  // last: joined before the members above go
};

// "map[saves=3 age=1.2s copy=0.8ms max=1.5ms write=4.1ms kf=12 pts=800 failures=0]"
std::string format_map_stats(const MapStoreStats& stats, pipeline::SteadyTime now);

}  // namespace sitepose::daemon
