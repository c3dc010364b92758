#include "sitepose/daemon/map_store.hpp"

#include <pthread.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "sitepose/core/log.hpp"

namespace sitepose::daemon {
namespace {

namespace fs = std::filesystem;

double ms_since(pipeline::SteadyTime start) {
  return std::chrono::duration<double, std::milli>(pipeline::SteadyClock::now() - start).count();
}

// Why a saved anchor does not fit the configured one; empty when it does.
// The map's coordinates are in its SLAM frame: with another T_site_slam or
// origin every published site position would be wrong.
std::string anchor_mismatch(const mapfile::SiteAnchorRecord& saved,
                            const mapfile::SiteAnchorRecord& configured) {
  constexpr double kDegTolerance = 1e-9;  // ~0.1 mm
  constexpr double kMetreTolerance = 1e-4;
  constexpr double kRadTolerance = 1e-6;
  if (std::abs(saved.latitude_deg - configured.latitude_deg) > kDegTolerance ||
      std::abs(saved.longitude_deg - configured.longitude_deg) > kDegTolerance ||
      std::abs(saved.height_m - configured.height_m) > kMetreTolerance) {
    return fmt::format(
        "saved on site origin ({:.9f}, {:.9f}, {:.3f} m), geo.origin is ({:.9f}, {:.9f}, {:.3f} m)",
        saved.latitude_deg, saved.longitude_deg, saved.height_m, configured.latitude_deg,
        configured.longitude_deg, configured.height_m);
  }
  const double dt_m = (saved.T_site_slam.translation() - configured.T_site_slam.translation()).norm();
  const double dr_rad = saved.T_site_slam.rotation().angularDistance(configured.T_site_slam.rotation());
  if (dt_m > kMetreTolerance || dr_rad > kRadTolerance) {
    return fmt::format("saved with another geo.T_site_slam ({:.4f} m, {:.6f} rad apart)", dt_m, dr_rad);
  }
  return {};
}

// <path>.bad-<n>, the first n that is free; empty when the rename failed.
std::string move_aside(const std::string& path) {
  for (int n = 1; n < 10000; ++n) {
    std::string target = path + ".bad-" + std::to_string(n);
    std::error_code ec;
    if (fs::exists(fs::symlink_status(target, ec))) continue;
    fs::rename(path, target, ec);
    if (ec) {
      spdlog::error("map: cannot move the refused file {} aside to {}: {}", path, target, ec.message());
      return {};
    }
    return target;
  }
  return {};
}

}  // namespace

std::optional<mapfile::SiteAnchorRecord> site_anchor_record(const GeoConfig& geo) {
  if (geo.mode != GeoMode::kFixed) return std::nullopt;
  mapfile::SiteAnchorRecord r;
  r.latitude_deg = geo.origin.latitude_deg;
  r.longitude_deg = geo.origin.longitude_deg;
  r.height_m = geo.origin.height_m;
  r.T_site_slam = geo.T_site_slam;
  return r;
}

MapLoadOutcome load_site_map(const std::string& path, const std::optional<mapfile::SiteAnchorRecord>& anchor,
                             const std::function<Status(map::MapData)>& load) {
  MapLoadOutcome out;
  const auto start = pipeline::SteadyClock::now();
  auto loaded = mapfile::load_map(path);
  if (!loaded && loaded.error().code == ErrorCode::kNotFound) {
    spdlog::info("map: no map file at {}: starting a new map", path);
    return out;
  }
  if (loaded && loaded->meta.anchor && anchor) {
    if (std::string why = anchor_mismatch(*loaded->meta.anchor, *anchor); !why.empty()) {
      out.refused_why = path + ": map file refused: " + why;
    }
  }
  if (!loaded) out.refused_why = loaded.error().message;
  if (out.refused_why.empty()) {
    out.keyframes = loaded->map.keyframe_count();
    out.points = loaded->map.point_count();
    if (auto st = load(std::move(loaded->map)); !st) {
      out.refused_why = path + ": map file refused: " + st.error().message;
    }
  }
  if (!out.refused_why.empty()) {
    out.keyframes = out.points = 0;
    out.moved_to = move_aside(path);
    spdlog::error("map: {}; {}; starting a new map", out.refused_why,
                  out.moved_to.empty() ? "left where it is, and no map will be saved over it"
                                       : "kept as " + out.moved_to);
    return out;
  }
  out.loaded = true;
  spdlog::info("map: loaded {}: {} keyframes, {} points, {:.1f} ms; relocalising in it", path, out.keyframes,
               out.points, ms_since(start));
  return out;
}

MapStore::MapStore(MapPersistenceConfig config, std::optional<mapfile::SiteAnchorRecord> anchor, CopyMap copy)
    : config_(std::move(config)), anchor_(std::move(anchor)), copy_(std::move(copy)) {}

MapStore::~MapStore() { stop(); }

void MapStore::start() {
  if (config_.checkpoint_interval_s <= 0.0 || thread_.joinable()) return;
  thread_ = std::jthread([this](const std::stop_token& stop) { checkpoint_loop(stop); });
}

void MapStore::stop() {
  if (!thread_.joinable()) return;
  thread_.request_stop();
  thread_.join();
}

void MapStore::disable(std::string why) {
  std::lock_guard lock(mutex_);
  disabled_why_ = std::move(why);
}

void MapStore::checkpoint_loop(const std::stop_token& stop) {
  pthread_setname_np(pthread_self(), "sp-mapsave");
  const auto interval = std::chrono::duration_cast<pipeline::SteadyClock::duration>(
      std::chrono::duration<double>(config_.checkpoint_interval_s));
  auto next = pipeline::SteadyClock::now() + interval;
  std::mutex wait_mutex;
  std::unique_lock wait_lock(wait_mutex);
  while (!wake_.wait_until(wait_lock, stop, next, [] { return false; }) && !stop.stop_requested()) {
    next += interval;
    if (auto st = save_now(); !st) spdlog::warn("map: checkpoint failed: {}", st.error().message);
    // After a slow save, the next one an interval from now, not a burst.
    next = std::max(next, pipeline::SteadyClock::now());
  }
}

Status MapStore::save_now() {
  std::lock_guard save_lock(save_mutex_);
  {
    std::lock_guard lock(mutex_);
    if (!disabled_why_.empty()) return make_error(ErrorCode::kRuntime, disabled_why_);
  }
  const auto start = pipeline::SteadyClock::now();
  const map::MapData map = copy_();
  const double copy_ms = ms_since(start);
  if (map.keyframe_count() == 0) return ok_status();
  mapfile::MapFileMeta meta;
  meta.anchor = anchor_;
  const auto write_start = pipeline::SteadyClock::now();
  Status st = mapfile::save_map(config_.map_file, map, meta);
  std::lock_guard lock(mutex_);
  stats_.last_copy_ms = copy_ms;
  stats_.max_copy_ms = std::max(stats_.max_copy_ms, copy_ms);
  if (!st) {
    ++stats_.failures;
    stats_.last_error = st.error().message;
    return st;
  }
  ++stats_.saves;
  stats_.last_save = pipeline::SteadyClock::now();
  stats_.last_write_ms = ms_since(write_start);
  stats_.keyframes = map.keyframe_count();
  stats_.points = map.point_count();
  return ok_status();
}

MapStoreStats MapStore::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

std::string format_map_stats(const MapStoreStats& s, pipeline::SteadyTime now) {
  const std::string age =
      s.last_save ? fmt::format("{:.1f}s", std::chrono::duration<double>(now - *s.last_save).count())
                  : "never";
  return fmt::format(
      "map[saves={} age={} copy={:.1f}ms max={:.1f}ms write={:.1f}ms kf={} pts={} failures={}]", s.saves, age,
      s.last_copy_ms, s.max_copy_ms, s.last_write_ms, s.keyframes, s.points, s.failures);
}

}  // namespace sitepose::daemon
