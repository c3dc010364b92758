// Motion states on the scenarios of issue 22: articulated machines that
// work in place (slewing), a standing camera (standing, stopgo) and a
// crowded site, with people on foot (crowded-people). Figures per scenario:
// balanced accuracy of the decided verdicts, ROC AUC of the motion score,
// the share of testable object-frames left unknown, and the unsafe error
// (moving called static), per class and per unknown reason; each stop and
// how long the machine stays masked after it. SITEPOSE_STATES_DUMP=1 prints
// every object-frame.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "dynamic_scenario.hpp"

namespace sitepose::experiments {
namespace {

void print_scores(const std::string& scenario, const std::string& what, const StateScores& s) {
  std::printf(
      "[figures] %s %-10s samples %4d testable %4d  balanced accuracy %.3f  AUC %.3f (all %.3f)  unknown "
      "%.1f %%  "
      "static->static %d static->moving %d moving->moving %d moving->static %d  unknown:",
      scenario.c_str(), what.c_str(), s.samples, s.testable, s.balanced_accuracy(), s.auc, s.auc_all,
      100.0 * s.unknown_share(), s.static_called_static, s.static_called_moving, s.moving_called_moving,
      s.moving_called_static);
  for (const auto& [reason, n] : s.unknown_by_reason) std::printf(" %s %d", reason.c_str(), n);
  std::printf("\n");
}

void dump(const DynamicRunResult& run) {
  if (std::getenv("SITEPOSE_STATES_DUMP") == nullptr) return;
  for (const ObjectSample& s : run.samples) {
    const dynamic::ObjectVerdict& v = s.object.verdict;
    std::printf(
        "  f %lld id %u %-9s gt %d raw %-7s state %-7s %-14s matched %3d points %3d score %8.2f pooled %8.2f "
        "part %8.2f ref %lld\n",
        static_cast<long long>(s.frame), v.instance, v.class_name.c_str(), s.moving_gt.value_or(-1),
        dynamic::to_string(v.raw), dynamic::to_string(v.state), dynamic::to_string(v.unknown_reason),
        v.matched_points, v.points, v.score, v.pooled_statistic, v.part_statistic,
        static_cast<long long>(v.reference_seq));
  }
}

// Each moving-called-static object-frame (the unsafe error), to tell a
// start from rest from a miss in mid-motion.
void print_moving_called_static(const std::string& scenario, const DynamicRunResult& run) {
  for (const ObjectSample& s : run.samples) {
    if (s.moving_gt && *s.moving_gt && s.object.verdict.state == dynamic::MotionState::kStatic) {
      std::printf("[figures] %s moving called static: frame %lld, %s %u, %d matched points\n",
                  scenario.c_str(), static_cast<long long>(s.frame), s.object.verdict.class_name.c_str(),
                  s.object.verdict.instance, s.object.verdict.matched_points);
    }
  }
}

struct Figures {
  StateScores all;
  std::map<std::string, StateScores> by_class;
  std::vector<UnmaskEvent> stops;  // machines and people that stop
  double fps = 0.0;
  DynamicRunResult run;
};

// Frames (and seconds) from each true stop to the first unmasked frame.
void print_stops(const std::string& scenario, const std::vector<UnmaskEvent>& stops, double fps) {
  for (const UnmaskEvent& e : stops) {
    std::printf(
        "[figures] %s %s %u stops at frame %lld (%d frames): unmasked after %d frames (%.2f s), %d testable "
        "frames before\n",
        scenario.c_str(), e.class_name.c_str(), e.instance, static_cast<long long>(e.stop_frame),
        e.stop_frames, e.latency_frames, e.latency_frames >= 0 ? e.latency_frames / fps : NAN,
        e.testable_frames);
  }
}

// SITEPOSE_STATES_SEED renders another seed of the scenario (figures over
// several renderings); default the scenario's.
std::optional<int> seed_from_env() {
  if (const char* env = std::getenv("SITEPOSE_STATES_SEED"); env && *env) return std::atoi(env);
  return std::nullopt;
}

Figures run_full(const std::string& scenario, int frames) {
  Figures f;
  Scenario s(scenario, frames_from_env(frames), seed_from_env());
  EXPECT_TRUE(s.error().empty()) << s.error();
  if (!s.error().empty()) return f;
  ModeFigures full = s.run(config::MaskingMode::kFull);
  f.run = std::move(full.run);
  dump(f.run);
  f.all = score_states(f.run.samples, kMinObjectPoints);
  print_scores(scenario, "all", f.all);
  print_moving_called_static(scenario, f.run);
  f.stops = unmask_latencies(f.run.samples, kMinObjectPoints);
  f.fps = s.fps();
  print_stops(scenario, f.stops, f.fps);
  std::set<std::string> classes;
  for (const ObjectSample& smp : f.run.samples) classes.insert(smp.object.verdict.class_name);
  for (const std::string& c : classes) {
    f.by_class[c] = score_states(f.run.samples, kMinObjectPoints, c);
    print_scores(scenario, c, f.by_class[c]);
  }
  return f;
}

// Unmasked share of a never-moving instance over its testable frames.
double unmasked_share(const DynamicRunResult& run, std::uint16_t instance) {
  int testable = 0, unmasked = 0;
  for (const ObjectSample& s : run.samples) {
    if (s.object.verdict.instance != instance || s.object.verdict.matched_points < kMinObjectPoints) continue;
    ++testable;
    unmasked += s.object.verdict.state == dynamic::MotionState::kStatic ? 1 : 0;
  }
  std::printf("[figures] instance %u unmasked in %d of %d testable frames\n", instance, unmasked, testable);
  return testable > 0 ? static_cast<double>(unmasked) / testable : 0.0;
}

// Issue 22: a machine that stops is unmasked within a second or two. The
// first stop of `instance` must be unmasked within `max_s` of its true stop.
void expect_unmasked_within(const Figures& f, std::uint16_t instance, double max_s) {
  const auto stop = std::find_if(f.stops.begin(), f.stops.end(),
                                 [&](const UnmaskEvent& e) { return e.instance == instance; });
  ASSERT_NE(stop, f.stops.end()) << "instance " << instance << " never stops in view";
  EXPECT_GE(stop->latency_frames, 0) << "still masked when its stop ended";
  EXPECT_LE(stop->latency_frames, max_s * f.fps);
}

// Moving-called-static object-frames that are NOT within the first
// `frames` frames of a start (the ground truth said static `frames` earlier).
int late_moving_called_static(const DynamicRunResult& run, int frames) {
  std::map<std::pair<std::uint16_t, std::int64_t>, bool> moving;
  for (const ObjectSample& s : run.samples) {
    if (s.moving_gt) moving[{s.object.verdict.instance, s.frame}] = *s.moving_gt;
  }
  int late = 0;
  for (const ObjectSample& s : run.samples) {
    if (!s.moving_gt || !*s.moving_gt || s.object.verdict.state != dynamic::MotionState::kStatic) continue;
    const auto before = moving.find({s.object.verdict.instance, s.frame - frames});
    const bool started_recently = before != moving.end() && !before->second;
    if (!started_recently) {
      ++late;
      std::printf("[figures] moving called static at frame %lld, instance %u, moving for over %d frames\n",
                  static_cast<long long>(s.frame), s.object.verdict.instance, frames);
    }
  }
  return late;
}

// Moving-called-static object-frames of `class_name` after the instance was
// once in state moving: a machine seen working must not be used as static
// while a part of it moves.
int moving_called_static_once_seen_moving(const DynamicRunResult& run, const std::string& class_name) {
  std::set<std::uint16_t> seen_moving;
  int n = 0;
  for (const ObjectSample& s : run.samples) {
    const dynamic::ObjectVerdict& v = s.object.verdict;
    if (v.class_name != class_name) continue;
    if (s.moving_gt && *s.moving_gt && v.state == dynamic::MotionState::kStatic &&
        seen_moving.count(v.instance)) {
      ++n;
    }
    if (v.state == dynamic::MotionState::kMoving) seen_moving.insert(v.instance);
  }
  std::printf("[figures] %s moving called static after a moving state: %d\n", class_name.c_str(), n);
  return n;
}

// Two excavators slew and dig while their tracks stand (the ego drives 12 s,
// then stands); a third (EX 120, id 3) never moves. Issue 22 asks 0
// moving-called-static frames. Bounds: what holds on seeds 7, 8 and 9
// (docs/dynamic/motion_states.md), not on the default seed 7 alone. A
// machine seen working stays masked between strokes: 0 such frames after
// its first moving state on every seed (before: 30 / 40 / 4). What is left
// is a machine's first stroke, before any moving verdict: 32 / 17 / 1 with
// the issue-24 tracking defaults, 28 / 14 / 0 of them more than 3 frames
// into the stroke (before those defaults 1 / 29 / 2 and at most 26 late;
// the moving house loses its matches and the standing tracks look static:
// seed 7, excavator 2, frames 73-82 and 93-100 with 8-65 points at scores
// under 3.3). Balanced accuracy 0.849 / 0.866 / 0.993; EX 120 unmasked in
// 97 / 96 / 98 % of its testable frames.
TEST(MotionStates, Slewing) {
  const Figures f = run_full("slewing", 150);
  EXPECT_EQ(moving_called_static_once_seen_moving(f.run, "excavator"), 0);
  EXPECT_LE(late_moving_called_static(f.run, 3), 28);
  EXPECT_LE(f.by_class.at("excavator").moving_called_static, 32);
  EXPECT_GE(f.all.balanced_accuracy(), 0.79);
  EXPECT_LE(f.all.unknown_share(), 0.45);
  EXPECT_GE(unmasked_share(f.run, 3), 0.9);
}

// The ego stands while a truck passes twice and a roller starts and stops
// (the time-chosen reference). Measured (seed 21, 150 frames): balanced
// accuracy 0.971, AUC 0.957, unknown 2.7 %, moving called static 0; the
// parked excavator is called moving in 2 of 124 testable frames (safe). The
// roller stops at frame 136 and is unmasked 6 frames (1.0 s) later (seeds
// 21, 22, 23; docs/dynamic/motion_states.md).
TEST(MotionStates, Standing) {
  const Figures f = run_full("standing", 150);
  EXPECT_EQ(f.all.moving_called_static, 0);
  EXPECT_LE(f.all.unknown_share(), 0.1);
  EXPECT_GE(f.all.balanced_accuracy(), 0.95);
  expect_unmasked_within(f, 2, 2.0);
}

// The ego stands while the truck passes (in view in frames 212-368, moving
// in all of them); the roller comes into view at frame 443, beyond these
// frames, and neither stops in view. With no static ground truth balanced
// accuracy and AUC are undefined (NaN), so the decided verdicts are bounded
// through the unknown share. Measured (seeds 5, 6, 7): 70-71 testable
// object-frames, unknown 0 / 1.4 / 0 %, 70 moving called moving, moving
// called static 0.
TEST(MotionStates, Stopgo) {
  const Figures f = run_full("stopgo", 300);
  EXPECT_GE(f.all.testable, 60);
  EXPECT_EQ(f.all.static_called_static + f.all.static_called_moving, 0) << "static truth: bound BA and AUC";
  EXPECT_EQ(f.all.moving_called_static, 0);
  EXPECT_LE(f.all.unknown_share(), 0.05);
}

TEST(MotionStates, Crowded) {
  const Figures f = run_full("crowded", 150);
  EXPECT_EQ(f.all.moving_called_static, 0);
  EXPECT_GE(f.all.balanced_accuracy(), 0.95);  // measured 1.000, AUC 0.982, unknown 2.3 %
  EXPECT_LE(f.all.unknown_share(), 0.1);
}

// crowded with three people on foot, 216 frames: the walking person is in
// view in frames 0-128 (walking from frame 38), the crouching one in frames
// 108-148; the roller stops at frame 183 for 22 frames; the parked truck
// drives off at frame 180. Measured (seeds 4, 5, 6): no person frame is
// testable more than once (a person's static verdict needs 16 points), so
// people stay masked and are never called static; moving called static
// 4 / 4 / 3 object-frames, all machines in the first 2 frames of a start
// (issue 22 asks 0; this guards the figure); the roller is unmasked 1 / 1 / 0
// frames after its stop.
TEST(MotionStates, CrowdedPeople) {
  const Figures f = run_full("crowded-people", 216);
  ASSERT_EQ(f.by_class.count("person"), 1u);
  EXPECT_GE(f.by_class.at("person").samples, 100);  // measured 145-146
  EXPECT_EQ(f.by_class.at("person").moving_called_static, 0);
  EXPECT_LE(f.all.moving_called_static, 4);
  EXPECT_GE(f.all.balanced_accuracy(), 0.95);  // measured 0.984-0.990
  expect_unmasked_within(f, 2, 2.0);
}

}  // namespace
}  // namespace sitepose::experiments
