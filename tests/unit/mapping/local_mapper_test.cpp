#include "sitepose/mapping/local_mapper.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <set>
#include <thread>

#include "sitepose/mapping/site_culling.hpp"
#include "sitepose/testing/map_world.hpp"

namespace sitepose::mapping {
namespace {

using testing::check_consistency;
using testing::make_world;
using testing::pose_at_x;
using testing::SimTracker;
using testing::SimTrackerOptions;
using testing::test_camera;

struct PointErrors {
  std::vector<double> error_m;  // per good point, sorted
  double median() const { return error_m.empty() ? 0.0 : error_m[error_m.size() / 2]; }
  double quantile(double q) const {
    return error_m.empty() ? 0.0 : error_m[static_cast<std::size_t>(q * (error_m.size() - 1))];
  }
};

PointErrors point_errors(const map::SharedMap& map, const SimTracker& tracker,
                         double min_true_depth_m = 0.0) {
  PointErrors e;
  map.read([&](const map::MapData& m) {
    for (const auto& [pid, p] : m.points()) {
      if (p.bad) continue;
      const int w = tracker.world_of_point(p);
      const Eigen::Vector3d& truth = tracker.world().points[w];
      if (truth.z() < min_true_depth_m) continue;
      e.error_m.push_back((p.p_world - truth).norm());
    }
  });
  std::sort(e.error_m.begin(), e.error_m.end());
  return e;
}

// Error of the point kept for each world point (the one with most observations).
std::map<int, double> errors_by_world_point(const map::SharedMap& map, const SimTracker& tracker) {
  std::map<int, double> result;
  const auto associations = tracker.associations();
  map.read([&](const map::MapData& m) {
    for (const auto& [w, pid] : associations) {
      result[w] = (m.point(pid)->p_world - tracker.world().points[w]).norm();
    }
  });
  return result;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Ground-truth pose of keyframe k along a back-and-forth drive over
// [0, span_m] in steps of step_m.
double back_and_forth_x(int k, double span_m, double step_m) {
  const int steps = static_cast<int>(std::lround(span_m / step_m));
  const int phase = k % (2 * steps);
  return step_m * (phase <= steps ? phase : 2 * steps - phase);
}

TEST(LocalMapper, QueueStateAndProcessPending) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(150, 1);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  EXPECT_TRUE(mapper.is_idle());
  EXPECT_TRUE(mapper.accepts_keyframes());
  for (int k = 0; k < 3; ++k) mapper.enqueue(tracker.insert_keyframe(pose_at_x(k), pose_at_x(k)));
  EXPECT_EQ(mapper.queue_size(), 3u);
  EXPECT_FALSE(mapper.is_idle());
  ASSERT_TRUE(mapper.process_pending().has_value());
  EXPECT_EQ(mapper.queue_size(), 0u);
  EXPECT_TRUE(mapper.is_idle());
  EXPECT_EQ(mapper.stats().keyframes_processed, 3);
  // Only the last keyframe found an empty queue: one local BA.
  EXPECT_EQ(mapper.stats().ba_runs, 1);
  // A keyframe that is gone by its turn is counted and skipped.
  mapper.enqueue(12345);
  ASSERT_TRUE(mapper.process_pending().has_value());
  EXPECT_EQ(mapper.stats().keyframes_missing, 1);
  mapper.start();
  EXPECT_TRUE(mapper.running());
  EXPECT_FALSE(mapper.process_pending().has_value());
  mapper.stop();
  EXPECT_FALSE(mapper.running());
  map.read([](const map::MapData& m) { EXPECT_EQ(check_consistency(m), ""); });
}

TEST(LocalMapper, CullsRecentPointsSeenByNoLaterKeyframe) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(150, 2);
  std::vector<bool> hidden(world.points.size());
  for (std::size_t w = 0; w < hidden.size(); ++w) hidden[w] = w % 4 == 0;
  map::SharedMap map;
  SimTrackerOptions options;
  options.stereo_dropout = 0.0;
  SimTracker tracker(world, camera, map, options);
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  auto hidden_points_alive = [&] {
    return map.read([&](const map::MapData& m) {
      int n = 0;
      for (const auto& [pid, p] : m.points()) n += !p.bad && hidden[tracker.world_of_point(p)] ? 1 : 0;
      return n;
    });
  };
  // Small steps: no pair is a stereo baseline apart, so nothing is triangulated.
  mapper.enqueue(tracker.insert_keyframe(pose_at_x(0.0), pose_at_x(0.0)));
  ASSERT_TRUE(mapper.process_pending().has_value());
  const int created = hidden_points_alive();
  EXPECT_GT(created, 50);
  mapper.enqueue(tracker.insert_keyframe(pose_at_x(0.2), pose_at_x(0.2), 1.0, &hidden));
  ASSERT_TRUE(mapper.process_pending().has_value());
  EXPECT_EQ(hidden_points_alive(), created);  // one keyframe later: still recent
  mapper.enqueue(tracker.insert_keyframe(pose_at_x(0.4), pose_at_x(0.4), 1.0, &hidden));
  ASSERT_TRUE(mapper.process_pending().has_value());
  // Two keyframes later a point seen by its creator only (weight 2 <= 3) goes.
  EXPECT_EQ(hidden_points_alive(), 0);
  EXPECT_GE(mapper.stats().points_culled, created);
  // Points the later keyframes saw survive, and bad ones were purged.
  map.read([&](const map::MapData& m) {
    EXPECT_GT(m.point_count(), 150u);
    for (const auto& [pid, p] : m.points()) EXPECT_FALSE(p.bad);
    EXPECT_EQ(check_consistency(m), "");
  });
}

TEST(LocalMapper, TriangulatesPointsWithoutStereoDepth) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(300, 3);
  map::SharedMap map;
  SimTrackerOptions options;
  options.stereo_max_depth_m = 18.0;  // the planes at 22 m and 29 m have no stereo depth
  SimTracker tracker(world, camera, map, options);
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  for (int k = 0; k < 6; ++k) {
    const SE3 T = pose_at_x(1.5 * k, 0.02 * k);
    mapper.enqueue(tracker.insert_keyframe(T, T));
    ASSERT_TRUE(mapper.process_pending().has_value());
  }
  const MappingStats stats = mapper.stats();
  const PointErrors far = point_errors(map, tracker, 20.0);
  std::printf("triangulated %lld points; far points %zu, median error %.3f m, 95%% %.3f m\n",
              static_cast<long long>(stats.points_triangulated), far.error_m.size(), far.median(),
              far.quantile(0.95));
  // The far planes hold ~600 points, most seen by >= 2 keyframes 1.5 m apart.
  EXPECT_GT(far.error_m.size(), 300u);
  EXPECT_GE(stats.points_triangulated, static_cast<long long>(far.error_m.size()));
  // At 22-29 m with 1.5-7.5 m baselines and 0.5 px noise.
  EXPECT_LT(far.median(), 0.3);
  EXPECT_LT(far.quantile(0.95), 1.5);
  map.read([](const map::MapData& m) { EXPECT_EQ(check_consistency(m), ""); });
}

