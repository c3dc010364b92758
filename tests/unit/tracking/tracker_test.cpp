#include "sitepose/tracking/tracker.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <set>

#include <opencv2/imgproc.hpp>

#include "sitepose/mapping/local_mapper.hpp"
#include "sitepose/sim/simulator.hpp"
#include "sitepose/testing/simulated.hpp"

namespace sitepose::tracking {
namespace {

// The tracker's link to a local mapper run by the test (as SlamSystem links them).
MapperLink link_to(mapping::LocalMapper& mapper) {
  MapperLink link;
  link.enqueue = [&mapper](map::KeyFrameId id) { mapper.enqueue(id); };
  link.queue_size = [&mapper] { return static_cast<int>(mapper.queue_size()); };
  link.is_idle = [&mapper] { return mapper.is_idle(); };
  return link;
}

// A small simulated site (480x270) keeps the test fast.
struct SmallSite {
  sim::Simulator simulator;
  static SmallSite make(const char* scenario_name, int frames) {
    auto simulator = testing::small_simulator(scenario_name, 480, 270, frames, SITEPOSE_SCENARIO_DIR);
    SITEPOSE_CHECK(simulator.has_value());
    return SmallSite{std::move(*simulator)};
  }
  StereoFrame frame(int i, sim::SimFrame* truth = nullptr) const {
    sim::SimFrame f = simulator.render(i);
    if (truth != nullptr) *truth = f;
    return testing::stereo_frame(f, "test");
  }
};

config::SiteposeConfig small_config() {
  config::SiteposeConfig config;
  config.orb.n_features = 1000;
  return config;
}

// Tracks frame i of the site, expects it OK and keeps the largest position
// error against the simulator's truth in max_error_m (world = first camera
// in both, so no alignment is needed). nullopt when tracking failed.
std::optional<PoseEstimate> track_expecting_ok(Tracker& tracker, const SmallSite& site, int i,
                                               double& max_error_m) {
  sim::SimFrame truth;
  auto pose = tracker.track(site.frame(i, &truth));
  EXPECT_TRUE(pose.has_value()) << pose.error().message;
  if (!pose) return std::nullopt;
  EXPECT_EQ(pose->state, TrackingState::kOk) << "frame " << i << ": " << pose->state_reason;
  max_error_m =
      std::max(max_error_m, (pose->T_world_cam.translation() - truth.T_world_cam.translation()).norm());
  return *pose;
}

// Issue 19 asks whether the tracker re-uses the map of an earlier pass:
// each committed pose counts its matches, and those whose point a keyframe
// made kOldKeyFrameAge_s or more before the frame observes. Here the older
// half of the keyframes is made to look 100 s older than it is.
TEST(Tracker, MatchesToPointsOfOldKeyFramesAreCounted) {
  const SmallSite site = SmallSite::make("static", 30);
  map::SharedMap map;
  Tracker tracker(site.simulator.camera(), small_config(), map);
  PoseEstimate pose;
  for (int i = 0; i < 29; ++i) {
    auto tracked = tracker.track(site.frame(i));
    ASSERT_TRUE(tracked.has_value());
    pose = *tracked;
  }
  ASSERT_EQ(pose.state, TrackingState::kOk);
  EXPECT_GT(pose.counters.matches, 50);
  EXPECT_EQ(pose.counters.matches_from_old_keyframes, 0) << "every keyframe is under 5 s old";

  std::set<map::KeyFrameId> old;
  map.write([&](map::MapData& m) {
    const map::KeyFrameId middle = (m.first_keyframe() + m.last_keyframe()) / 2;
    for (const auto& entry : m.keyframes()) {
      if (entry.first <= middle) old.insert(entry.first);
    }
    for (const map::KeyFrameId id : old) m.keyframe(id)->t_ns -= 100'000'000'000;
  });
  auto last = tracker.prepare(site.frame(29));
  ASSERT_TRUE(last.has_value());
  const std::vector<std::uint8_t> all(last->size(), 1);
  const PassResult result = tracker.estimate(*last, all);
  pose = tracker.commit(*last, result, all);
  ASSERT_EQ(pose.state, TrackingState::kOk);
  int matched = 0;
  int seen_by_old = 0;
  map.read([&](const map::MapData& m) {
    for (const map::PointId id : result.point_of_keypoint) {
      const map::MapPoint* p = m.point(id);
      if (p == nullptr) continue;
      ++matched;
      const bool is_old = std::any_of(p->observations.begin(), p->observations.end(),
                                      [&](const auto& view) { return old.count(view.first) != 0; });
      if (is_old) ++seen_by_old;
    }
  });
  EXPECT_EQ(pose.counters.matches, matched);
  EXPECT_EQ(pose.counters.matches_from_old_keyframes, seen_by_old);
  EXPECT_GT(seen_by_old, 0);
  EXPECT_LT(seen_by_old, matched) << "some matched points were made by the newer keyframes";
  EXPECT_EQ(tracker.counters().matches_from_old_keyframes, seen_by_old);
}

TEST(Tracker, TracksASmallStaticSite) {
  const SmallSite site = SmallSite::make("static", 30);
  map::SharedMap map;
  Tracker tracker(site.simulator.camera(), small_config(), map);
  double max_error_m = 0.0;
  for (int i = 0; i < 30; ++i) {
    const std::optional<PoseEstimate> pose = track_expecting_ok(tracker, site, i, max_error_m);
    ASSERT_TRUE(pose.has_value());
    EXPECT_GT(pose->counters.features_used, 50);
  }
  EXPECT_LT(max_error_m, 0.03);
  EXPECT_GE(tracker.counters().keyframes_created, 1);
}

// The pool only spreads the work: extraction, stereo matching and the
// projection searches split into jobs whose results are joined in a fixed
// order, so a tracker with threads tracks exactly as one without.
TEST(Tracker, PooledAndSerialTrackIdentically) {
  const SmallSite site = SmallSite::make("static", 12);
  features::TaskPool pool(1);
  map::SharedMap pooled_map;
  map::SharedMap serial_map;
  Tracker pooled(site.simulator.camera(), small_config(), pooled_map, {}, &pool);
  Tracker serial(site.simulator.camera(), small_config(), serial_map);
  for (int i = 0; i < 12; ++i) {
    const StereoFrame frame = site.frame(i);
    auto a = pooled.track(frame);
    auto b = serial.track(frame);
    ASSERT_TRUE(a.has_value() && b.has_value());
    EXPECT_EQ(a->state, b->state) << "frame " << i;
    EXPECT_EQ(a->counters.features_used, b->counters.features_used) << "frame " << i;
    EXPECT_EQ((a->T_world_cam.matrix() - b->T_world_cam.matrix()).norm(), 0.0) << "frame " << i;
  }
  EXPECT_EQ(pooled.counters().keyframes_created, serial.counters().keyframes_created);
}

// The blackout scenario covers the lens for frames 24-33 while the roller
// drives 1.3 m. The tracker must come back by relocalisation, stay
// RECOVERING until the new pose has held, and never call a wrong pose OK.
// With the local mapper, as the system runs: relocalised at frame 34 0.01 m
// off, OK from frame 36 on, within 0.05 m. (Without it the map held too few
// points: the only relocalisation found was 1.2 m off, and was kept
// RECOVERING to the end.)
struct BlindSpell {
  static constexpr int kFrames = 46;
  static constexpr int kFirstCovered = 24;
  static constexpr int kFirstVisible = 34;
  std::vector<TrackingState> states;
  int first_back = kFirstVisible;  // first frame not LOST after the spell
  int hold = 0;
  int relocalisations = 0;
};

BlindSpell track_blind_spell() {
  BlindSpell out;
  const SmallSite site = SmallSite::make("blackout", BlindSpell::kFrames);
  map::SharedMap map;
  const config::SiteposeConfig config = small_config();
  mapping::LocalMapper mapper(site.simulator.camera(), config.mapping, config.tracking, map);
  Tracker tracker(site.simulator.camera(), config, map, link_to(mapper));
  for (int i = 0; i < BlindSpell::kFrames; ++i) {
    sim::SimFrame truth;
    auto pose = tracker.track(site.frame(i, &truth));
    EXPECT_TRUE(mapper.process_pending().has_value());
    EXPECT_TRUE(pose.has_value()) << pose.error().message;
    if (!pose) return out;
    out.states.push_back(pose->state);
    if (pose->state != TrackingState::kOk) continue;
    const double error_m = (pose->T_world_cam.translation() - truth.T_world_cam.translation()).norm();
    EXPECT_LT(error_m, 0.05) << "frame " << i << " reported OK " << error_m << " m off";
  }
  while (out.first_back < BlindSpell::kFrames && out.states[out.first_back] == TrackingState::kLost)
    ++out.first_back;
  out.hold = config.tracking.relocalisation_hold_frames;
  out.relocalisations = tracker.counters().relocalisations;
  return out;
}

TEST(Tracker, AfterABlindSpellRelocalisesAndHoldsBeforeOk) {
  const BlindSpell spell = track_blind_spell();
  ASSERT_EQ(spell.states.size(), static_cast<std::size_t>(BlindSpell::kFrames));
  for (int i = BlindSpell::kFirstCovered; i < BlindSpell::kFirstVisible; ++i)
    EXPECT_EQ(spell.states[i], TrackingState::kLost) << "frame " << i;
  ASSERT_LT(spell.first_back - BlindSpell::kFirstVisible, 5)
      << "no relocalisation within 5 frames of the view's return";
  for (int i = spell.first_back; i < spell.first_back + spell.hold - 1; ++i) {
    EXPECT_EQ(spell.states[i], TrackingState::kRecovering) << "frame " << i << " is OK before the pose held";
  }
  EXPECT_GE(spell.relocalisations, 1);
}

// OK at the hold's end (frame 36; track_blind_spell() scores every OK pose
// within 0.05 m). Disabled until the frame after a relocalisation was
// tracked by descriptors against the keyframe it found: before, the pose
// stayed RECOVERING to the end here (0.004-0.023 m off).
TEST(Tracker, AfterABlindSpellComesBackOkAtTheRightPlace) {
  const BlindSpell spell = track_blind_spell();
  ASSERT_EQ(spell.states.size(), static_cast<std::size_t>(BlindSpell::kFrames));
  ASSERT_LT(spell.first_back + spell.hold - 1, BlindSpell::kFrames);
  EXPECT_EQ(spell.states[spell.first_back + spell.hold - 1], TrackingState::kOk);
}

// A tracker that has tracked frames 0-9 of the static scenario, and frame 10
// prepared (not tracked).
class TrackerAtFrame10 : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(tracker.track(site.frame(i)).has_value());
    auto frame = tracker.prepare(site.frame(10));
    ASSERT_TRUE(frame.has_value());
    prepared = std::move(*frame);
  }
  const SmallSite site = SmallSite::make("static", 12);
  map::SharedMap map;
  Tracker tracker{site.simulator.camera(), small_config(), map};
  PreparedFrame prepared;
};

