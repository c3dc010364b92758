#include "sitepose/dynamic/motion_classifier.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>

#include "sitepose/testing/cameras.hpp"

namespace sitepose::dynamic {
namespace {

using testing::test_camera;

// An object: world points on a 3 m x 2 m patch 10 m in front of the origin
// camera, each with its own random descriptor.
struct Object {
  std::uint16_t instance = 1;
  std::vector<Eigen::Vector3d> p_world;
  cv::Mat descriptors;
};

Object make_object(std::uint16_t instance, int n, double x_offset_m, std::mt19937& rng) {
  Object o;
  o.instance = instance;
  std::uniform_real_distribution<double> ux(-1.5, 1.5), uy(-1.0, 1.0), uz(-0.3, 0.3);
  o.descriptors.create(n, 32, CV_8UC1);
  cv::randu(o.descriptors, cv::Scalar(0), cv::Scalar(256));
  for (int i = 0; i < n; ++i) o.p_world.emplace_back(x_offset_m + ux(rng), uy(rng), 10.0 + uz(rng));
  return o;
}

// Observes the objects (each displaced by its own world offset) from
// T_world_cam with pixel noise sigma_px.
ObjectFeatures observe(const std::vector<Object>& objects, const std::vector<Eigen::Vector3d>& offsets,
                       const SE3& T_world_cam, std::int64_t seq, double sigma_px, std::mt19937& rng) {
  const StereoCamera cam = test_camera();
  std::normal_distribution<double> noise(0.0, sigma_px);
  ObjectFeatures f;
  f.seq = seq;
  f.t_ns = seq * 166'666'667;
  f.T_world_cam = T_world_cam;
  f.covariance = Matrix6d::Identity() * 1e-6;
  std::vector<cv::Mat> rows;
  for (std::size_t j = 0; j < objects.size(); ++j) {
    const Object& o = objects[j];
    const std::size_t first = f.uv_px.size();
    for (std::size_t i = 0; i < o.p_world.size(); ++i) {
      const Eigen::Vector3d p_cam = T_world_cam.inverse() * (o.p_world[i] + offsets[j]);
      const Eigen::Vector3d s = cam.project_stereo(p_cam);
      f.uv_px.emplace_back(s.x() + noise(rng), s.y() + noise(rng));
      f.u_right_px.push_back(s.z() + noise(rng));
      f.octave.push_back(0);
      f.instance.push_back(o.instance);
      rows.push_back(o.descriptors.row(static_cast<int>(i)));
    }
    // The detector's box: around the object's keypoints.
    cv::Rect2d box(f.uv_px[first].x(), f.uv_px[first].y(), 0.0, 0.0);
    for (std::size_t i = first; i < f.uv_px.size(); ++i)
      box |= cv::Rect2d(f.uv_px[i].x(), f.uv_px[i].y(), 1.0, 1.0);
    f.boxes.push_back({o.instance, "truck", 1.0, cv::Rect(box)});
  }
  cv::vconcat(rows, f.descriptors);
  return f;
}

SE3 at_x(double x_m) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x_m, 0.0, 0.0)); }

config::DynamicConfig config_for(config::ClassifierMode mode) {
  config::DynamicConfig c;
  c.classifier = mode;
  c.reference_offset_frames = 2;
  c.hysteresis_frames = 2;
  c.min_object_points = 8;
  return c;
}

