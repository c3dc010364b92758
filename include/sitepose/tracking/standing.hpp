#pragma once
// Where the camera stands, and whether a pose that leaves that place is a
// drive-off or a drag (issue 24, "Robust when standing"; rule in
// docs/tracking/standing.md).
//
// While the camera stands, a machine passing close can cover most of the
// view; points on it (or background points matched to its repeated
// texture) then outvote the background and drag the estimated pose along
// with the machine. Two hypotheses explain such a frame: the camera moved
// (the estimate), or it still stands where it stood (the anchor) and part
// of the view moved. The tracker re-estimates the pose from the anchor; in
// a genuine drive-off every match moves with the camera, so that estimate
// converges to the moved pose and its inliers fit the moved pose too. When
// a machine drags the pose, the background points still visible keep
// fitting the standing pose and not the moved one.

#include <cstdint>
#include <optional>

#include "sitepose/core/se3.hpp"

namespace sitepose::tracking {

// The camera stands once its pose has stayed within these of one place for
// kStandingWindowS; a pose this close to the anchor needs no test.
inline constexpr double kStillRadiusM = 0.01;
inline constexpr double kStillAngleRad = 0.0087;  // 0.5 deg
inline constexpr double kStandingWindowS = 0.5;
// When the two hypotheses agree, the re-estimate from the anchor is
// committed: in a drive-off it converges to the moved pose, and where the
// view constrains the pose weakly it stays with the standing prior. Within
// kNearRadiusM of the anchor it is accepted as it is: a right pose is within
// 0.05 m, and this leaves 2 cm for the anchor's own error. Beyond that an
// agreement counts only while the re-estimate keeps at least kKeptShare of
// the inliers the standing camera had (or departs steadily, below); a
// drive-off is confirmed, and the anchor forgotten, once a pose so accepted
// is more than kLeftRadiusM from the anchor. The re-estimate must keep
// at least kKeptShare of the inliers the standing camera had: the first
// centimetres of a drive-off change the view little, whereas a machine that
// covers the view and drags the pose leaves few of them.
// Without that view (a machine still covers part of it) a drive-off is
// confirmed once the pose has left the anchor further with every frame,
// each one agreeing and precise, for kDepartureS: a dragged pose jumps back
// and forth with whatever the passing machine's texture offers.
inline constexpr double kNearRadiusM = 0.03;
inline constexpr double kLeftRadiusM = 0.05;
inline constexpr double kKeptShare = 0.5;
inline constexpr double kDepartureS = 0.5;
// Share of the re-estimate's inliers outside the moved pose's reprojection
// gate: at most kAgreeShare, the two hypotheses are one motion; at least
// kConflictShare, the view holds two motions and the standing one is kept.
inline constexpr double kAgreeShare = 0.2;
inline constexpr double kConflictShare = 0.5;

// What the standing test made of one estimate.
enum class StandingVerdict : std::uint8_t {
  kNotStanding,  // no anchor: the camera was moving
  kStill,        // within the still radius of the anchor; no test needed
  kMoved,        // the re-estimate from the anchor agrees: the camera moved
  kHeld,         // the view holds two motions: the standing pose is kept
  kUnsure,       // neither hypothesis confirmed: never OK
};

const char* to_string(StandingVerdict verdict);

// Distance of two camera poses: centre in metres, rotation angle in radians.
struct PoseDistance {
  double translation_m = 0.0;
  double rotation_rad = 0.0;
};
PoseDistance pose_distance(const SE3& T_cam_world_a, const SE3& T_cam_world_b);

// The two hypotheses of one frame whose estimate left the still radius.
struct TwoMotions {
  double moved_m = 0.0;           // the estimate's distance from the anchor
  bool reestimate_valid = false;  // the re-estimate from the anchor has enough inliers
  int reestimate_inliers = 0;
  double reestimate_m = 0.0;        // the re-estimate's distance from the anchor
  int outside_moved_gate = 0;       // re-estimate inliers the estimate does not explain
  bool reestimate_precise = false;  // as an OK pose must be (precise_pose())
  int standing_inliers = 0;         // most inliers of a frame at the anchor
  double departing_s = 0.0;         // see StandingDetector::departing_s()

  // One motion: the re-estimate is valid and the estimate explains all but
  // kAgreeShare of its inliers.
  bool agree() const;
};

// kMoved, kHeld or kUnsure (rule above and in docs/tracking/standing.md).
StandingVerdict judge_two_motions(const TwoMotions& m);

// Finds where the camera stands from its committed poses. One thread (the
// tracker's).
class StandingDetector {
 public:
  // A committed pose the tracker trusts (not LOST, not kUnsure) and its
  // inlier count.
  void update(std::int64_t t_ns, const SE3& T_cam_world, int n_inliers);
  // The camera left (drive-off confirmed) or tracking was lost: start over.
  void forget();
  // T_cam_world where the camera stands; nullopt while it moves.
  const std::optional<SE3>& anchor() const { return anchor_; }
  // The most inliers of a frame within the still radius of the anchor.
  int standing_inliers() const { return standing_inliers_; }
  // A frame tested away from the anchor (see judge_two_motions()).
  void note_departure(std::int64_t t_ns, const TwoMotions& m);
  // A frame within the still radius: no departure under way.
  void note_still() { departing_ = false; }
  // How long the pose has left the anchor further with every tested frame,
  // each agreeing and precise, if a frame at t_ns moved_m from the anchor
  // continues that; 0 when it would not.
  double departing_s(std::int64_t t_ns, double moved_m) const;
  // Whether T_cam_world is within the still radius and angle of `reference`.
  static bool still(const SE3& reference, const SE3& T_cam_world);

 private:
  std::optional<SE3> anchor_;
  int standing_inliers_ = 0;
  bool departing_ = false;
  std::int64_t departure_start_ns_ = 0;
  double departure_m_ = 0.0;         // the last departing frame's distance from the anchor
  std::optional<SE3> window_start_;  // first pose of the current still window
  std::int64_t window_start_ns_ = 0;
};

}  // namespace sitepose::tracking