TEST(LocalMapper, FusesDuplicatePoints) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(200, 4);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  auto duplicated_world_points = [&] {
    return map.read([&](const map::MapData& m) {
      std::map<int, int> count;
      for (const auto& [pid, p] : m.points()) {
        if (!p.bad) ++count[tracker.world_of_point(p)];
      }
      return static_cast<int>(
          std::count_if(count.begin(), count.end(), [](auto& c) { return c.second > 1; }));
    });
  };
  mapper.enqueue(tracker.insert_keyframe(pose_at_x(0.0), pose_at_x(0.0)));
  ASSERT_TRUE(mapper.process_pending().has_value());
  // The tracker found only half of the points: the other half of its stereo
  // keypoints become second points of the same world points.
  mapper.enqueue(tracker.insert_keyframe(pose_at_x(0.3), pose_at_x(0.3), /*associate_fraction=*/0.5));
  const int before = duplicated_world_points();
  ASSERT_TRUE(mapper.process_pending().has_value());
  const int after = duplicated_world_points();
  std::printf("duplicated world points: %d before fusion, %d after; %lld merged, %lld observations added\n",
              before, after, static_cast<long long>(mapper.stats().fuse_points_merged),
              static_cast<long long>(mapper.stats().fuse_observations_added));
  EXPECT_GT(before, 100);
  EXPECT_LT(after, before / 20);
  EXPECT_GT(mapper.stats().fuse_points_merged, before * 9 / 10);
  map.read([](const map::MapData& m) { EXPECT_EQ(check_consistency(m), ""); });
}