TEST(MotionClassifier, PaperModeStaticAndMovingObjects) {
  std::mt19937 rng(1);
  const std::vector<Object> objects{make_object(1, 60, -2.0, rng), make_object(2, 60, 2.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kPaper), 6.0, 1.2, 8);
  // Object 2 moves 0.3 m per frame (1.8 m/s at 6 fps): 0.6 m over N = 2
  // frames, beyond 3 sigma_bkg = 0.36 m.
  for (int k = 0; k < 3; ++k) {
    classifier.remember(observe(objects, {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.3 * k, 0, 0)},
                                at_x(0.1 * k), k, 0.2, rng));
  }
  const auto out = classifier.classify(
      observe(objects, {Eigen::Vector3d::Zero(), Eigen::Vector3d(0.9, 0, 0)}, at_x(0.3), 3, 0.2, rng));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].verdict.state, MotionState::kStatic);
  EXPECT_EQ(out[0].verdict.reference_seq, 1);  // N = 2 frames back
  EXPECT_EQ(out[0].verdict.reference_instance, 1);
  EXPECT_GT(out[0].verdict.score, 0.7);
  EXPECT_EQ(out[1].verdict.state, MotionState::kMoving);
  EXPECT_LT(out[1].verdict.score, 0.7);
  // Kept points: those below the median, about half of the matches.
  EXPECT_GE(out[0].verdict.points, 20);
  EXPECT_LE(out[0].verdict.points, 31);
}

TEST(MotionClassifier, PaperModeWithoutReferenceFrameIsUnknown) {
  std::mt19937 rng(2);
  const std::vector<Object> objects{make_object(1, 60, 0.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kPaper), 6.0, 1.2, 8);
  classifier.remember(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.0), 0, 0.2, rng));
  const auto out = classifier.classify(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.1), 1, 0.2, rng));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].verdict.state, MotionState::kUnknown);
  EXPECT_EQ(out[0].verdict.reference_seq, -1);
}

TEST(MotionClassifier, TooFewPointsIsUnknown) {
  std::mt19937 rng(3);
  const std::vector<Object> objects{make_object(1, 6, 0.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  classifier.remember(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.0), 0, 0.2, rng));
  for (int k = 1; k < 4; ++k) {
    const auto out =
        classifier.classify(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.2 * k), k, 0.2, rng));
    ASSERT_EQ(out.size(), 1u);
    EXPECT_EQ(out[0].verdict.raw, MotionState::kUnknown);
    EXPECT_EQ(out[0].verdict.state, MotionState::kUnknown);
  }
}

TEST(MotionClassifier, SiteposeReferenceByParallaxElseOldest) {
  std::mt19937 rng(4);
  const std::vector<Object> objects{make_object(1, 60, 0.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  const double x[] = {0.0, 0.05, 0.10, 0.20, 0.25};
  for (int k = 0; k < 5; ++k) {
    classifier.remember(observe(objects, {Eigen::Vector3d::Zero()}, at_x(x[k]), k, 0.2, rng));
  }
  // CF at 0.30 m: newest frame >= 0.15 m away is seq 2 (0.10 m).
  auto out = classifier.classify(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.30), 5, 0.2, rng));
  EXPECT_EQ(out[0].verdict.reference_seq, 2);
  // Camera at 0.12 m: no kept frame 0.15 m away, the oldest is used.
  out = classifier.classify(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.12), 6, 0.2, rng));
  EXPECT_EQ(out[0].verdict.reference_seq, 0);
}