// The frame after a relocalisation has no motion to predict from:
// track_against_keyframe finds its pose from one keyframe's points by
// descriptors and PnP, whatever pose the result holds when it starts.
TEST_F(TrackerAtFrame10, TrackAgainstKeyframeNeedsNoPriorPose) {
  const config::SiteposeConfig config = small_config();
  const Relocaliser relocaliser(site.simulator.camera(), config.tracking,
                                map::ScalePyramid{config.orb.scale_factor, config.orb.n_levels});
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const map::KeyFrameId first = map.read([](const map::MapData& m) { return m.first_keyframe(); });
  const SE3 truth_T_world_cam = site.simulator.render(10).T_world_cam;
  PassResult result;
  result.point_of_keypoint.assign(prepared.size(), map::kNoPoint);
  // 3 m and 10 degrees from where the camera is.
  result.T_cam_world =
      (truth_T_world_cam * SE3(so3_exp(Eigen::Vector3d(0.0, 0.17, 0.0)), Eigen::Vector3d(3.0, 0.0, 0.5)))
          .inverse();
  ASSERT_TRUE(relocaliser.track_against_keyframe(map, prepared, all, first, result));
  EXPECT_FALSE(result.relocalised);
  EXPECT_GE(result.n_inliers, config.tracking.min_inliers_ok);
  EXPECT_LT((result.T_cam_world.inverse().translation() - truth_T_world_cam.translation()).norm(), 0.03);

  // A keyframe that is not in the map: false, and the result as it was.
  const PassResult before = result;
  EXPECT_FALSE(relocaliser.track_against_keyframe(map, prepared, all, first + 1000, result));
  EXPECT_EQ(result.n_inliers, before.n_inliers);
  EXPECT_EQ(result.point_of_keypoint, before.point_of_keypoint);
  // No usable keypoint: too few matches, the result as it was.
  const std::vector<std::uint8_t> none(prepared.size(), 0);
  EXPECT_FALSE(relocaliser.track_against_keyframe(map, prepared, none, first, result));
  EXPECT_LT((result.T_cam_world.matrix() - before.T_cam_world.matrix()).norm(), 1e-15);
}

