#pragma once
// Motion-only BA over a pass's matches, shared by the tracker's passes and
// relocalisation. A pure function over value snapshots; no map access.

#include <vector>

#include "sitepose/map/map_data.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/tracking/pass_result.hpp"
#include "sitepose/tracking/prepared_frame.hpp"
#include "sitepose/tracking/projection_search.hpp"

namespace sitepose::tracking {

// Optimises result.T_cam_world against points[match_of_keypoint[k]] (-1 =
// unmatched) with the keypoints' level sigmas; fills the pose, covariance,
// variance factor, inlier matches (point_of_keypoint, n_inliers) and adds the
// solve's time to timings.motion_ba_ms. On a solver error the pose stays,
// no keypoint is matched and result.failure says why.
void optimise_pose(const optim::MotionOnlyBa& motion_ba, const map::ScalePyramid& pyramid,
                   const PreparedFrame& frame, const std::vector<PointView>& points,
                   const std::vector<int>& match_of_keypoint, PassResult& result);

// A map point is established when keyframes at least this far apart in time
// observed it where it is: a static point stays put, a point on a passing
// machine is matched again only by chance (a repeated texture), and hardly
// at the same place over half a second. A point seen by one keyframe, or
// by keyframes close in time, is fresh.
inline constexpr double kEstablishedSpanS = 0.5;

// optimise_pose(), but fresh points cannot outvote the established map.
// When fresh points are at least a third of the matches:
// - with at least kMinEstablishedMatches established matches, the pose is
//   first solved on those alone, the fresh matches are kept only where they
//   fit that pose (chi^2 gate), and the pose is solved again on both;
// - with fewer, while at least kHiddenEstablishedPoints established points
//   project into the image at the starting pose (the established map is
//   there but hidden), no pose: n_inliers = 0 and result.failure says why;
// - with fewer and no established map in view (a new map, new ground),
//   optimise_pose() on all matches.
// Otherwise (the usual case) it is optimise_pose() on all matches.
// Records result.established_matched and result.established_in_view.
// Why: with the camera standing, a machine passing close hides most of the
// background; each keyframe then makes points on the machine, and a frame
// later they outnumber the background's and drag the pose along with the
// machine (issue 24, docs/tracking/standing.md).
inline constexpr int kMinEstablishedMatches = 20;
inline constexpr int kHiddenEstablishedPoints = 2 * kMinEstablishedMatches;
void optimise_pose_established_first(const optim::MotionOnlyBa& motion_ba, const StereoCamera& camera,
                                     const map::ScalePyramid& pyramid, const PreparedFrame& frame,
                                     const std::vector<PointView>& points,
                                     const std::vector<int>& match_of_keypoint, PassResult& result);

// The established map is hidden when fewer than this share of its points
// in view are matched (with at least kHiddenEstablishedPoints in view).
// What is left of it (a strip beside a machine passing close, the ground
// under its chassis) holds a pose whose stated sigma is small but whose
// error is not: a rotation traded for a translation over a small patch.
// The tracker keeps such a pose for tracking but does not call it OK and
// makes no keyframe from it. Measured in docs/tracking/standing.md.
inline constexpr double kMinMatchedEstablishedShare = 0.15;
bool established_map_hidden(const PassResult& result);

}  // namespace sitepose::tracking