TEST(MotionClassifier, SiteposeHysteresisUnmasksAfterTwoVerdictsAndRemasksAtOnce) {
  std::mt19937 rng(5);
  const std::vector<Object> objects{make_object(1, 80, 0.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  int seq = 0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  auto step = [&](double camera_x, const Eigen::Vector3d& object_offset) {
    const ObjectFeatures f = observe(objects, {object_offset}, at_x(camera_x), seq++, 0.2, rng);
    auto out = classifier.classify(f);
    classifier.remember(f);
    return out[0].verdict;
  };
  step(0.0, offset);
  ObjectVerdict v = step(0.2, offset);
  EXPECT_EQ(v.raw, MotionState::kStatic);
  EXPECT_EQ(v.state, MotionState::kUnknown);  // 1/6 s is too short to call it static
  v = step(0.4, offset);
  EXPECT_EQ(v.state, MotionState::kUnknown);  // 1/3 s: still too short
  v = step(0.6, offset);
  EXPECT_EQ(v.reference_seq, 0);
  EXPECT_EQ(v.state, MotionState::kUnknown);  // first counted static verdict (0.5 s)
  v = step(0.8, offset);
  EXPECT_EQ(v.state, MotionState::kStatic);  // second: unmasked
  for (int k = 0; k < 5; ++k) {
    v = step(1.0 + 0.2 * k, offset);
    EXPECT_EQ(v.state, MotionState::kStatic) << "frame " << k;  // no flicker
  }
  // The object starts moving: one moving verdict re-masks it.
  offset = Eigen::Vector3d(0.3, 0.0, 0.0);
  v = step(2.0, offset);
  EXPECT_EQ(v.raw, MotionState::kMoving);
  EXPECT_EQ(v.state, MotionState::kMoving);
}

// Points matched to the wrong place (here: a wrong stereo partner, 20 px
// off) do not share the object's displacement. A minority of them is left
// out of the test, whichever way the object moves; a majority leaves no
// common displacement to test (unknown).
TEST(MotionClassifier, SiteposeTestsOnlyThePointsThatShareTheObjectsDisplacement) {
  const auto raw_verdict = [](double mismatched_fraction, const Eigen::Vector3d& motion) {
    std::mt19937 rng(13);
    const std::vector<Object> objects{make_object(1, 60, 0.0, rng)};
    MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
    const ObjectFeatures reference = observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.0), 0, 0.2, rng);
    classifier.classify(reference);
    classifier.remember(reference);
    ObjectFeatures current = observe(objects, {motion}, at_x(0.5), 3, 0.2, rng);
    const int mismatched = static_cast<int>(mismatched_fraction * 60);
    for (int i = 0; i < mismatched; ++i) current.u_right_px[i] -= 20.0;  // points lie at random
    return classifier.classify(current)[0].verdict;
  };
  const Eigen::Vector3d parked = Eigen::Vector3d::Zero();
  const Eigen::Vector3d driving(0.3, 0.0, 0.0);
  ObjectVerdict v = raw_verdict(0.0, parked);
  EXPECT_EQ(v.raw, MotionState::kStatic);
  EXPECT_EQ(v.points, 60);
  v = raw_verdict(0.35, parked);
  EXPECT_EQ(v.raw, MotionState::kStatic);  // the paper's 70 % rule over all points would say otherwise
  EXPECT_EQ(v.points, 60 - 21);
  EXPECT_EQ(raw_verdict(0.35, driving).raw, MotionState::kMoving);
  v = raw_verdict(0.6, parked);
  EXPECT_EQ(v.raw, MotionState::kUnknown);
  EXPECT_EQ(v.points, 60);
}