TEST_F(TrackerAtFrame10, EstimateLeavesNoTrace) {
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const auto keyframes_before = map.read([](const map::MapData& m) { return m.keyframe_count(); });
  const auto last_before = tracker.last_T_world_cam();
  const PassResult first = tracker.estimate(prepared, all);
  const PassResult second = tracker.estimate(prepared, all);
  ASSERT_TRUE(first.valid);
  EXPECT_EQ(first.point_of_keypoint, second.point_of_keypoint);
  EXPECT_LT((first.T_cam_world.matrix() - second.T_cam_world.matrix()).norm(), 1e-12);
  EXPECT_EQ(map.read([](const map::MapData& m) { return m.keyframe_count(); }), keyframes_before);
  EXPECT_LT((tracker.last_T_world_cam()->matrix() - last_before->matrix()).norm(), 1e-15);
  // A pass that may use only half of the keypoints gives fewer inliers and
  // starting from the first pass's pose converges to the same place.
  std::vector<std::uint8_t> half(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); k += 2) half[k] = 1;
  const PassResult restricted = tracker.estimate(prepared, half);
  EXPECT_LT(restricted.n_inliers, first.n_inliers);
  for (int k = 1; k < prepared.size(); k += 2) EXPECT_EQ(restricted.point_of_keypoint[k], map::kNoPoint);
  const PassResult from_first = tracker.estimate(prepared, all, &first);
  EXPECT_LT((from_first.T_cam_world.translation() - first.T_cam_world.translation()).norm(), 0.005);
}

