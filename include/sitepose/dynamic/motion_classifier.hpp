#pragma once
// Motion-state classification, Algorithm 2 of the paper (METHOD.md
// "Motion-state classification"), in two modes:
//
//  * paper: reference frame (RF) = N processed frames back; objects of RF
//    and the current frame (CF) associated by descriptor matching (the pair
//    with most matches wins); matched points triangulated by stereo in each
//    camera and moved to the world with that frame's pose (T_world_cam;
//    not the authors' frame bug); errors above the median dropped; static
//    when more than 70 % of the kept errors are below 3 sigma_bkg.
//  * sitepose (METHOD.md "Where sitepose goes further"):
//    - RF = newest kept frame whose camera centre is at least
//      min_reference_parallax_m from CF's and at least 0.4 s older; when
//      the camera stands still (centre within 3 cm) the newest frame at
//      least 1 s older, chosen by time (any displacement is then the
//      object's own); else the oldest kept frame;
//    - articulated machines (excavator, loader): once working (two moving
//      verdicts within 20 s), the points that leave the common displacement
//      and each show motion on their own make the object moving when they
//      are >= 12 % of its points and >= 2 (a slewing house on standing
//      tracks is not outvoted by the tracks); with a moving verdict and one
//      more sign of motion (moving or ambiguous) within 20 s, static
//      verdicts do not unmask it (it may resume work: unknown, settling);
//    - people are unmasked only on strong evidence (twice the points,
//      three times the hysteresis);
//    - an unknown verdict says why (ObjectVerdict::unknown_reason);
//    - the same matching; instead of the paper's median cut, mismatches
//      are the points whose displacement disagrees with the object's common
//      (median) one beyond their pixel noise; an object whose points have
//      no common displacement (at most half agree) is unknown;
//    - the agreeing points are tested with their squared Mahalanobis
//      distance under the propagated stereo covariance of both points and
//      CF's pose (chi2 3 dof; static when > 70 % pass), plus an
//      object-level test of their mean displacement (pixel noise averages
//      out, pose noise does not; chi2 3 dof 99.9 %), so a machine that
//      starts moving is caught early;
//    - noise calibrated per frame: pixel noise and pose covariance scaled
//      by the pose solve's a-posteriori variance factor (a static object
//      then scores ~chi2 3 dof, not far below it);
//    - per-instance hysteresis: one moving verdict re-masks at once,
//      unmasking needs hysteresis_frames consecutive static verdicts over
//      >= 0.4 s each; evidence against "static" without a moving verdict
//      (failed point test with a passed object-level test, or no common
//      displacement) is unknown and masks the object at once (doubt masks;
//      only proof unmasks);
//    - a second test for the objects called static (check_against_map()):
//      their keypoints against their own map points, seen from pass 1's
//      pose. A map point averages many sightings, and the weighted mean
//      over an object's points averages the pixel noise, so what is left is
//      mostly the map error the points share (modelled); a roller starting
//      sideways 7.5 m away is caught 16 mm into its start (2 frames at
//      6 fps), before pass 2 can use it.
// Objects with too few matched points (or not associated) are unknown and
// stay masked.
//
// Frames: poses are T_world_cam of the left camera; covariances are the
// left perturbation [translation; rotation] of T_world_cam (core/pose_estimate.hpp).
// Thread: one instance per tracking thread; not thread-safe.

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/se3.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/dynamic/object_types.hpp"
#include "sitepose/tracking/prepared_frame.hpp"