// An excavator's house turns on its standing tracks, and at the start of a
// slew it loses its matches while the tracks keep theirs. Points on the
// tracks alone (the lowest 30 % of the box) do not make it static; the
// same points of a truck do, and so do the excavator's with its upper
// structure matched.
TEST(MotionClassifier, SiteposeExcavatorIsStaticOnlyWithPointsOnItsUpperStructure) {
  const auto raw_verdict = [](const std::string& class_name, bool upper_structure_matched) {
    std::mt19937 rng(23);
    const std::vector<Object> objects{make_object(1, 60, 0.0, rng)};
    MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
    ObjectFeatures reference = observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.0), 0, 0.2, rng);
    reference.boxes[0].class_name = class_name;
    classifier.classify(reference);
    classifier.remember(reference);
    ObjectFeatures current = observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.5), 3, 0.2, rng);
    current.boxes[0].class_name = class_name;
    const cv::Rect box = current.boxes[0].box;
    const double undercarriage_from_v_px = box.y + 0.7 * box.height;
    // Without its upper structure matched, the frame keeps only the
    // keypoints on the tracks (the box stays the machine's).
    ObjectFeatures seen = current;
    seen.uv_px.clear();
    seen.u_right_px.clear();
    seen.octave.clear();
    seen.instance.clear();
    std::vector<cv::Mat> rows;
    for (std::size_t i = 0; i < current.uv_px.size(); ++i) {
      if (!upper_structure_matched && current.uv_px[i].y() < undercarriage_from_v_px) continue;
      seen.uv_px.push_back(current.uv_px[i]);
      seen.u_right_px.push_back(current.u_right_px[i]);
      seen.octave.push_back(current.octave[i]);
      seen.instance.push_back(current.instance[i]);
      rows.push_back(current.descriptors.row(static_cast<int>(i)));
    }
    cv::vconcat(rows, seen.descriptors);
    EXPECT_GE(seen.uv_px.size(), 8u);  // enough to test on their own
    return classifier.classify(seen)[0].verdict;
  };
  ObjectVerdict v = raw_verdict("excavator", false);
  EXPECT_EQ(v.raw, MotionState::kUnknown);
  EXPECT_EQ(v.unknown_reason, UnknownReason::kTooFewPoints);
  EXPECT_EQ(v.points, 0);  // none on the upper structure
  const ObjectVerdict truck = raw_verdict("truck", false);
  EXPECT_EQ(truck.raw, MotionState::kStatic);
  EXPECT_EQ(truck.points, truck.matched_points);
  v = raw_verdict("excavator", true);
  EXPECT_EQ(v.raw, MotionState::kStatic);
  EXPECT_EQ(v.points, 60);
}

// A working excavator: the standing tracks (60 % of the points) outvote
// the part that moves (the 40 % with the largest x), so the common
// displacement is zero; the moving part still makes the object moving.
TEST(MotionClassifier, SiteposeMovingPartMakesTheObjectMovingThoughTheRestStands) {
  const auto raw_verdict = [](double part_motion_m) {
    std::mt19937 rng(17);
    Object machine = make_object(1, 60, 0.0, rng);
    std::vector<double> xs;
    for (const auto& p : machine.p_world) xs.push_back(p.x());
    std::sort(xs.begin(), xs.end());
    const double cut = xs[36];
    MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
    const SE3 standing = at_x(0.0);
    const auto as_excavator = [](ObjectFeatures f) {
      f.boxes[0].class_name = "excavator";
      return f;
    };
    classifier.remember(as_excavator(observe({machine}, {Eigen::Vector3d::Zero()}, standing, 0, 0.2, rng)));
    // Two moving verdicts of the whole machine: it is working.
    for (int k = 6; k < 8; ++k) {
      classifier.classify(
          as_excavator(observe({machine}, {Eigen::Vector3d(0.3, 0.0, 0.0)}, standing, k, 0.2, rng)));
    }
    Object moved = machine;
    for (auto& p : moved.p_world) {
      if (p.x() >= cut) p += Eigen::Vector3d(part_motion_m, 0.0, 0.1 * part_motion_m);
    }
    return classifier
        .classify(as_excavator(observe({moved}, {Eigen::Vector3d::Zero()}, standing, 8, 0.2, rng)))[0]
        .verdict;
  };
  ObjectVerdict v = raw_verdict(0.0);
  EXPECT_EQ(v.raw, MotionState::kStatic);
  EXPECT_EQ(v.part_statistic, 0.0);
  v = raw_verdict(0.25);
  EXPECT_EQ(v.raw, MotionState::kMoving);
  EXPECT_GT(v.part_statistic, 100.0);
  EXPECT_EQ(v.matched_points, 60);
}