// Pass 2 searches pass 1's local map from pass 1's pose: every point pass 1
// matched is among the points pass 2 sees, and with twice the keypoints it
// finds more inliers than pass 1. (Here, 10 frames in, the reference
// keyframe's neighbourhood, pass 2's local map before b55d757, holds them
// all too; on `parked` it missed 291 of pass 1's points in 52 of 100 frames.)
TEST_F(TrackerAtFrame10, SecondPassSearchesTheFirstPassLocalMap) {
  std::vector<std::uint8_t> even(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); k += 2) even[k] = 1;
  const PassResult pass1 = tracker.estimate(prepared, even);
  ASSERT_TRUE(pass1.valid);
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const PassResult pass2 = tracker.estimate(prepared, all, &pass1);
  ASSERT_TRUE(pass2.valid);
  const std::set<map::PointId> seen(pass2.visible_points.begin(), pass2.visible_points.end());
  int matched_by_pass1 = 0, seen_by_pass2 = 0;
  for (const map::PointId id : pass1.point_of_keypoint) {
    if (id == map::kNoPoint) continue;
    ++matched_by_pass1;
    seen_by_pass2 += seen.count(id) != 0 ? 1 : 0;
  }
  EXPECT_EQ(seen_by_pass2, matched_by_pass1);
  EXPECT_GT(pass2.n_inliers, pass1.n_inliers);
}

