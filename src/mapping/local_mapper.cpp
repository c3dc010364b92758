#include "sitepose/mapping/local_mapper.hpp"

#include <time.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <set>
#include <unordered_set>

#include "sitepose/core/log.hpp"
#include "sitepose/mapping/keyframe_culling.hpp"
#include "sitepose/mapping/local_ba_problem.hpp"
#include "sitepose/mapping/map_snapshot.hpp"
#include "sitepose/mapping/site_culling.hpp"

namespace sitepose::mapping {
namespace {

// ORB-SLAM2 LocalMapping constants (stereo case).
constexpr double kMinFoundRatio = 0.25;       // MapPointCulling
constexpr int kRecentCullAfterKeyframes = 2;  // cull weak points once 2 KFs have passed
constexpr int kRecentKeepKeyframes = 3;       // then leave the recent list
constexpr int kTriangulationNeighbours = 10;  // CreateNewMapPoints nn (stereo)
constexpr int kFuseNeighbours = 10;           // SearchInNeighbors nn (stereo)
constexpr int kFuseSecondNeighbours = 5;      // ... and 5 of each of those
constexpr int kMaxFixedKeyframes = 20;        // cap of the fixed ring in local BA
constexpr int kFuseSiteNeighbours = 10;       // nearest keyframes of the site fused with (site culling)
// Nice value of the mapper thread (0 = the tracking threads'): weight 335
// against 1024, so a contended core gives tracking ~3/4 of its time.
constexpr int kMapperThreadNice = 5;

double elapsed_ms(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// CPU time of the calling thread: wall time alone hides contention for cores.
double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

// What triangulation and fusion work on outside the map's lock: the
// keyframe, the keyframes it is matched with and the scale pyramid, copied
// under the lock; the lock is taken again only to apply the results.
struct KeyFramesCopy {
  KeyFrameSnapshot current;
  std::vector<KeyFrameSnapshot> others;  // triangulation partners or fusion targets
  map::ScalePyramid pyramid;
};

KeyFramesCopy copy_keyframes(const map::MapData& m, map::KeyFrameId keyframe,
                             const std::vector<map::KeyFrameId>& others) {
  KeyFramesCopy c;
  c.pyramid = m.pyramid();
  c.current = snapshot_keyframe(*m.keyframe(keyframe));
  for (map::KeyFrameId id : others) c.others.push_back(snapshot_keyframe(*m.keyframe(id)));
  return c;
}

// The keyframes fused with: the best covisible ones, the best covisible of
// those, and with `site` (site culling) the nearest of the site.
std::vector<map::KeyFrameId> fusion_targets(const map::MapData& m, map::KeyFrameId keyframe,
                                            const std::optional<SiteNeighbourhood>& site) {
  std::vector<map::KeyFrameId> targets;
  std::set<map::KeyFrameId> seen{keyframe};
  for (map::KeyFrameId id : m.best_covisible(keyframe, kFuseNeighbours)) {
    if (seen.insert(id).second) targets.push_back(id);
  }
  const std::size_t first_ring = targets.size();
  for (std::size_t i = 0; i < first_ring; ++i) {
    for (map::KeyFrameId id : m.best_covisible(targets[i], kFuseSecondNeighbours)) {
      if (seen.insert(id).second) targets.push_back(id);
    }
  }
  // A place driven again: its old keyframes need not be covisible with
  // the new one yet (after a relocalisation they are not); fusing with
  // them joins the duplicated points, so the site rule can cull.
  if (site) {
    for (map::KeyFrameId id : site_neighbours(m, keyframe, *site, kFuseSiteNeighbours)) {
      if (seen.insert(id).second) targets.push_back(id);
    }
  }
  return targets;
}

// The good points of the copied keyframes, each once: the keyframe's
// (fused into the targets) and the targets' it lacks (fused into it).
struct FusionPoints {
  std::vector<PointSnapshot> current;
  std::vector<PointSnapshot> targets;
};

FusionPoints fusion_points(const map::MapData& m, const KeyFramesCopy& keyframes) {
  FusionPoints points;
  std::unordered_set<map::PointId> in_current;
  for (map::PointId pid : keyframes.current.point_of_keypoint) {
    const map::MapPoint* p = m.good_point(pid);
    if (p != nullptr && in_current.insert(pid).second) points.current.push_back(snapshot_point(*p));
  }
  std::unordered_set<map::PointId> in_targets;
  for (const KeyFrameSnapshot& target : keyframes.others) {
    for (map::PointId pid : target.point_of_keypoint) {
      const map::MapPoint* p = m.good_point(pid);
      if (p != nullptr && in_current.count(pid) == 0 && in_targets.insert(pid).second) {
        points.targets.push_back(snapshot_point(*p));
      }
    }
  }
  return points;
}

}  // namespace

LocalMapper::LocalMapper(const StereoCamera& camera, const config::MappingConfig& mapping,
                         const config::TrackingConfig& tracking, map::SharedMap& map)
    : camera_(camera),
      mapping_(mapping),
      tracking_(tracking),
      map_(map),
      local_ba_(camera, mapping, tracking),
      close_depth_m_(tracking.close_depth_baselines * camera.baseline_m),
      worker_({"sp-mapping", kMapperThreadNice, "local mapping"},
              [this](map::KeyFrameId keyframe) { return process_keyframe(keyframe); }) {
  // load_config() enforces these bounds; reaching here without them is a bug.
  SITEPOSE_CHECK(mapping_.local_ba_keyframes >= 1);
  SITEPOSE_CHECK(mapping_.keyframe_redundancy > 0.0 && mapping_.keyframe_redundancy <= 1.0);
  SITEPOSE_CHECK(mapping_.min_point_observations >= 1);
  SITEPOSE_CHECK(camera_.baseline_m > 0.0 && camera_.fx > 0.0);
  new_point_params_.chi2_mono = tracking_.chi2_mono;
  new_point_params_.chi2_stereo = tracking_.chi2_stereo;
  fuse_params_.chi2_mono = tracking_.chi2_mono;
  fuse_params_.chi2_stereo = tracking_.chi2_stereo;
}

LocalMapper::~LocalMapper() { stop(); }

void LocalMapper::enqueue(map::KeyFrameId keyframe) { worker_.enqueue(keyframe); }

Status LocalMapper::process_pending() {
  if (worker_.running()) {
    return make_error(ErrorCode::kRuntime,
                      "LocalMapper::process_pending: the mapping thread is running; use wait_until_idle()");
  }
  return worker_.process_pending();
}

void LocalMapper::start() { worker_.start(); }

void LocalMapper::stop() { worker_.stop(); }

bool LocalMapper::running() const { return worker_.running(); }

void LocalMapper::pause() { worker_.hold(); }

void LocalMapper::resume() { worker_.release(); }

void LocalMapper::wait_until_idle() { worker_.wait_until_idle(); }

bool LocalMapper::is_idle() const { return worker_.idle(); }

bool LocalMapper::accepts_keyframes() const { return !worker_.busy(); }

std::size_t LocalMapper::queue_size() const { return worker_.queue_size(); }

MappingStats LocalMapper::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

bool LocalMapper::queue_empty() const { return worker_.queue_size() == 0; }

Status LocalMapper::process_keyframe(map::KeyFrameId keyframe) {
  const auto start = std::chrono::steady_clock::now();
  if (!process_new_keyframe(keyframe)) {
    std::lock_guard lock(mutex_);
    ++stats_.keyframes_missing;
    return ok_status();
  }
  if (listener_.added) {
    const std::vector<map::Descriptor> descriptors = map_.read([&](const map::MapData& m) {
      std::vector<map::Descriptor> out;
      if (const map::KeyFrame* kf = m.keyframe(keyframe); kf != nullptr) {
        out.reserve(kf->keypoints.size());
        for (const map::KeyPointData& k : kf->keypoints) out.push_back(k.descriptor);
      }
      return out;
    });
    listener_.added(keyframe, descriptors);
  }
  MappingStepTimes steps;
  auto step_start = std::chrono::steady_clock::now();
  // Adds the time since the last mark to `total` and starts the next step.
  const auto mark = [&step_start](double& total) {
    total += elapsed_ms(step_start);
    step_start = std::chrono::steady_clock::now();
  };
  cull_recent_points(keyframe);
  mark(steps.culling_ms);
  create_new_points(keyframe);
  mark(steps.new_points_ms);
  fuse_neighbours(keyframe);
  mark(steps.fuse_ms);
  // ORB-SLAM2: BA and keyframe culling only when no other keyframe waits.
  // Behind the tracker, the redundancy test would count views of keyframes
  // not yet processed, and the tracker holds back at 3 queued anyway.
  Status ba_status;
  if (queue_empty()) {
    ba_status = local_bundle_adjustment(keyframe);
    mark(steps.local_ba_ms);
    cull_keyframes(keyframe);
    if (mapping_.site_culling) cull_site_keyframes(keyframe);
    mark(steps.culling_ms);
  }
  const std::size_t purged = map_.write([](map::MapData& m) { return m.purge_bad_points(); });
  if (listener_.processed &&
      map_.read([&](const map::MapData& m) { return m.keyframe(keyframe) != nullptr; })) {
    listener_.processed(keyframe);
  }
  const double ms = elapsed_ms(start);
  {
    std::lock_guard lock(mutex_);
    ++stats_.keyframes_processed;
    stats_.points_purged += static_cast<std::int64_t>(purged);
    stats_.last_keyframe_ms = ms;
    stats_.total_keyframe_ms += ms;
    stats_.total_steps.new_points_ms += steps.new_points_ms;
    stats_.total_steps.fuse_ms += steps.fuse_ms;
    stats_.total_steps.local_ba_ms += steps.local_ba_ms;
    stats_.total_steps.culling_ms += steps.culling_ms;
  }
  spdlog::debug("local mapping: keyframe={} ms={:.1f}", keyframe, ms);
  return ba_status;
}

bool LocalMapper::process_new_keyframe(map::KeyFrameId keyframe) {
  return map_.write([&](map::MapData& m) {
    const map::KeyFrame* kf = m.keyframe(keyframe);
    if (kf == nullptr || kf->bad) return false;
    for (map::PointId pid : kf->point_of_keypoint) {
      const map::MapPoint* p = m.good_point(pid);
      if (p == nullptr) continue;
      if (p->first_keyframe == keyframe) {
        recent_points_.push_back(pid);  // created by the tracker with this keyframe
      } else {
        m.update_point_appearance(pid);  // tracked: one more view
      }
    }
    m.update_connections(keyframe);
    return true;
  });
}

void LocalMapper::cull_recent_points(map::KeyFrameId keyframe) {
  const int culled = map_.write([&](map::MapData& m) {
    int n = 0;
    std::erase_if(recent_points_, [&](map::PointId pid) {
      const map::MapPoint* p = m.good_point(pid);
      if (p == nullptr) return true;
      const map::KeyFrameId age = keyframe - p->first_keyframe;
      if (p->found_ratio() < kMinFoundRatio ||
          (age >= kRecentCullAfterKeyframes &&
           m.observation_weight(pid) <= mapping_.min_point_observations)) {
        m.set_point_bad(pid);
        ++n;
        return true;
      }
      return age >= kRecentKeepKeyframes;
    });
    return n;
  });
  std::lock_guard lock(mutex_);
  stats_.points_culled += culled;
}

void LocalMapper::create_new_points(map::KeyFrameId keyframe) {
  const KeyFramesCopy copy = map_.read([&](const map::MapData& m) {
    return copy_keyframes(m, keyframe, m.best_covisible(keyframe, kTriangulationNeighbours));
  });

  struct Created {
    map::KeyFrameId other;
    NewPoint point;
  };
  std::vector<Created> created;
  std::vector<bool> used_current(copy.current.keypoints.size(), false);
  for (std::size_t n = 0; n < copy.others.size(); ++n) {
    // Behind the tracker: the next keyframe matters more than more points.
    if (n > 0 && !queue_empty()) break;
    const KeyFrameSnapshot& other = copy.others[n];
    // ORB-SLAM2 stereo rule: below one stereo baseline the pair adds nothing.
    if ((other.camera_center() - copy.current.camera_center()).norm() < camera_.baseline_m) continue;
    const std::vector<KeypointMatch> matches =
        search_for_triangulation(camera_, copy.pyramid, copy.current, other, new_point_params_, used_current);
    for (const NewPoint& p :
         triangulate_matches(camera_, copy.pyramid, copy.current, other, matches, new_point_params_)) {
      used_current[p.index1] = true;
      created.push_back({other.id, p});
    }
  }
  if (created.empty()) return;

  const int n_created = map_.write([&](map::MapData& m) {
    int n = 0;
    for (const Created& c : created) {
      const map::KeyFrame* kf = m.keyframe(keyframe);
      const map::KeyFrame* other = m.keyframe(c.other);
      if (kf == nullptr || other == nullptr) continue;
      // The slots may have been filled since the copy.
      if (kf->point_of_keypoint[c.point.index1] != map::kNoPoint ||
          other->point_of_keypoint[c.point.index2] != map::kNoPoint) {
        continue;
      }
      const map::PointId pid = m.add_point(c.point.p_world, keyframe, c.point.index1);
      m.add_observation(pid, c.other, c.point.index2);
      m.update_point_appearance(pid);
      recent_points_.push_back(pid);
      ++n;
    }
    return n;
  });
  std::lock_guard lock(mutex_);
  stats_.points_triangulated += n_created;
}

void LocalMapper::fuse_neighbours(map::KeyFrameId keyframe) {
  const std::optional<SiteNeighbourhood> site =
      mapping_.site_culling ? std::optional(site_neighbourhood()) : std::nullopt;
  FusionPoints points;
  const KeyFramesCopy copy = map_.read([&](const map::MapData& m) {
    KeyFramesCopy c = copy_keyframes(m, keyframe, fusion_targets(m, keyframe, site));
    points = fusion_points(m, c);
    return c;
  });

  std::vector<FuseProposal> proposals;
  for (const KeyFrameSnapshot& target : copy.others) {
    const map::KeypointGrid grid = make_keypoint_grid(camera_, target);
    const auto found = fuse_into_keyframe(camera_, copy.pyramid, target, grid, points.current, fuse_params_);
    proposals.insert(proposals.end(), found.begin(), found.end());
  }
  {
    const map::KeypointGrid grid = make_keypoint_grid(camera_, copy.current);
    const auto found =
        fuse_into_keyframe(camera_, copy.pyramid, copy.current, grid, points.targets, fuse_params_);
    proposals.insert(proposals.end(), found.begin(), found.end());
  }

  const FuseOutcome outcome = map_.write([&](map::MapData& m) {
    FuseOutcome o = apply_fuse_proposals(m, proposals);
    // Refresh what the fusion changed, then the keyframe's covisibility.
    std::unordered_set<map::PointId> refresh(o.touched.begin(), o.touched.end());
    if (const map::KeyFrame* kf = m.keyframe(keyframe); kf != nullptr) {
      refresh.insert(kf->point_of_keypoint.begin(), kf->point_of_keypoint.end());
    }
    for (map::PointId pid : refresh) {
      if (m.good_point(pid) != nullptr) m.update_point_appearance(pid);
    }
    m.update_connections(keyframe);
    return o;
  });
  std::lock_guard lock(mutex_);
  stats_.fuse_observations_added += outcome.observations_added;
  stats_.fuse_points_merged += outcome.points_merged;
}

Status LocalMapper::local_bundle_adjustment(map::KeyFrameId keyframe) {
  // Not with a keyframe waiting, nor paused (the loop closer waits); an
  // enqueue (or a pause) after this point aborts the solve.
  if (!worker_.begin_interruptible_step()) return ok_status();
  const LocalBaProblem problem = map_.read([&](const map::MapData& m) {
    return build_local_ba_problem(m, keyframe, mapping_.local_ba_keyframes, kMaxFixedKeyframes);
  });
  if (problem.n_free_keyframes == 0 || problem.input.observations.empty()) return ok_status();

  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_ms = thread_cpu_ms();
  Expected<optim::LocalBaResult> result = local_ba_.solve(problem.input, &worker_.interrupt());
  const double ms = elapsed_ms(start);
  const double cpu_ms = thread_cpu_ms() - cpu_start_ms;
  if (!result) {
    std::lock_guard lock(mutex_);
    ++stats_.ba_failures;
    return make_error(result.error().code,
                      "local mapping: keyframe " + std::to_string(keyframe) + ": " + result.error().message);
  }
  const LocalBaApplied applied =
      map_.write([&](map::MapData& m) { return apply_local_ba(m, problem, *result); });
  std::lock_guard lock(mutex_);
  ++stats_.ba_runs;
  if (result->aborted) ++stats_.ba_aborted;
  stats_.ba_outliers_erased += applied.outliers_erased;
  stats_.last_ba_keyframes = static_cast<int>(problem.keyframe_ids.size());
  stats_.last_ba_points = static_cast<int>(problem.point_ids.size());
  stats_.last_ba_observations = static_cast<int>(problem.input.observations.size());
  stats_.last_ba_ms = ms;
  stats_.last_ba_cpu_ms = cpu_ms;
  stats_.total_ba_ms += ms;
  return ok_status();
}

void LocalMapper::cull_keyframes(map::KeyFrameId keyframe) {
  const std::vector<map::KeyFrameId> candidates = map_.read([&](const map::MapData& m) {
    return redundant_keyframes(m, keyframe, mapping_.local_ba_keyframes, mapping_.keyframe_redundancy,
                               close_depth_m_);
  });
  if (candidates.empty()) return;
  // With site culling the window obeys the site rules too (no emptied
  // cell, the tracker's keyframes stay).
  const SiteNeighbourhood site = site_neighbourhood();
  remove_keyframes(
      candidates,
      [&](const map::MapData& m, map::KeyFrameId id) {
        return mapping_.site_culling
                   ? may_cull_from_site(m, id, keyframe, site, mapping_.keyframe_redundancy, close_depth_m_)
                   : is_keyframe_redundant(m, id, mapping_.keyframe_redundancy, close_depth_m_);
      },
      false);
}

void LocalMapper::cull_site_keyframes(map::KeyFrameId keyframe) {
  const SiteNeighbourhood site = site_neighbourhood();
  std::size_t near = 0;
  const std::vector<map::KeyFrameId> candidates = map_.read([&](const map::MapData& m) {
    std::vector<map::KeyFrameId> redundant;
    const std::vector<map::KeyFrameId> all = site_candidates(m, keyframe, site);
    near = all.size();
    for (map::KeyFrameId id : all) {
      if (is_keyframe_redundant(m, id, mapping_.keyframe_redundancy, close_depth_m_)) redundant.push_back(id);
    }
    return redundant;
  });
  spdlog::debug("local mapping: keyframe={} site candidates={} redundant={}", keyframe, near,
                candidates.size());
  if (candidates.empty()) return;
  remove_keyframes(
      candidates,
      [&](const map::MapData& m, map::KeyFrameId id) {
        return may_cull_from_site(m, id, keyframe, site, mapping_.keyframe_redundancy, close_depth_m_);
      },
      true);
}

void LocalMapper::remove_keyframes(const std::vector<map::KeyFrameId>& candidates,
                                   const std::function<bool(const map::MapData&, map::KeyFrameId)>& may_cull,
                                   bool by_site) {
  // Removing one keyframe lowers the redundancy of the others: test again
  // on the live map, one at a time.
  const std::vector<map::KeyFrameId> culled = map_.write([&](map::MapData& m) {
    std::vector<map::KeyFrameId> removed;
    for (map::KeyFrameId id : candidates) {
      if (!may_cull(m, id)) continue;
      m.set_keyframe_bad(id);
      if (m.keyframe(id) == nullptr) removed.push_back(id);  // a loop keyframe stays
    }
    return removed;
  });
  if (listener_.removed) {
    for (map::KeyFrameId id : culled) listener_.removed(id);
  }
  std::lock_guard lock(mutex_);
  stats_.keyframes_culled += static_cast<std::int64_t>(culled.size());
  if (by_site) stats_.keyframes_culled_by_site += static_cast<std::int64_t>(culled.size());
}

SiteNeighbourhood LocalMapper::site_neighbourhood() const {
  return SiteNeighbourhood{mapping_.site_radius_m, mapping_.site_angle_deg};
}

}  // namespace sitepose::mapping