namespace sitepose::dynamic {

namespace detail {
struct PointDisplacement;
}  // namespace detail

// What the classifier needs of a frame: object keypoints with stereo depth,
// their descriptors and instance tags, the pose, the dynamic boxes.
struct ObjectFeatures {
  std::int64_t seq = 0;
  std::int64_t t_ns = 0;
  SE3 T_world_cam;
  std::optional<Matrix6d> covariance;  // of T_world_cam; nullopt = unknown (treated as 0)
  // A-posteriori variance factor of the pose solve (tracking::PassResult):
  // how much noisier (> 1) or cleaner (< 1) this frame's keypoints were than
  // the unit pixel model. Scales the pixel noise and `covariance` (clamped).
  double variance_factor = 1.0;
  std::vector<Eigen::Vector2d> uv_px;  // left keypoints on objects with a stereo match
  std::vector<double> u_right_px;
  std::vector<int> octave;
  std::vector<std::uint16_t> instance;
  cv::Mat descriptors;           // one 32-byte row per keypoint above
  std::vector<ObjectBox> boxes;  // the frame's dynamic boxes
};

// Object keypoints (instance != 0, stereo match, depth < max_depth_m) of a
// prepared frame, with the given pose.
ObjectFeatures make_object_features(const tracking::PreparedFrame& frame, const std::vector<ObjectBox>& boxes,
                                    const SE3& T_world_cam, const std::optional<Matrix6d>& covariance,
                                    double variance_factor, double max_depth_m);

// The a-posteriori variance factor as the noise model uses it: clamped to
// [0.05, 4] (never ~4.5x more confident than the unit pixel model, never
// more than 2x less).
double clamped_variance_factor(double variance_factor);

// The paper's decision rule on a list of per-point statistics: static when
// more than `fraction` of them are below `threshold` (paper: errors in m
// and 3 sigma_bkg; sitepose: squared Mahalanobis distances and the chi2 gate).
bool is_static_at(const std::vector<double>& statistics, double threshold, double fraction);

// A verdict plus the per-point statistics it came from (for ROC sweeps:
// is_static_at() with another threshold gives the verdict at that threshold).
struct ClassifiedObject {
  ObjectVerdict verdict;
  std::vector<double> statistics;  // paper: kept errors (m); sitepose: squared Mahalanobis distances
};

// One unknown object per box, in box order (what classify() starts from;
// the frame's objects when there is no pose to classify them with).
std::vector<ClassifiedObject> unclassified_objects(const std::vector<ObjectBox>& boxes);

// The map test of one object (check_against_map()).
struct MapCheck {
  std::uint16_t instance = 0;
  int points = 0;  // matched points that agree with the common displacement
  Eigen::Vector3d displacement_m = Eigen::Vector3d::Zero();  // weighted mean, keypoint - map point, world
  double statistic = 0.0;                                    // squared Mahalanobis distance of displacement_m
  bool moving = false;                                       // statistic above the gate
};

struct ClassifierTimings {
  double match_ms = 0.0;
  double test_ms = 0.0;
};

class MotionClassifier {
 public:
  // fps: frame rate of the source (paper mode's default N = round(fps / 2.5),
  // at least 1); scale_factor / n_levels: the ORB pyramid (pixel noise grows
  // with the level).
  MotionClassifier(const StereoCamera& camera, const config::DynamicConfig& config, double fps,
                   double scale_factor, int n_levels);

  // Classifies every box of `current` (its pose = pass 1's) against a
  // reference frame from the ring. One entry per box, in box order.
  std::vector<ClassifiedObject> classify(const ObjectFeatures& current);

  // Adds a frame with its final pose to the ring (call after commit; frames
  // without a pose are not added).
  void remember(ObjectFeatures frame);

  // Tests each of `instances` (objects whose state is static) against the
  // map: map_point_of_keypoint (one entry per keypoint of `frame`, the
  // world position of the map point it matched, if any) vs the keypoint's
  // stereo point moved to the world with `current`'s pose (pass 1's,
  // background only). An object whose common displacement fails the gate
  // (chi2 3 dof 99.9 %) is moving from now on, like after a moving verdict.
  // One result per instance tested (at least 30 matched points), in order.
  std::vector<MapCheck> check_against_map(
      const tracking::PreparedFrame& frame,
      const std::vector<std::optional<Eigen::Vector3d>>& map_point_of_keypoint, const ObjectFeatures& current,
      const std::vector<std::uint16_t>& instances);

  // Clears the ring and the hysteresis.
  void reset();

  // Instances whose smoothed state is static now (sitepose mode; paper mode
  // keeps no state and returns none).
  std::vector<std::uint16_t> static_instances() const;

  int reference_offset_frames() const { return reference_offset_; }
  std::size_t ring_capacity() const { return capacity_; }
  std::size_t ring_size() const { return ring_.size(); }
  const ClassifierTimings& last_timings() const { return timings_; }
  // Largest depth of a point used (the paper: 40 baselines), m.
  double max_depth_m() const { return max_depth_m_; }