// A small part (15 % of the points) moves while the rest stands. A truck is
// rigid: such points are mismatches (the common displacement says static).
// An excavator not seen working needs a larger part (a parked one's
// mismatches must not mask it); one with two moving verdicts within
// kWorkingMemoryS is working, and the same part makes it moving.
TEST(MotionClassifier, SiteposeSmallMovingPartCountsOnlyOnAWorkingArticulatedMachine) {
  std::mt19937 rng(29);
  const Object machine = make_object(1, 60, 0.0, rng);
  Object part_moved = machine;
  for (int i = 0; i < 9; ++i) part_moved.p_world[i] += Eigen::Vector3d(0.25, 0.0, 0.025);
  const SE3 standing = at_x(0.0);
  const Eigen::Vector3d still = Eigen::Vector3d::Zero();
  const Eigen::Vector3d moved = Eigen::Vector3d(0.3, 0.0, 0.0);
  const auto verdict = [&](const std::string& class_name, int moving_verdicts_before) {
    const auto as_class = [&](ObjectFeatures f) {
      f.boxes[0].class_name = class_name;
      return f;
    };
    MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
    classifier.remember(as_class(observe({machine}, {still}, standing, 0, 0.2, rng)));
    for (int k = 0; k < moving_verdicts_before; ++k) {
      const auto out = classifier.classify(as_class(observe({machine}, {moved}, standing, 6 + k, 0.2, rng)));
      EXPECT_EQ(out[0].verdict.raw, MotionState::kMoving);
    }
    return classifier.classify(as_class(observe({part_moved}, {still}, standing, 9, 0.2, rng)))[0].verdict;
  };
  EXPECT_EQ(verdict("truck", 2).raw, MotionState::kStatic);
  EXPECT_EQ(verdict("excavator", 0).raw, MotionState::kStatic);
  EXPECT_EQ(verdict("excavator", 1).raw, MotionState::kStatic);
  const ObjectVerdict v = verdict("excavator", 2);
  EXPECT_EQ(v.raw, MotionState::kMoving);
  EXPECT_GT(v.part_statistic, 100.0);
}

// A machine that moved (0.3 m, seq 6 and 7) and then stands still: its
// static verdicts unmask it after hysteresis_frames, unless it is an
// articulated machine with two signs of motion within kWorkingMemoryS (it
// may resume work: unknown, settling). One moving verdict is not enough.
TEST(MotionClassifier, SiteposeWorkingExcavatorStaysMaskedBetweenStrokes) {
  const auto state_after_pause = [](const std::string& class_name, int moving_verdicts) {
    std::mt19937 rng(31);
    const Object machine = make_object(1, 60, 0.0, rng);
    const SE3 standing = at_x(0.0);
    const Eigen::Vector3d moved(0.3, 0.0, 0.0);
    const auto as_class = [&](ObjectFeatures f) {
      f.boxes[0].class_name = class_name;
      return f;
    };
    MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
    classifier.remember(as_class(observe({machine}, {Eigen::Vector3d::Zero()}, standing, 0, 0.2, rng)));
    for (int k = 0; k < moving_verdicts; ++k) {
      const auto out = classifier.classify(as_class(observe({machine}, {moved}, standing, 6 + k, 0.2, rng)));
      EXPECT_EQ(out[0].verdict.raw, MotionState::kMoving);
    }
    classifier.remember(as_class(observe({machine}, {moved}, standing, 8, 0.2, rng)));
    ObjectVerdict v;
    for (int seq = 14; seq < 18; ++seq) {
      v = classifier.classify(as_class(observe({machine}, {moved}, standing, seq, 0.2, rng)))[0].verdict;
      EXPECT_EQ(v.raw, MotionState::kStatic);
    }
    return v;
  };
  EXPECT_EQ(state_after_pause("truck", 2).state, MotionState::kStatic);
  EXPECT_EQ(state_after_pause("excavator", 1).state, MotionState::kStatic);
  const ObjectVerdict working = state_after_pause("excavator", 2);
  EXPECT_EQ(working.state, MotionState::kUnknown);
  EXPECT_EQ(working.unknown_reason, UnknownReason::kSettling);
}