// Pass 1's matches that pass 2 did not re-find are carried over when their
// keypoint is free, their point unclaimed and their reprojection under
// pass 2's pose within the chi2 gate; pass 2's own matches and inlier count
// stay. From a pose turned by 20 px nothing passes the gate.
TEST_F(TrackerAtFrame10, CarryOverAddsPassOneMatchesThatPassTwoDidNotRefind) {
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const PassResult pass1 = tracker.estimate(prepared, all);
  ASSERT_TRUE(pass1.valid);
  std::vector<std::uint8_t> even(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); k += 2) even[k] = 1;
  // A pass 2 that leaves the odd keypoints unmatched, as pass 2's search
  // leaves a fifth of pass 1's matches.
  const PassResult pass2 = tracker.estimate(prepared, even, &pass1);
  ASSERT_TRUE(pass2.valid);
  const std::set<map::PointId> claimed_by_pass2(pass2.point_of_keypoint.begin(),
                                                pass2.point_of_keypoint.end());
  int unclaimed = 0;  // pass 1's matches on keypoints pass 2 left free, to points pass 2 did not match
  for (int k = 1; k < prepared.size(); k += 2) {
    const map::PointId id = pass1.point_of_keypoint[k];
    unclaimed += id != map::kNoPoint && claimed_by_pass2.count(id) == 0 ? 1 : 0;
  }
  ASSERT_GT(unclaimed, 50);

  PassResult merged = pass2;
  const int carried = tracker.carry_over_matches(prepared, pass1, merged);
  EXPECT_LE(carried, unclaimed);
  EXPECT_GE(carried, unclaimed * 9 / 10);  // the rest are outside the gate at pass 2's pose
  EXPECT_EQ(merged.n_inliers, pass2.n_inliers);
  EXPECT_LT((merged.T_cam_world.matrix() - pass2.T_cam_world.matrix()).norm(), 1e-15);
  std::set<map::PointId> ids;
  int matches = 0;
  for (int k = 0; k < prepared.size(); ++k) {
    if (pass2.point_of_keypoint[k] != map::kNoPoint) {
      EXPECT_EQ(merged.point_of_keypoint[k], pass2.point_of_keypoint[k]);
    } else if (merged.point_of_keypoint[k] != map::kNoPoint) {
      EXPECT_EQ(merged.point_of_keypoint[k], pass1.point_of_keypoint[k]);
    }
    if (merged.point_of_keypoint[k] == map::kNoPoint) continue;
    ++matches;
    ids.insert(merged.point_of_keypoint[k]);
  }
  EXPECT_EQ(static_cast<int>(ids.size()), matches) << "a point matched at two keypoints";
  EXPECT_EQ(tracker.carry_over_matches(prepared, pass1, merged), 0) << "carried twice";

  PassResult turned = pass2;  // every point 20 px off
  const double yaw = 20.0 / site.simulator.camera().fx;
  turned.T_cam_world =
      SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())), Eigen::Vector3d::Zero()) *
      pass2.T_cam_world;
  EXPECT_EQ(tracker.carry_over_matches(prepared, pass1, turned), 0);
}

