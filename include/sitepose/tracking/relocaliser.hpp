#pragma once
// Relocalisation (METHOD.md "Core tracker"; issue 19): a pose for a frame
// the motion model could not track, from any keyframe of the map, and the
// hold that keeps such a pose RECOVERING until it has proven itself.
//
//   Relocaliser        — candidates from place recognition over the whole
//                        map; per candidate brute-force descriptor matching,
//                        PnP RANSAC, motion-only BA, then a projection
//                        search over the candidate's covisible neighbourhood
//                        and BA again. const: reads the map, changes nothing.
//   RelocalisationHold — after a relocalisation, counts the frames whose
//                        pose is precise; the tracker reports OK only once
//                        the hold is over, and drops the relocalisation when
//                        the pose stops being precise.
//
// Thread: the track stage's thread; the map is read through SharedMap.

#include <functional>
#include <optional>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/tracking/pass_result.hpp"
#include "sitepose/tracking/prepared_frame.hpp"
#include "sitepose/tracking/projection_search.hpp"

namespace sitepose::tracking {

// A keyframe relocalisation tries: its pose, its good points and those of
// its best covisible keyframes (the projection search after PnP).
struct RelocalisationCandidate {
  SE3 T_cam_world;
  std::vector<PointView> points;
  std::vector<PointView> neighbourhood_points;
};

// An OK pose promises 0.05 m (issue 19). Its position sigma from the
// motion-only BA's Hessian (unit pixel noise, not scaled by the variance
// factor, which is below 1 on sharp images) must be within 0.02 m, so that
// 2.5 sigma stays inside the promise: a pose held by few or only distant
// points is RECOVERING, and a relocalisation does not hold on one.
inline constexpr double kMaxOkPositionSigmaM = 0.02;

// The square root of the largest eigenvalue of the position block of
// result's covariance; +inf without one.
double position_sigma_m(const PassResult& result);

// Precise enough for OK while tracking: min_inliers_ok inliers and a
// position sigma within kMaxOkPositionSigmaM.
bool precise_pose(const PassResult& result, int min_inliers_ok);

// An OK pose must also rest on points this frame measures itself: at least
// this many inliers with a stereo depth of their own, nearer than
// tracking.close_depth_baselines baselines. Without them (a truck arriving
// in front of the lens hides the near ground, and the right image) the pose
// rests on the map's points alone, mostly distant ones, and inherits their
// errors, which its sigma does not show: measured 0.05-0.59 m off at
// position sigmas of 0.004-0.02 m with 0-9 such inliers; over 82 runs every
// OK frame with fewer than 20 was a truck arriving in front of the lens
// (docs/tracking/provisional_map.md, "A pose needs the near points it
// measures"). Such a pose is tracked on, RECOVERING.
inline constexpr int kMinOkCloseInliers = 20;
// The inliers of result whose keypoint in frame has a stereo depth in
// (0, close_depth_m).
int close_inliers(const PreparedFrame& frame, const PassResult& result, double close_depth_m);

// A relocalisation (or a provisional map's join) has no usable prior: a
// repeated pattern (paving, a fence) can give a precise pose at the wrong
// place, and there the rest of the map predicted in view is not found. It
// must find this share of the map points its local-map search predicted in
// view (inliers / visible_points); the measurements behind the value are in
// docs/tracking/provisional_map.md.
inline constexpr double kMinRelocalisationFoundShare = 0.2;
// inliers / visible points of result's local-map search; 0 without any.
double found_share(const PassResult& result);

// A pattern that repeats in the near part of the view (tiled paving, a row
// of identical containers) can hold a precise pose displaced along it that
// passes kMinRelocalisationFoundShare on the near points it finds. Beyond
// the pattern the scene does not repeat: displaced, the distant points
// (fence, buildings) project far from where they are and are not found; at
// the right place they are found from wherever the camera stands, as their
// appearance changes least with the viewpoint. So the points in view at
// kFarPointDepthM or deeper must be found at this share as well, when at
// least kMinFarPointsInView of them are in view (measured: twins 8.2 m and
// 42 m off at 0.07 at most, right places at 0.20 and more;
// docs/tracking/provisional_map.md).
inline constexpr double kFarPointDepthM = 10.0;
inline constexpr int kMinFarPointsInView = 30;
inline constexpr double kMinRelocalisationFarFoundShare = 0.12;
// inliers / visible points at kFarPointDepthM or deeper at result's pose;
// nullopt with fewer than kMinFarPointsInView of them (no distant
// background to check a pattern against). Call under SharedMap::read().
std::optional<double> far_found_share(const map::MapData& map, const PassResult& result);
// Whether result's pose passes the check above (true without a distant
// background to check). Call under SharedMap::read().
bool finds_distant_background(const map::MapData& map, const PassResult& result);

// The position sigma of result's pose when its map points are not exact:
// each inlier's point carries the error of a stereo point triangulated at
// its present distance along its mean viewing direction (depth z^2 / bf,
// across z / f, for one pixel), propagated into the observation's noise.
// position_sigma_m() takes the points as exact; after a relocalisation to a
// place seen before only from afar, from another angle, the pose inherits
// the distant points' depth errors (measured: 0.11 m off at a sigma below
// 0.02 m), which this sigma shows. The points of a joined provisional map
// not yet confirmed (MapData::joined_unconfirmed_since) are left out: their
// error is the join's, common to all of them. +inf without enough inliers.
// Call under SharedMap::read().
double map_aware_position_sigma_m(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                  const PreparedFrame& frame, const map::MapData& map,
                                  const PassResult& result);

// While a relocalisation is held, a frame counts towards OK only with a
// map-aware position sigma within this.
inline constexpr double kMaxHeldMapAwareSigmaM = 0.02;

class Relocaliser {
 public:
  // Reads tracking.min_inliers_ok and the motion-only BA settings.
  Relocaliser(const StereoCamera& camera, const config::TrackingConfig& tracking,
              const map::ScalePyramid& pyramid);

