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
//   RelocalisationHold — after a relocalisation, counts the frames in a row
//                        whose pose has enough inliers; the tracker reports
//                        OK only once the hold is over.
//
// Thread: the track stage's thread; the map is read through SharedMap.

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

class Relocaliser {
 public:
  // Reads tracking.min_inliers_ok and the motion-only BA settings.
  Relocaliser(const StereoCamera& camera, const config::TrackingConfig& tracking,
              const map::ScalePyramid& pyramid);

  // Tries the map's candidate places, best first; true with result's pose,
  // matches and relocalised = true at the first that gives min_inliers_ok
  // inliers. On false, result holds the last attempt's leftovers only.
  bool relocalise(const map::SharedMap& map, const PreparedFrame& frame,
                  const std::vector<std::uint8_t>& usable, PassResult& result) const;

  // One candidate place; see relocalise().
  bool relocalise_against(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                          const RelocalisationCandidate& candidate, PassResult& result) const;

 private:
  StereoCamera camera_;
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
  }
  // One more frame tracked after it; the hold ends after hold_frames frames
  // in a row with enough inliers.
  void update(bool enough_inliers) {
    if (!holding_) return;
    held_frames_ = enough_inliers ? held_frames_ + 1 : 0;
    if (held_frames_ >= hold_frames_) holding_ = false;
  }
  bool holding() const { return holding_; }
  int held_frames() const { return held_frames_; }
  int hold_frames() const { return hold_frames_; }

 private:
  int hold_frames_;
  bool holding_ = false;
  int held_frames_ = 0;
};

}  // namespace sitepose::tracking
