#pragma once
// New map points from two keyframes (ORB-SLAM2 LocalMapping::
// CreateNewMapPoints, written for sitepose): match the unmatched keypoints of
// two keyframes along epipolar lines, then triangulate each match (or take
// the stereo depth when the stereo rays see more parallax) and keep the
// points that pass depth, reprojection and scale checks.
//
// Frames: keyframe poses are T_world_cam of the left camera; pixels at
// pyramid level 0; sigma^2 of a keypoint = scale(octave)^2.
// Pure functions on snapshots (map_snapshot.hpp): no lock is needed.

#include <vector>

#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/mapping/map_snapshot.hpp"

namespace sitepose::mapping {

struct NewPointParams {
  // ORB-SLAM2 ORBmatcher::TH_LOW: best descriptor distance accepted (of 256 bits).
  int max_descriptor_distance = 50;
  // Best distance must be below ratio * second best (Lowe's ratio test).
  double ratio = 0.6;
  // Squared epipolar distance gate in units of the level's sigma^2:
  // chi^2 with 1 dof at 95 % (ORB-SLAM2 CheckDistEpipolarLine).
  double epipolar_chi2 = 3.84;
  // Reprojection gates (tracking.chi2_mono / chi2_stereo: 2 / 3 dof at 95 %).
  double chi2_mono = 5.991;
  double chi2_stereo = 7.815;
};

// One match: keypoint index1 of keyframe 1 with keypoint index2 of keyframe 2.
struct KeypointMatch {
  int index1 = -1;
  int index2 = -1;
  int distance = 0;  // Hamming distance of the descriptors
};

// Matches between keypoints with no map point in either keyframe (and not
// flagged in used1 / used2, which may be empty): for each keypoint of
// keyframe 1, the candidates of keyframe 2 within the epipolar gate; the
// best is kept when it passes the distance and ratio tests. Monocular pairs
// near the epipole are skipped (their depth is unobservable). Each keypoint
// of keyframe 2 is used at most once (the lowest distance wins). Sorted by
// index1.
std::vector<KeypointMatch> search_for_triangulation(const StereoCamera& camera,
                                                    const map::ScalePyramid& pyramid,
                                                    const KeyFrameSnapshot& kf1,
                                                    const KeyFrameSnapshot& kf2,
                                                    const NewPointParams& params,
                                                    const std::vector<bool>& used1 = {},
                                                    const std::vector<bool>& used2 = {});

struct NewPoint {
  int index1 = -1;
  int index2 = -1;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  bool from_stereo = false;  // placed by a stereo depth rather than two-view triangulation
};

// Triangulates matches; a match yields a point only when the rays have
// parallax (linear triangulation when they see more than the stereo pair,
// or the better stereo back-projection), it lies in front of both cameras,
// its reprojection chi^2 is within the gate in both keyframes and the
// distance ratio agrees with the octave ratio (factor 1.5 * scale_factor).
std::vector<NewPoint> triangulate_matches(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                          const KeyFrameSnapshot& kf1, const KeyFrameSnapshot& kf2,
                                          const std::vector<KeypointMatch>& matches,
                                          const NewPointParams& params);

// Fundamental matrix F21 with x2^T F21 x1 = 0 for homogeneous level-0
// pixels x1 of keyframe 1 and x2 of keyframe 2.
Eigen::Matrix3d fundamental_2_1(const StereoCamera& camera, const SE3& T_cam1_world,
                                const SE3& T_cam2_world);

}  // namespace sitepose::mapping