  // Where candidate keyframes come from: the usable rows of the frame's
  // descriptors -> keyframe ids, best first (the place-recognition
  // database, placerec/keyframe_database.hpp), only ids below only_before
  // unless it is kNoKeyFrame. Without one, every query descriptor votes for
  // the keyframes of its nearest map point (place_recognition.hpp): exact,
  // but its cost grows with the map.
  using PlaceSource = std::function<std::vector<map::KeyFrameId>(
      const map::SharedMap& map, const cv::Mat& descriptors, const std::vector<std::uint8_t>& usable,
      map::KeyFrameId only_before)>;
  void set_place_source(PlaceSource source) { place_source_ = std::move(source); }

  // The caller's last word on a candidate's pose (e.g. track the local map
  // from it and require a precise pose); may refine result.
  using Verify = std::function<bool(PassResult& result)>;

  // Tries the map's candidate places: per candidate, PnP, motion-only BA
  // and verify (when given). True with result's pose, matches and
  // relocalised = true when at least one place passes and no other place
  // more than 0.5 m away passes too (a repeated scene: neither
  // is trusted). On false, result is as given. only_before: candidates
  // among the keyframes with smaller ids only (the site map while a
  // provisional map is tracked); kNoKeyFrame = the whole map.
  bool relocalise(const map::SharedMap& map, const PreparedFrame& frame,
                  const std::vector<std::uint8_t>& usable, PassResult& result, const Verify& verify = {},
                  map::KeyFrameId only_before = map::kNoKeyFrame) const;

  // One candidate place; see relocalise().
  bool relocalise_against(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                          const RelocalisationCandidate& candidate, PassResult& result) const;

  // The frame after a relocalisation, whose motion is unknown: its pose from
  // `keyframe`'s points by descriptor matching and PnP, as relocalise_against
  // does, with no prior from the last pose (ORB-SLAM2 tracks that frame
  // against its reference keyframe by descriptors too); when too few of them
  // match, from the points of the keyframe and its covisible neighbours.
  // result.relocalised is left as given: the caller tracks the local map
  // next. False, with result as given, when the keyframe is gone or too few
  // matches hold.
  bool track_against_keyframe(const map::SharedMap& map, const PreparedFrame& frame,
                              const std::vector<std::uint8_t>& usable, map::KeyFrameId keyframe,
                              PassResult& result) const;

 private:
  // Candidate keyframes for `frame`, best first (see PlaceSource).
  std::vector<map::KeyFrameId> candidate_places(const map::SharedMap& map, const PreparedFrame& frame,
                                                const std::vector<std::uint8_t>& usable,
                                                map::KeyFrameId only_before) const;

  StereoCamera camera_;
  PlaceSource place_source_;
  int min_inliers_ok_;
  optim::MotionOnlyBa motion_ba_;
  map::ScalePyramid pyramid_;
};

class RelocalisationHold {
 public:
  explicit RelocalisationHold(int hold_frames) : hold_frames_(hold_frames) {}

  // A relocalisation: the hold starts over.
  void restart() {
    holding_ = true;
    held_frames_ = 0;
    misses_in_a_row_ = 0;
  }
  // One more frame tracked after it. The hold ends after hold_frames
  // confirmed frames (precise, and precise with the map points' errors) in
  // a row: any other frame starts the count again, since a pose that jumps
  // between confirmed frames has not held (truckstop seed 4, mode none,
  // 640x360: 0.4-0.7 m off between them). kMaxMissesInARow imprecise frames
  // in a row fail the hold (see fails()).
  void update(bool precise, bool confirmed) {
    if (!holding_) return;
    held_frames_ = confirmed ? held_frames_ + 1 : 0;
    misses_in_a_row_ = precise ? 0 : misses_in_a_row_ + 1;
    if (held_frames_ >= hold_frames_) holding_ = false;
  }
  // Whether update(precise) would fail the hold: the relocalisation is then
  // dropped rather than tracked on (it may sit on a repeated structure's
  // twin), and the next frame relocalises anew.
  bool fails(bool precise) const { return holding_ && !precise && misses_in_a_row_ + 1 >= kMaxMissesInARow; }
  void stop() { holding_ = false; }
  bool holding() const { return holding_; }
  int held_frames() const { return held_frames_; }
  int hold_frames() const { return hold_frames_; }

 private:
  static constexpr int kMaxMissesInARow = 2;
  int hold_frames_;
  bool holding_ = false;
  int held_frames_ = 0;
  int misses_in_a_row_ = 0;
};

}  // namespace sitepose::tracking