// The map check's matching: only the usable keypoints are matched, to the
// same points a full estimate finds; a pose guess 8 px off needs the wider
// radius (radii scale by 2.5 for points seen head-on, as in the local map
// search: 1 -> 2.5 px, 7 -> 17.5 px).
TEST_F(TrackerAtFrame10, SearchLocalMapMatchesOnlyTheUsableKeypoints) {
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const PassResult full = tracker.estimate(prepared, all);
  ASSERT_TRUE(full.valid);
  std::vector<std::uint8_t> even(prepared.size(), 0), odd(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); ++k) (k % 2 == 0 ? even : odd)[k] = 1;
  const PassResult anchor = tracker.estimate(prepared, even);
  ASSERT_TRUE(anchor.valid);

  const std::vector<map::PointId> found = tracker.search_local_map(prepared, odd, anchor, 7.0);
  int matched = 0, same_as_full = 0, full_odd = 0;
  for (int k = 0; k < prepared.size(); ++k) {
    if (!odd[k]) {
      EXPECT_EQ(found[k], map::kNoPoint);
      continue;
    }
    full_odd += full.point_of_keypoint[k] != map::kNoPoint ? 1 : 0;
    if (found[k] == map::kNoPoint) continue;
    ++matched;
    same_as_full += found[k] == full.point_of_keypoint[k] ? 1 : 0;
  }
  EXPECT_GE(matched, full_odd * 8 / 10);
  EXPECT_GE(same_as_full, matched * 8 / 10);  // a duplicate point (not fused yet) may win

  // Turned by 8 px (yaw): the local map's radius loses most matches.
  PassResult turned = anchor;
  const double yaw = 8.0 / site.simulator.camera().fx;
  turned.T_cam_world =
      SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())), Eigen::Vector3d::Zero()) *
      anchor.T_cam_world;
  const auto count = [](const std::vector<map::PointId>& ids) {
    return std::count_if(ids.begin(), ids.end(), [](map::PointId id) { return id != map::kNoPoint; });
  };
  const auto wide = count(tracker.search_local_map(prepared, odd, turned, 7.0));
  const auto narrow = count(tracker.search_local_map(prepared, odd, turned, 1.0));
  EXPECT_GE(wide, matched * 8 / 10);
  EXPECT_LT(narrow, wide / 2) << "wide " << wide << ", narrow " << narrow << ", matched " << matched
                              << ", same " << same_as_full;
}

// Checks that `local` gives each of `anchor`'s matches as the index of its
// point and -1 elsewhere; returns how many keypoints it anchors.
int anchored_into(const AnchorLocalMap& local, const PassResult& anchor) {
  EXPECT_EQ(local.match_of_anchor.size(), anchor.point_of_keypoint.size());
  int anchored = 0;
  for (std::size_t k = 0; k < local.match_of_anchor.size() && k < anchor.point_of_keypoint.size(); ++k) {
    const int i = local.match_of_anchor[k];
    if (anchor.point_of_keypoint[k] == map::kNoPoint) {
      EXPECT_EQ(i, -1);
      continue;
    }
    EXPECT_TRUE(i >= 0 && static_cast<std::size_t>(i) < local.points.size()) << "keypoint " << k << ": " << i;
    if (i < 0 || static_cast<std::size_t>(i) >= local.points.size()) continue;
    EXPECT_EQ(local.points[static_cast<std::size_t>(i)].id, anchor.point_of_keypoint[k]);
    ++anchored;
  }
  return anchored;
}

// The map check and pass 2 share pass 1's local map, listed once: searching
// the listed map gives what listing it again gives. The anchor's matches
// point into the list; a tracker with a pool lists the same points in the
// same order.
TEST_F(TrackerAtFrame10, ALocalMapListedOnceServesTheMapCheckAndPassTwo) {
  std::vector<std::uint8_t> even(prepared.size(), 0), odd(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); ++k) (k % 2 == 0 ? even : odd)[k] = 1;
  const PassResult pass1 = tracker.estimate(prepared, even);
  ASSERT_TRUE(pass1.valid);
  const AnchorLocalMap local = tracker.local_map_of(prepared, pass1);
  const int anchored = anchored_into(local, pass1);
  EXPECT_EQ(anchored, pass1.n_inliers);
  EXPECT_GT(local.points.size(), static_cast<std::size_t>(anchored));  // the keyframes' other points too

  EXPECT_EQ(tracker.search_local_map(prepared, odd, pass1, 7.0, &local),
            tracker.search_local_map(prepared, odd, pass1, 7.0));
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const PassResult pass2_listed_again = tracker.estimate(prepared, all, &pass1);
  const PassResult pass2_shared = tracker.estimate(prepared, all, &pass1, &local);
  ASSERT_TRUE(pass2_shared.valid);
  EXPECT_EQ(pass2_shared.point_of_keypoint, pass2_listed_again.point_of_keypoint);
  EXPECT_EQ(pass2_shared.visible_points, pass2_listed_again.visible_points);
  EXPECT_LT((pass2_shared.T_cam_world.matrix() - pass2_listed_again.T_cam_world.matrix()).norm(), 1e-15);

  features::TaskPool pool(1);
  const Tracker pooled{site.simulator.camera(), small_config(), map, {}, &pool};
  const AnchorLocalMap pooled_local = pooled.local_map_of(prepared, pass1);
  ASSERT_EQ(pooled_local.points.size(), local.points.size());
  for (std::size_t i = 0; i < local.points.size(); ++i)
    EXPECT_EQ(pooled_local.points[i].id, local.points[i].id);
  EXPECT_EQ(pooled_local.match_of_anchor, local.match_of_anchor);
}