TEST(LocalMapper, LocalBaReducesPoseAndPointErrorAndKeepsTheFirstKeyframe) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(550, 5);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  config::MappingConfig mapping;
  LocalMapper mapper(camera, mapping, config::TrackingConfig{}, map);
  std::mt19937 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<SE3> truth;
  std::vector<map::KeyFrameId> ids;
  constexpr int kKeyframes = 11;
  for (int k = 0; k < kKeyframes; ++k) {
    truth.push_back(pose_at_x(0.6 * k, 0.01 * k));
    // The tracker's estimate: ~7 cm and ~0.3 degrees off per axis, the first exact.
    Vector6d xi;
    xi << 0.07 * n(rng), 0.07 * n(rng), 0.07 * n(rng), 0.005 * n(rng), 0.005 * n(rng), 0.005 * n(rng);
    const SE3 estimate = k == 0 ? truth[0] : SE3::exp(xi) * truth[k];
    ids.push_back(tracker.insert_keyframe(truth[k], estimate));
    mapper.enqueue(ids.back());
  }
  auto pose_error = [&] {
    return map.read([&](const map::MapData& m) {
      double sum = 0.0;
      int count = 0;
      for (int k = 1; k < kKeyframes; ++k) {
        if (const map::KeyFrame* kf = m.keyframe(ids[k]); kf != nullptr) {
          sum += (kf->camera_center() - truth[k].translation()).norm();
          ++count;
        }
      }
      return std::make_pair(sum / std::max(1, count), count);
    });
  };
  const auto [pose_before, n_before] = pose_error();
  const auto points_before = errors_by_world_point(map, tracker);
  // All keyframes are queued: steps 1-4 run for each, local BA once, for the
  // last one, over a window holding all of them.
  ASSERT_TRUE(mapper.process_pending().has_value());
  const MappingStats stats = mapper.stats();
  const auto [pose_after, n_after] = pose_error();
  // The same world points before and after (new far points are triangulated meanwhile).
  const auto after_by_world = errors_by_world_point(map, tracker);
  std::vector<double> before_common;
  std::vector<double> after_common;
  for (const auto& [w, error] : after_by_world) {
    if (const auto it = points_before.find(w); it != points_before.end()) {
      before_common.push_back(it->second);
      after_common.push_back(error);
    }
  }
  const double median_before = median(before_common);
  const double median_after = median(after_common);
  std::printf("local BA: %d keyframes, %d points, %d observations in %.1f ms (%.1f ms CPU; aborted %lld)\n",
              stats.last_ba_keyframes, stats.last_ba_points, stats.last_ba_observations, stats.last_ba_ms,
              stats.last_ba_cpu_ms, static_cast<long long>(stats.ba_aborted));
  std::printf(
      "mean keyframe centre error %.4f m -> %.4f m (%d -> %d keyframes); "
      "median point error %.4f -> %.4f m (%zu points)\n",
      pose_before, pose_after, n_before, n_after, median_before, median_after, after_common.size());
  EXPECT_EQ(stats.ba_runs, 1);
  EXPECT_GE(stats.last_ba_keyframes, kKeyframes - 1);  // culling happens after BA
  EXPECT_GT(stats.last_ba_points, 1000);
  EXPECT_GT(n_after, 2);
  EXPECT_LT(pose_after, 0.3 * pose_before);
  EXPECT_GT(after_common.size(), 1000u);
  EXPECT_LT(median_after, 0.7 * median_before);
  map.read([&](const map::MapData& m) {
    const map::KeyFrame* first = m.keyframe(ids[0]);
    ASSERT_NE(first, nullptr);
    EXPECT_EQ(first->T_world_cam.translation(), truth[0].translation());
    EXPECT_EQ(first->T_world_cam.rotation().coeffs(), truth[0].rotation().coeffs());
    EXPECT_EQ(check_consistency(m), "");
  });
}