// A standing camera compares against a frame chosen by time: the newest
// one at least 1 s old (not the ring's oldest, 2 s back).
TEST(MotionClassifier, SiteposeStandingCameraTakesTheFrameOneSecondBack) {
  std::mt19937 rng(19);
  const std::vector<Object> objects{make_object(1, 60, 0.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  for (int k = 0; k < 12; ++k) {
    classifier.remember(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.001 * (k % 2)), k, 0.2, rng));
  }
  const auto out = classifier.classify(observe(objects, {Eigen::Vector3d::Zero()}, at_x(0.0), 12, 0.2, rng));
  EXPECT_EQ(out[0].verdict.reference_seq, 6);  // 1 s at 6 fps
  EXPECT_EQ(out[0].verdict.raw, MotionState::kStatic);
}

// Unknown verdicts say why; people need three times the static frames.
TEST(MotionClassifier, SiteposeUnknownReasonsAndPeopleNeedStrongEvidence) {
  std::mt19937 rng(23);
  const std::vector<Object> objects{make_object(1, 80, -2.0, rng), make_object(2, 4, 2.0, rng)};
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  const std::vector<Eigen::Vector3d> still{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  int seq = 0;
  auto step = [&](double camera_x, const std::string& class_of_first) {
    ObjectFeatures f = observe(objects, still, at_x(camera_x), seq++, 0.2, rng);
    f.boxes[0].class_name = class_of_first;
    auto out = classifier.classify(f);
    classifier.remember(f);
    return out;
  };
  auto out = step(0.0, "person");
  EXPECT_EQ(out[0].verdict.unknown_reason, UnknownReason::kNoReference);
  out = step(0.2, "person");
  EXPECT_EQ(out[1].verdict.unknown_reason, UnknownReason::kTooFewPoints);
  int frames_to_unmask = 0;
  for (int k = 2; k < 20 && out[0].verdict.state != MotionState::kStatic; ++k) {
    out = step(0.2 * k, "person");
    if (out[0].verdict.state == MotionState::kUnknown && out[0].verdict.raw == MotionState::kStatic) {
      EXPECT_EQ(out[0].verdict.unknown_reason, UnknownReason::kSettling);
    }
    frames_to_unmask = k;
  }
  // A machine is unmasked at frame 4 (SiteposeHysteresis...); a person
  // needs 6 counted static verdicts, the first at frame 3.
  EXPECT_EQ(out[0].verdict.state, MotionState::kStatic);
  EXPECT_EQ(frames_to_unmask, 8);
}

// A prepared frame of `object` seen from T_world_cam, displaced by offset,
// with pixel noise, plus the exact map positions of its points (the object
// where it was parked). Keypoint 0 is background, without a map point.
struct MapCheckInput {
  tracking::PreparedFrame frame;
  std::vector<std::optional<Eigen::Vector3d>> map_points;
  ObjectFeatures current;
};

MapCheckInput map_check_input(const Object& object, const Eigen::Vector3d& offset, const SE3& T_world_cam,
                              double sigma_px, std::mt19937& rng) {
  const StereoCamera cam = test_camera();
  std::normal_distribution<double> noise(0.0, sigma_px);
  MapCheckInput in;
  const auto add = [&](const Eigen::Vector3d& p_world, std::uint16_t instance, bool in_map) {
    const Eigen::Vector3d s = cam.project_stereo(T_world_cam.inverse() * p_world);
    in.frame.uv_px.emplace_back(s.x() + noise(rng), s.y() + noise(rng));
    in.frame.features.u_right.push_back(s.z() + noise(rng));
    in.frame.features.depth_m.push_back(cam.bf() /
                                        (in.frame.uv_px.back().x() - in.frame.features.u_right.back()));
    in.frame.octave.push_back(0);
    in.frame.instance.push_back(instance);
    in.map_points.push_back(in_map ? std::optional<Eigen::Vector3d>(p_world - offset) : std::nullopt);
  };
  add(Eigen::Vector3d(0.0, 0.0, 30.0), 0, false);
  for (const Eigen::Vector3d& p : object.p_world) add(p + offset, object.instance, true);
  in.current.T_world_cam = T_world_cam;
  in.current.covariance = Matrix6d::Identity() * 1e-8;
  in.current.variance_factor = 1.0;
  return in;
}

// A parked object, classified static, then tested against its map points
// each frame: at rest it passes (and stays static); displaced by 2 cm
// sideways at 10 m (1.4 px: a single point's test would pass it) it fails
// and is masked at once; paper mode has no such test.
TEST(MotionClassifier, MapCheckMasksAStaticObjectThatLeftItsMapPoints) {
  std::mt19937 rng(5);
  const Object object = make_object(3, 80, 0.0, rng);
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  for (int k = 0; k < 6; ++k) {
    const ObjectFeatures f = observe({object}, {Eigen::Vector3d::Zero()}, at_x(0.2 * k), k, 0.5, rng);
    classifier.classify(f);
    classifier.remember(f);
  }
  ASSERT_EQ(classifier.static_instances(), std::vector<std::uint16_t>{3});

  int false_alarms = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const MapCheckInput at_rest = map_check_input(object, Eigen::Vector3d::Zero(), at_x(1.2), 0.5, rng);
    const auto checks = classifier.check_against_map(at_rest.frame, at_rest.map_points, at_rest.current, {3});
    ASSERT_EQ(checks.size(), 1u);
    EXPECT_EQ(checks[0].points, 80);  // the background keypoint is not the object's
    false_alarms += checks[0].moving ? 1 : 0;
  }
  EXPECT_LE(false_alarms, 1);  // gate at chi2 3 dof 99.9 %
  EXPECT_EQ(classifier.static_instances(), std::vector<std::uint16_t>{3});

  const MapCheckInput moved = map_check_input(object, Eigen::Vector3d(0.02, 0.0, 0.0), at_x(1.2), 0.5, rng);
  const auto checks = classifier.check_against_map(moved.frame, moved.map_points, moved.current, {3});
  ASSERT_EQ(checks.size(), 1u);
  EXPECT_TRUE(checks[0].moving) << "statistic " << checks[0].statistic;
  EXPECT_NEAR(checks[0].displacement_m.x(), 0.02, 0.003);
  EXPECT_TRUE(classifier.static_instances().empty());

  MotionClassifier paper(test_camera(), config_for(config::ClassifierMode::kPaper), 6.0, 1.2, 8);
  EXPECT_TRUE(paper.check_against_map(moved.frame, moved.map_points, moved.current, {3}).empty());
}

