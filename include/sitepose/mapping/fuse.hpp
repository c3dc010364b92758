#pragma once
// Duplicate fusion by projection (ORB-SLAM2 ORBmatcher::Fuse, written for
// sitepose): map points are projected into a keyframe and matched to its
// keypoints near the projection. The search runs on snapshots without a
// lock and returns proposals; the mapper applies them under
// SharedMap::write() (apply_fuse_proposals), where a keypoint that already
// has a point keeps the point with the larger observation weight.
//
// Frames and units: T_world_cam of the left camera; level-0 pixels; the
// keypoint's sigma^2 is scale(octave)^2.

#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/map/keypoint_grid.hpp"
#include "sitepose/mapping/map_snapshot.hpp"

namespace sitepose::mapping {

struct FuseParams {
  // Search radius = radius_scale * scale(predicted level) px (ORB-SLAM2 th = 3).
  double radius_scale = 3.0;
  // ORB-SLAM2 ORBmatcher::TH_LOW (of 256 bits).
  int max_descriptor_distance = 50;
  // Reprojection gates at the keypoint's sigma (tracking.chi2_mono / chi2_stereo).
  double chi2_mono = 5.991;
  double chi2_stereo = 7.815;
};

struct FuseProposal {
  map::PointId point = map::kNoPoint;
  map::KeyFrameId keyframe = map::kNoKeyFrame;
  int index = -1;     // keypoint of `keyframe`
  int distance = 0;   // Hamming distance to the point's descriptor
};

// Grid over a snapshot's keypoints for fuse_into_keyframe.
map::KeypointGrid make_keypoint_grid(const StereoCamera& camera, const KeyFrameSnapshot& keyframe);

// Proposals for the points not yet observed by `target`: the projection must
// be in the image and in front, the distance within the point's scale range
// (0.8 min .. 1.2 max), the viewing angle within 60 degrees of the point's
// normal; candidates are keypoints within radius at the predicted level or
// one below it, inside the chi^2 gate; the closest descriptor within
// max_descriptor_distance wins.
std::vector<FuseProposal> fuse_into_keyframe(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                             const KeyFrameSnapshot& target, const map::KeypointGrid& grid,
                                             const std::vector<PointSnapshot>& points,
                                             const FuseParams& params);

struct FuseOutcome {
  int observations_added = 0;  // keypoint had no point: the point gained an observation
  int points_merged = 0;       // keypoint had a point: the lighter one was replaced
  std::vector<map::PointId> touched;  // points whose observations changed (good ones at the time)
};

// Applies proposals in order on the live map (call under SharedMap::write()).
// A proposal is skipped when its point went bad, its keyframe is gone, or
// the point already observes the keyframe.
FuseOutcome apply_fuse_proposals(map::MapData& map, const std::vector<FuseProposal>& proposals);

}  // namespace sitepose::mapping