TEST(LocalMapper, LocalBaRemovesWrongAssociations) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(250, 6);
  map::SharedMap map;
  SimTrackerOptions options;
  options.wrong_association_fraction = 0.06;
  SimTracker tracker(world, camera, map, options);
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  auto wrong_observations = [&] {
    return map.read([&](const map::MapData& m) {
      int wrong = 0;
      for (const auto& [pid, p] : m.points()) {
        if (p.bad) continue;
        const int w = tracker.world_of_point(p);
        for (const auto& [kf, index] : p.observations) wrong += tracker.world_of(kf, index) != w ? 1 : 0;
      }
      return wrong;
    });
  };
  int injected_present = 0;
  for (int k = 0; k < 8; ++k) {
    const SE3 T = pose_at_x(0.5 * k);
    const map::KeyFrameId id = tracker.insert_keyframe(T, T);
    injected_present += wrong_observations();
    mapper.enqueue(id);
    ASSERT_TRUE(mapper.process_pending().has_value());
    // Whatever the last keyframe brought in is judged by its local BA.
    EXPECT_LE(wrong_observations(), 2) << "after keyframe " << k;
  }
  std::printf("wrong associations injected %zu, erased by BA %lld\n", tracker.wrong_associations_made(),
              static_cast<long long>(mapper.stats().ba_outliers_erased));
  EXPECT_GT(tracker.wrong_associations_made(), 100u);
  EXPECT_GT(injected_present, 100);
  EXPECT_GE(mapper.stats().ba_outliers_erased,
            static_cast<long long>(tracker.wrong_associations_made() * 8 / 10));
  map.read([](const map::MapData& m) { EXPECT_EQ(check_consistency(m), ""); });
}

// Drives back and forth over [0, 10] m in 0.5 m steps (one pass: 40
// keyframes there and back) with true poses; per pass the keyframes and
// points in the map at its end.
struct BackAndForthDrive {
  std::vector<std::size_t> keyframes_after_pass;
  std::vector<std::size_t> points_after_pass;
  std::size_t max_keyframes = 0;
  std::size_t max_points = 0;
  MappingStats stats;
};

constexpr int kKeyframesPerPass = 40;

BackAndForthDrive drive_back_and_forth(const config::MappingConfig& mapping, const testing::World& world,
                                       map::SharedMap& map, SimTracker& tracker, int passes) {
  LocalMapper mapper(test_camera(), mapping, config::TrackingConfig{}, map);
  BackAndForthDrive drive;
  for (int k = 0; k < passes * kKeyframesPerPass; ++k) {
    const SE3 T = pose_at_x(back_and_forth_x(k, 10.0, 0.5));
    // A real tracker misses some of the map points it sees.
    const map::KeyFrameId id = tracker.insert_keyframe(T, T, 0.85);
    // The real tracker protects its reference keyframe, the newest one.
    map.write([&](map::MapData& m) { m.set_tracker_keyframes({id}); });
    mapper.enqueue(id);
    EXPECT_TRUE(mapper.process_pending().has_value());
    map.read([&](const map::MapData& m) {
      drive.max_keyframes = std::max(drive.max_keyframes, m.keyframe_count());
      drive.max_points = std::max(drive.max_points, m.point_count());
      if ((k + 1) % kKeyframesPerPass == 0) {
        drive.keyframes_after_pass.push_back(m.keyframe_count());
        drive.points_after_pass.push_back(m.point_count());
      }
    });
  }
  drive.stats = mapper.stats();
  std::printf("site_culling %d, %d passes of %d keyframes: keyframes after each pass", mapping.site_culling,
              passes, kKeyframesPerPass);
  for (std::size_t n : drive.keyframes_after_pass) std::printf(" %zu", n);
  std::printf("; points");
  for (std::size_t n : drive.points_after_pass) std::printf(" %zu", n);
  std::printf(
      "\nat most %zu keyframes and %zu points kept (world %zu points); %lld culled (%lld by site); "
      "%.1f ms per keyframe, of which BA %.1f ms\n",
      drive.max_keyframes, drive.max_points, world.points.size(),
      static_cast<long long>(drive.stats.keyframes_culled),
      static_cast<long long>(drive.stats.keyframes_culled_by_site),
      drive.stats.total_keyframe_ms / (passes * kKeyframesPerPass),
      drive.stats.total_ba_ms / (passes * kKeyframesPerPass));
  return drive;
}

// The map of a strip driven again and again grows with the strip, not with
// the passes: after the second pass neither keyframes nor points grow.
void expect_bounded_by_the_strip(const BackAndForthDrive& drive, const testing::World& world) {
  ASSERT_GE(drive.keyframes_after_pass.size(), 3u);
  const std::size_t second = drive.keyframes_after_pass[1];
  for (std::size_t pass = 2; pass < drive.keyframes_after_pass.size(); ++pass) {
    EXPECT_LE(drive.keyframes_after_pass[pass], second + 2) << "keyframes grow at pass " << pass + 1;
    EXPECT_LE(drive.points_after_pass[pass], drive.points_after_pass[1] * 11 / 10)
        << "points grow at pass " << pass + 1;
  }
  EXPECT_LT(drive.max_keyframes, 40u);
  // Points stay bounded by the world (duplicates fused, weak ones culled).
  EXPECT_LT(drive.max_points, world.points.size() * 12 / 10);
  EXPECT_GT(drive.stats.fuse_points_merged, 0);
}