// A pass keeps the local map it listed and searched, its inliers as
// indices into it, for the map check and pass 2; a pass from an anchor
// (which searched the anchor's map) keeps none.
TEST_F(TrackerAtFrame10, APassKeepsTheLocalMapItSearched) {
  std::vector<std::uint8_t> even(prepared.size(), 0);
  for (int k = 0; k < prepared.size(); k += 2) even[k] = 1;
  const PassResult pass1 = tracker.estimate(prepared, even);
  ASSERT_TRUE(pass1.valid);
  ASSERT_NE(pass1.local_map, nullptr);
  const AnchorLocalMap& local = *pass1.local_map;
  const int anchored = anchored_into(local, pass1);
  EXPECT_EQ(anchored, pass1.n_inliers);
  const std::vector<std::uint8_t> all(prepared.size(), 1);
  const PassResult pass2 = tracker.estimate(prepared, all, &pass1, pass1.local_map.get());
  ASSERT_TRUE(pass2.valid);
  EXPECT_GT(pass2.n_inliers, pass1.n_inliers);
  EXPECT_EQ(pass2.local_map, nullptr);
}

// The dynamic layer's pass 1 tracks on the background (instance 0) alone.
// An unmasked static object keeps the total inlier count high while the
// background shrinks; the keyframe rule must still renew the background.
TEST(Tracker, RenewsTheBackgroundWhileStaticObjectsKeepTheTotalHigh) {
  constexpr int kFrames = 36;
  const SmallSite site = SmallSite::make("static", kFrames);
  struct Run {
    int keyframes = 0;
    int last_background_inliers = 0;
  };
  // shrinking_background: the image right of a boundary that moves from 70 %
  // to 15 % of the width is a static object, used like the background.
  const auto run = [&](bool shrinking_background) {
    map::SharedMap map;
    const config::SiteposeConfig config = small_config();
    mapping::LocalMapper mapper(site.simulator.camera(), config.mapping, config.tracking, map);
    Tracker tracker(site.simulator.camera(), config, map, link_to(mapper));
    Run out;
    for (int i = 0; i < kFrames; ++i) {
      const StereoFrame frame = site.frame(i);
      cv::Mat labels(frame.left.size(), CV_16UC1, cv::Scalar(0));
      if (shrinking_background) {
        const double share = 0.7 - 0.55 * i / (kFrames - 1);
        labels.colRange(static_cast<int>(share * labels.cols), labels.cols).setTo(1);
      }
      auto prepared = tracker.prepare(frame, labels);
      EXPECT_TRUE(prepared.has_value());
      if (!prepared) return out;
      const std::vector<std::uint8_t> all(prepared->size(), 1);
      const PassResult result = tracker.estimate(*prepared, all);
      EXPECT_EQ(tracker.commit(*prepared, result, all).state, TrackingState::kOk) << "frame " << i;
      EXPECT_TRUE(mapper.process_pending().has_value());
      out.last_background_inliers = 0;
      for (int k = 0; k < prepared->size(); ++k) {
        if (prepared->instance[k] == 0 && result.point_of_keypoint[k] != map::kNoPoint) {
          ++out.last_background_inliers;
        }
      }
    }
    out.keyframes = tracker.counters().keyframes_created;
    return out;
  };
  const Run plain = run(false);
  const Run shrinking = run(true);
  std::printf("[figures] keyframes: plain %d, shrinking background %d (%d background inliers at the end)\n",
              plain.keyframes, shrinking.keyframes, shrinking.last_background_inliers);
  // The background fell to about a fifth of its width: a keyframe for each
  // quarter lost, beyond those the plain run needs.
  EXPECT_GE(shrinking.keyframes, plain.keyframes + 3);
}