 private:
  struct Track {
    MotionState state = MotionState::kUnknown;
    int static_streak = 0;
    int unknown_streak = 0;
    std::int64_t last_seq = -1;
    // When motion was proven (a moving verdict or the map check) last and
    // the time before, if ever.
    std::optional<std::int64_t> last_moving_t_ns;
    std::optional<std::int64_t> previous_moving_t_ns;
    // When a sign of motion (a moving verdict, or points that contradict
    // each other) was seen last and the time before, if ever.
    std::optional<std::int64_t> last_sign_t_ns;
    std::optional<std::int64_t> previous_sign_t_ns;
    void note_sign_of_motion(std::int64_t t_ns) {
      previous_sign_t_ns = last_sign_t_ns;
      last_sign_t_ns = t_ns;
    }
    // Safety first: evidence of motion masks the object again at once.
    void mask_as_moving(std::int64_t t_ns) {
      state = MotionState::kMoving;
      static_streak = 0;
      unknown_streak = 0;
      previous_moving_t_ns = last_moving_t_ns;
      last_moving_t_ns = t_ns;
      note_sign_of_motion(t_ns);
    }
  };

  // CF and its reference frame (nullptr = none) with the keypoint matches
  // between them (per CF keypoint its RF keypoint, or -1).
  struct Pairing {
    const ObjectFeatures& current;
    const ObjectFeatures* ref;
    const std::vector<int>& match;
    std::optional<Matrix6d> pose_covariance;  // CF's, scaled by its variance factor
  };

  const ObjectFeatures* select_reference(const ObjectFeatures& current) const;
  // The verdict on one object of CF (its state after hysteresis in sitepose
  // mode), from its points matched to its associated RF object.
  void judge(const Pairing& pairing, const std::map<std::uint16_t, std::uint16_t>& ref_of_current,
             ClassifiedObject& object);
  // The matched points of CF object `instance` and RF object `ref_instance`:
  // CF's sighting minus RF's, world frame, without the Mahalanobis distance.
  std::vector<detail::PointDisplacement> displacements(const Pairing& pairing, std::uint16_t instance,
                                                       std::uint16_t ref_instance) const;
  // Forgets instances not seen for a ring's length.
  void forget_unseen_tracks(std::int64_t seq);
  // Whether `instance` is an articulated machine with two moving verdicts
  // within kWorkingMemoryS before t_ns (working: its parts move on their own).
  bool is_working(std::uint16_t instance, const std::string& class_name, std::int64_t t_ns) const;
  // Whether `instance` is an articulated machine with a moving verdict and
  // one more sign of motion within kWorkingMemoryS before t_ns: it may
  // resume work at any moment.
  bool may_resume_work(std::uint16_t instance, const std::string& class_name, std::int64_t t_ns) const;
  // What a static raw verdict is worth to the hysteresis.
  enum class StaticEvidence {
    kCounts,
    kTooShort,  // RF and CF too close in time to tell: the state stays
    kPaused,    // a working machine between strokes: masked (unknown)
  };
  MotionState smooth(std::uint16_t instance, const ObjectFeatures& current, MotionState raw,
                     StaticEvidence static_evidence, bool conflicting_evidence, int hysteresis_frames);
  double pixel_sigma_px(int octave, double variance_factor) const;
  // A keypoint's stereo point moved to the world: its covariance from the
  // pixel noise of its level (scaled by the variance factor) and, when
  // given, the pose's; and the pixel-noise part alone, rotated to the world.
  struct WorldPoint {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d pixel_covariance = Eigen::Matrix3d::Zero();
  };
  std::optional<WorldPoint> to_world(const Eigen::Vector2d& uv_px, double u_right_px, int octave,
                                     double variance_factor, const SE3& T_world_cam,
                                     const Matrix6d* pose_covariance) const;

  StereoCamera camera_;
  config::DynamicConfig config_;
  int reference_offset_ = 2;
  std::size_t capacity_ = 13;
  double max_depth_m_ = 40.0;
  std::vector<double> level_scale_;
  std::deque<ObjectFeatures> ring_;
  std::map<std::uint16_t, Track> tracks_;
  ClassifierTimings timings_;
};

}  // namespace sitepose::dynamic