// Too few matched points: no test (the object keeps its state).
TEST(MotionClassifier, MapCheckNeedsEnoughMatchedPoints) {
  std::mt19937 rng(6);
  const Object object = make_object(3, 5, 0.0, rng);
  MotionClassifier classifier(test_camera(), config_for(config::ClassifierMode::kSitepose), 6.0, 1.2, 8);
  const MapCheckInput moved = map_check_input(object, Eigen::Vector3d(0.5, 0.0, 0.0), at_x(0.0), 0.5, rng);
  EXPECT_TRUE(classifier.check_against_map(moved.frame, moved.map_points, moved.current, {3}).empty());
}

TEST(MotionClassifier, ClampedVarianceFactorBoundsTheNoiseModel) {
  EXPECT_DOUBLE_EQ(clamped_variance_factor(1e-6), 0.05);
  EXPECT_DOUBLE_EQ(clamped_variance_factor(0.7), 0.7);
  EXPECT_DOUBLE_EQ(clamped_variance_factor(100.0), 4.0);
}

TEST(MotionClassifier, IsStaticAtNeedsMoreThanTheFraction) {
  EXPECT_TRUE(is_static_at({0.1, 0.1, 0.1, 0.1, 5.0}, 1.0, 0.7));   // 80 %
  EXPECT_FALSE(is_static_at({0.1, 0.1, 0.1, 5.0, 5.0}, 1.0, 0.7));  // 60 %
  EXPECT_FALSE(is_static_at({}, 1.0, 0.7));
}

}  // namespace
}  // namespace sitepose::dynamic
