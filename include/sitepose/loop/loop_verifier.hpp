#pragma once
// Geometric verification of a loop candidate (ORB-SLAM2 LoopClosing::
// ComputeSim3, stereo: SE(3)). Works on value copies (mapping snapshots)
// taken under the map's read lock; no lock is held here.
//
//   1. descriptor matching: each keypoint of the current keyframe that has
//      a map point to the closest keypoint of the candidate that has one
//      (Hamming <= max_descriptor_distance, ratio test, one match per
//      candidate keypoint); fewer than min_descriptor_matches: refused;
//   2. RANSAC over 3-point samples (rigid_fit.hpp) of the pairs
//      (candidate's point in the world, current's point in the current
//      camera): the hypothesis is T_world_cam of the current keyframe
//      where the loop side puts it; a pair is an inlier when each point
//      reprojects into the other keyframe's keypoint within chi2_inlier
//      (left image, at the keypoint's sigma = scale(octave) px);
//   3. refinement of that pose by Gauss-Newton on the same two
//      reprojection errors of the inliers (Huber at chi2_inlier), and the
//      inliers counted again; fewer than min_refined_inliers: refused;
//   4. guided matching: the points of the candidate and its covisible
//      keyframes (`loop_points`) projected into the current keyframe at the
//      refined pose (mapping/fuse.hpp search, radius guided_radius_scale);
//      accepted with at least min_total_matches keypoints matched in all,
//      and at least min_match_ratio of the loop points that should be in
//      view matched (not in ORB-SLAM2: the guard against repeated
//      structure, which matches under a shifted pose only in part).
//
// Frames: T_world_cam of the left camera; level-0 pixels.

#include <string>
#include <unordered_map>
#include <vector>

#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/mapping/map_snapshot.hpp"

namespace sitepose::loop {

struct LoopVerifierParams {
  int max_descriptor_distance = 50;  // ORB-SLAM2 TH_LOW
  double ratio = 0.75;               // ORB-SLAM2 SearchByBoW for loops
  int min_descriptor_matches = 20;   // ORB-SLAM2 ComputeSim3
  int ransac_iterations = 300;
  int min_ransac_inliers = 20;
  double chi2_inlier = 9.210;  // 2 dof, 99 % (ORB-SLAM2 Sim3Solver)
  int refine_iterations = 10;
  int min_refined_inliers = 20;       // ORB-SLAM2 OptimizeSim3
  double guided_radius_scale = 10.0;  // ORB-SLAM2 SearchByProjection th for loops
  int min_total_matches = 40;         // ORB-SLAM2 ComputeSim3
  // Of the loop side's points the current keyframe should see at the
  // refined pose (in the image, scale range and viewing angle), the share
  // matched. Repeated structure (identical machines in a row) matches
  // itself under a shifted pose, but the rest of the view does not.
  double min_match_ratio = 0.25;
};

// What verification needs of one side, copied under the map's read lock.
struct LoopView {
  mapping::KeyFrameSnapshot keyframe;
  // World position of each point the keyframe observes.
  std::unordered_map<map::PointId, Eigen::Vector3d> p_world;
};

struct LoopMatch {
  int keypoint = -1;                        // of the current keyframe
  map::PointId loop_point = map::kNoPoint;  // a point of the loop side
};

struct VerifiedLoop {
  map::KeyFrameId candidate = map::kNoKeyFrame;
  SE3 T_world_cam;                 // of the current keyframe, where the loop side puts it
  std::vector<LoopMatch> matches;  // refined inliers and guided matches, one per keypoint
  int descriptor_matches = 0;
  int ransac_inliers = 0;
  int refined_inliers = 0;
  int visible_loop_points = 0;  // loop points in view at the refined pose
};

// kNotFound (with the stage and the counts) when the candidate is refused.
Expected<VerifiedLoop> verify_loop(const StereoCamera& camera, const map::ScalePyramid& pyramid,
                                   const LoopView& current, const LoopView& candidate,
                                   const std::vector<mapping::PointSnapshot>& loop_points,
                                   const LoopVerifierParams& params = {});

// Pairs of stage 1: (current keypoint, candidate keypoint), both with a point.
std::vector<std::pair<int, int>> match_keyframe_points(const LoopView& current, const LoopView& candidate,
                                                       const LoopVerifierParams& params);

}  // namespace sitepose::loop