// Issue 19: a strip driven again is tracked against the keyframes of the
// first pass, not mapped again. `backforth` drives 16 m out (frames 12-108),
// stands, and drives the same 16 m back (120-216). The travel rule asks for
// a keyframe only away from every keyframe that shares a good part of the
// frame's matches. When it looked only at the one sharing most (mostly the
// last made, whose fresh points the frame matches best) the way back made
// 10 keyframes here (the way out 17); now 1.
TEST(Tracker, AStripDrivenAgainIsTrackedAgainstItsKeyframes) {
  constexpr int kFrames = 240;
  constexpr int kWayBackFrom = 120;
  const SmallSite site = SmallSite::make("backforth", kFrames);
  map::SharedMap map;
  const config::SiteposeConfig config = small_config();
  mapping::LocalMapper mapper(site.simulator.camera(), config.mapping, config.tracking, map);
  Tracker tracker(site.simulator.camera(), config, map, link_to(mapper));
  int keyframes_out = 0;
  double max_error_m = 0.0;
  for (int i = 0; i < kFrames; ++i) {
    if (i == kWayBackFrom) keyframes_out = tracker.counters().keyframes_created;
    ASSERT_TRUE(track_expecting_ok(tracker, site, i, max_error_m).has_value());
    ASSERT_TRUE(mapper.process_pending().has_value());
  }
  const int keyframes_back = tracker.counters().keyframes_created - keyframes_out;
  std::printf("[figures] keyframes made on the way out %d, on the way back %d; largest error %.4f m\n",
              keyframes_out, keyframes_back, max_error_m);
  EXPECT_GE(keyframes_out, 8) << "the way out maps the strip";
  EXPECT_LE(keyframes_back, 3) << "the way back re-uses it";
  EXPECT_LT(max_error_m, 0.1);
}

TEST(Tracker, PrepareTagsInstancesAndMovesTheBudget) {
  const SmallSite site = SmallSite::make("parked", 1);
  map::SharedMap map;
  Tracker tracker(site.simulator.camera(), small_config(), map);
  sim::SimFrame truth;
  const StereoFrame frame = site.frame(0, &truth);
  ASSERT_GT(cv::countNonZero(truth.instance_mask), 0) << "parked must show machines";
  auto tagged = tracker.prepare(frame, truth.instance_mask);
  ASSERT_TRUE(tagged.has_value());
  int on_objects = 0;
  for (int k = 0; k < tagged->size(); ++k) {
    const cv::Point p(static_cast<int>(std::lround(tagged->uv_px[k].x())),
                      static_cast<int>(std::lround(tagged->uv_px[k].y())));
    EXPECT_EQ(tagged->instance[k], truth.instance_mask.at<std::uint16_t>(p));
    on_objects += tagged->instance[k] != 0 ? 1 : 0;
  }
  EXPECT_GT(on_objects, 0);
  // With the objects as extraction mask, the background gets the full budget.
  const cv::Mat mask = truth.instance_mask != 0;
  auto split = tracker.prepare(frame, truth.instance_mask, mask);
  ASSERT_TRUE(split.has_value());
  int background_plain = 0;
  int background_split = 0;
  for (auto id : tagged->instance) background_plain += id == 0 ? 1 : 0;
  for (auto id : split->instance) background_split += id == 0 ? 1 : 0;
  EXPECT_GT(background_split, background_plain);
}

TEST(Tracker, RejectsFramesOfTheWrongSize) {
  const SmallSite site = SmallSite::make("static", 1);
  map::SharedMap map;
  Tracker tracker(site.simulator.camera(), small_config(), map);
  StereoFrame frame = site.frame(0);
  cv::resize(frame.left, frame.left, cv::Size(), 0.5, 0.5);
  cv::resize(frame.right, frame.right, cv::Size(), 0.5, 0.5);
  auto prepared = tracker.prepare(frame);
  ASSERT_FALSE(prepared.has_value());
  EXPECT_NE(prepared.error().message.find("240x135"), std::string::npos) << prepared.error().message;
}

}  // namespace
}  // namespace sitepose::tracking