void expect_true_map(const map::SharedMap& map, const SimTracker& tracker) {
  // Stereo disparity noise 0.3 px gives ~0.2 m depth error at 22 m; the
  // far plane (29 m) is triangulated over a few metres.
  const PointErrors errors = point_errors(map, tracker);
  EXPECT_LT(errors.median(), 0.2);
  EXPECT_LT(errors.quantile(0.9), 1.5);
  // Keyframes stay where they are (the first is fixed, the poses were true).
  map.read([&](const map::MapData& m) {
    for (const auto& [id, kf] : m.keyframes()) {
      EXPECT_NEAR(kf.camera_center().y(), 0.0, 0.02);
      EXPECT_NEAR(kf.camera_center().z(), 0.0, 0.02);
      EXPECT_LT(rotation_angle_rad(kf.T_world_cam.rotation()), 0.002);
    }
  });
  map.read([](const map::MapData& m) {
    for (const auto& [pid, p] : m.points()) EXPECT_FALSE(p.bad);
    EXPECT_NE(m.keyframe(m.first_keyframe()), nullptr);
    EXPECT_EQ(check_consistency(m), "");
  });
}

TEST(LocalMapper, KeyframeCullingBoundsTheMapWhenDrivingBackAndForth) {
  const testing::World world = make_world(200, 7);
  map::SharedMap map;
  SimTracker tracker(world, test_camera(), map, SimTrackerOptions{});
  const BackAndForthDrive drive = drive_back_and_forth(config::MappingConfig{}, world, map, tracker, 5);
  expect_bounded_by_the_strip(drive, world);
  EXPECT_GT(drive.stats.keyframes_culled, 160);
  expect_true_map(map, tracker);
  // The steps' times (what `bench track` reports per keyframe) are each
  // spent and together within the keyframes' time.
  const mapping::MappingStepTimes& steps = drive.stats.total_steps;
  EXPECT_GT(steps.new_points_ms, 0.0);
  EXPECT_GT(steps.fuse_ms, 0.0);
  EXPECT_GT(steps.local_ba_ms, drive.stats.total_ba_ms * 0.999);  // the solve and more
  EXPECT_GT(steps.culling_ms, 0.0);
  EXPECT_LE(steps.new_points_ms + steps.fuse_ms + steps.local_ba_ms + steps.culling_ms,
            drive.stats.total_keyframe_ms);
}

// The same drive with site culling: as bounded, and every site cell of the
// strip keeps a keyframe (the window rule alone erodes the map to a few).
TEST(LocalMapper, SiteCullingBoundsTheMapAndKeepsEveryCellOfTheStrip) {
  const testing::World world = make_world(200, 7);
  map::SharedMap map;
  SimTracker tracker(world, test_camera(), map, SimTrackerOptions{});
  config::MappingConfig mapping;
  mapping.site_culling = true;
  // Cells of 0.7 m: the drive's 0.5 m steps then keep off the cell borders,
  // where a millimetre of local BA would move a keyframe into the next cell.
  mapping.site_radius_m = 0.7;
  const BackAndForthDrive drive = drive_back_and_forth(mapping, world, map, tracker, 5);
  expect_bounded_by_the_strip(drive, world);
  expect_true_map(map, tracker);
  const SiteNeighbourhood site{mapping.site_radius_m, mapping.site_angle_deg};
  map.read([&](const map::MapData& m) {
    for (int k = 0; k <= kKeyframesPerPass / 2; ++k) {
      map::KeyFrame at;
      at.T_world_cam = pose_at_x(back_and_forth_x(k, 10.0, 0.5));
      const bool covered = std::any_of(m.keyframes().begin(), m.keyframes().end(), [&](const auto& entry) {
        return site_cell_of(entry.second, site) == site_cell_of(at, site);
      });
      EXPECT_TRUE(covered) << "no keyframe in the cell of x " << at.camera_center().x();
    }
  });
}

// The place-recognition database follows the mapper through its listener:
// every processed keyframe is added once, every culled one removed, so what
// the listener holds is the map's good keyframes.
TEST(LocalMapper, TellsItsListenerOfEveryKeyframeAddedAndCulled) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(200, 7);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  std::set<map::KeyFrameId> held;
  int added = 0;
  int removed = 0;
  int processed = 0;
  int still_in_map = 0;  // keyframes in the map after their own processing
  mapper.set_keyframe_listener({[&](map::KeyFrameId id, const std::vector<map::Descriptor>& descriptors) {
                                  EXPECT_TRUE(held.insert(id).second) << "keyframe " << id << " added twice";
                                  EXPECT_FALSE(descriptors.empty());
                                  ++added;
                                },
                                [&](map::KeyFrameId id) {
                                  EXPECT_EQ(held.erase(id), 1U) << "keyframe " << id << " removed unknown";
                                  ++removed;
                                },
                                [&](map::KeyFrameId id) {
                                  // Handed on (the loop closer) only while still in the map.
                                  EXPECT_EQ(held.count(id), 1U) << "keyframe " << id << " processed unknown";
                                  ++processed;
                                }});
  for (int k = 0; k < 60; ++k) {
    const SE3 T = pose_at_x(back_and_forth_x(k, 10.0, 0.5));
    const map::KeyFrameId id = tracker.insert_keyframe(T, T, 0.85);
    mapper.enqueue(id);
    ASSERT_TRUE(mapper.process_pending().has_value());
    if (map.read([&](const map::MapData& m) { return m.keyframe(id) != nullptr; })) ++still_in_map;
    EXPECT_EQ(processed, still_in_map);
  }
  EXPECT_EQ(added, 60);
  EXPECT_EQ(removed, mapper.stats().keyframes_culled);
  EXPECT_GT(removed, 20);
  map.read([&](const map::MapData& m) {
    std::set<map::KeyFrameId> good;
    for (const auto& [id, kf] : m.keyframes()) {
      if (!kf.bad) good.insert(id);
    }
    EXPECT_EQ(held, good);
  });
}

// The loop closer's hold: while paused the thread takes no keyframe from
// the queue, whatever the timing; after resume() it catches up.
TEST(LocalMapper, PausedThreadTakesNoKeyFrame) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(250, 8);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  mapper.start();
  for (int k = 0; k < 3; ++k) {
    const SE3 T = pose_at_x(0.5 * k);
    mapper.enqueue(tracker.insert_keyframe(T, T));
    mapper.wait_until_idle();
  }
  mapper.pause();
  const SE3 T = pose_at_x(1.5);
  mapper.enqueue(tracker.insert_keyframe(T, T));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(mapper.queue_size(), 1U);
  EXPECT_EQ(mapper.stats().keyframes_processed, 3);
  mapper.resume();
  mapper.wait_until_idle();
  EXPECT_EQ(mapper.queue_size(), 0U);
  EXPECT_EQ(mapper.stats().keyframes_processed, 4);
  mapper.stop();
}

TEST(LocalMapper, ThreadedRunGivesAConsistentMap) {
  const StereoCamera camera = test_camera();
  const testing::World world = make_world(250, 8);
  map::SharedMap map;
  SimTracker tracker(world, camera, map, SimTrackerOptions{});
  LocalMapper mapper(camera, config::MappingConfig{}, config::TrackingConfig{}, map);
  mapper.start();
  constexpr int kKeyframes = 40;
  for (int k = 0; k < kKeyframes; ++k) {
    const SE3 T = pose_at_x(back_and_forth_x(k, 8.0, 0.8));
    // One keyframe at a time into the running mapper thread. The tracker
    // lets three wait, but the mapper culls only when none waits, so with a
    // queue the keyframe count below depended on thread timing (30 or more
    // in 6 of 30 runs on an idle machine, bound < 30).
    mapper.enqueue(tracker.insert_keyframe(T, T));
    mapper.wait_until_idle();
  }
  mapper.wait_until_idle();
  EXPECT_TRUE(mapper.is_idle());
  mapper.stop();
  const MappingStats stats = mapper.stats();
  EXPECT_EQ(stats.keyframes_processed + stats.keyframes_missing, kKeyframes);
  EXPECT_GE(stats.ba_runs, 1);
  const PointErrors errors = point_errors(map, tracker);
  EXPECT_LT(errors.median(), 0.1);
  map.read([](const map::MapData& m) {
    EXPECT_EQ(check_consistency(m), "");
    EXPECT_LT(m.keyframe_count(), 30u);
  });
}

}  // namespace
}  // namespace sitepose::mapping
