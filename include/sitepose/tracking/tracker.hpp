#pragma once
// The stereo tracker (METHOD.md "Core tracker", "Two-pass coarse-to-fine
// tracking"), split in three steps so the dynamic layer can run two passes
// on one extraction:
//
//   prepare()  — ORB extraction (features::StereoExtractor: left and right
//                concurrently on the lent pool) and stereo matching, once
//                per frame; tags keypoints with instance ids.
//   estimate() — a pose from the keypoints marked usable: motion model
//                (descriptors against the reference keyframe when the motion
//                is unknown; relocalisation when both fail), then the local
//                map, with motion-only BA.
//                const: changes no tracker or map state, so pass 1 leaves no
//                trace and pass 2 can start from pass 1's pose.
//   commit()   — accepts one estimate: motion model, map statistics,
//                keyframe decision and insertion, hand-over to the mapper;
//                a provisional map when the site map stays lost, and its
//                join (provisional_map.cpp).
//
// Thread: one thread (the track stage) calls all three; the map is shared
// with the local mapper through map::SharedMap (see its ownership rule).

#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/pose_estimate.hpp"
#include "sitepose/core/stereo_frame.hpp"
#include "sitepose/features/stereo_extractor.hpp"
#include "sitepose/map/shared_map.hpp"
#include "sitepose/optim/motion_only_ba.hpp"
#include "sitepose/tracking/pass_result.hpp"
#include "sitepose/tracking/prepared_frame.hpp"
#include "sitepose/tracking/projection_search.hpp"
#include "sitepose/tracking/relocaliser.hpp"

namespace sitepose::tracking {

// How the tracker talks to the local mapper without depending on it.
struct MapperLink {
  std::function<void(map::KeyFrameId)> enqueue;  // hand a new keyframe over
  std::function<int()> queue_size;               // keyframes not processed yet
  std::function<bool()> is_idle;                 // nothing queued or running
  std::function<void()> interrupt;               // abort a running local BA
  // Hold the mapper between keyframes while the tracker moves or drops a
  // provisional map (LocalMapper::pause / resume); unset: nothing runs
  // beside the tracker (inline mapping).
  std::function<void()> pause;
  std::function<void()> resume;
  // A keyframe the tracker removed (a dropped provisional map): e.g. out of
  // the place-recognition database, as the mapper's culling does.
  std::function<void(map::KeyFrameId)> removed;
};

// What the dynamic layer gives prepare(): see there.
struct FrameMasks {
  cv::Mat instance_labels;
  cv::Mat extraction_mask;
};

// A local map on one frame (the points of the keyframes that observe a
// set of matches), listed once and searched by each later step that starts
// from the same pass: the map check and pass 2 both search the one pass 1
// listed and searched (PassResult::local_map). Listing one costs 1-3 ms
// (tens of thousands of keyframe slots, a few thousand distinct points). A
// snapshot: points the mapper moves meanwhile keep the position they had
// when it was taken.
struct AnchorLocalMap {
  std::vector<PointView> points;
  // Per keypoint of the frame: the index into `points` of the point the
  // anchor matched there, or -1.
  std::vector<int> match_of_anchor;
};

struct TrackerCounters {
  int frames = 0;
  int keyframes_created = 0;
  int relocalisations = 0;
  int frames_lost = 0;
  // Close-point repeatability (a measurement, no effect on tracking): over
  // consecutive tracked frames, the previous frame's matched close points
  // (stereo depth < close_depth_baselines) and how many of them this frame
  // matched again. rematched / previous = share re-found.
  long close_points_previous = 0;
  long close_points_rematched = 0;
  // Provisional maps (provisional_map.cpp): started after the site map was
  // lost for tracking.new_map_after_lost_s, joined to it when relocalised
  // in it, dropped when tracking left one before it was joined. A joined
  // map whose join was not yet confirmed when tracking was lost is dropped
  // too, counted apart (it is also among the joined).
  int provisional_maps_started = 0;
  int provisional_maps_joined = 0;
  int provisional_maps_dropped = 0;
  int joins_dropped_unconfirmed = 0;
  // The largest move a join made (translation, rotation): how far dead
  // reckoning had put a provisional map.
  double largest_join_move_m = 0.0;
  double largest_join_rotation_deg = 0.0;
  // Over the frames committed with a pose: matched map points, and those of
  // them a keyframe made at least kOldKeyFrameAge_s before the frame
  // observes (PoseCounters::matches_from_old_keyframes).
  long matches = 0;
  long matches_from_old_keyframes = 0;
};

// What "an old keyframe" is for TrackerCounters::matches_from_old_keyframes:
// made this long before the frame (keyframe and frame timestamps), the age
// at which issue 19 asks whether the tracker re-uses the map of an earlier
// pass rather than re-mapping it.
inline constexpr double kOldKeyFrameAge_s = 60.0;

class Tracker {
 public:
  // pool: worker threads for extraction, stereo matching and the
  // projection searches, owned by the caller (SlamSystem) and outliving the
  // tracker; nullptr = all on the caller's thread (same results).
  Tracker(const StereoCamera& camera, const config::SiteposeConfig& config, map::SharedMap& map,
          MapperLink mapper = {}, features::TaskPool* pool = nullptr);

  // instance_labels: empty, or CV_16UC1 of the image size with the detector
  // instance id under each pixel (0 = background). extraction_mask: empty
  // or CV_8UC1, nonzero = keep the feature budget away from these pixels
  // (the background then gets the full budget and the masked area a share
  // of its own, so pass 2 still has object keypoints to unmask).
  Expected<PreparedFrame> prepare(const StereoFrame& frame, const cv::Mat& instance_labels = {},
                                  const cv::Mat& extraction_mask = {});
  // The same with both masks made by make_masks, on the calling thread
  // while the pool builds the image pyramids (StereoExtractor); its error
  // is returned.
  using MaskMaker = std::function<Expected<FrameMasks>()>;
  Expected<PreparedFrame> prepare(const StereoFrame& frame, const MaskMaker& make_masks);

  // usable: per keypoint of `frame`, 1 = may be used. anchor: an earlier
  // pass on the same frame (pass 2 gets pass 1) whose pose to start from
  // and whose local map to search, matching every keypoint afresh;
  // default: the motion model, or without a velocity (after a
  // relocalisation) Relocaliser::track_against_keyframe on the reference
  // keyframe. anchor_local: the local map to search from the anchor when
  // the caller has it (anchor->local_map, or local_map_of(frame, *anchor));
  // else the local map of the anchor's matches is listed here.
  PassResult estimate(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                      const PassResult* anchor = nullptr, const AnchorLocalMap* anchor_local = nullptr) const;

  // The local map of `anchor`'s matches (a pass on `frame`), for the calls
  // below and estimate() to share.
  AnchorLocalMap local_map_of(const PreparedFrame& frame, const PassResult& anchor) const;

  // Pass 2 matches every keypoint afresh and re-finds only about 80 % of
  // pass 1's matches (its local-map search has the ratio test that pass 1's
  // motion-model search has not). Adds to `result` those inlier matches of
  // `anchor` it did not re-find, where the keypoint is free, the point not
  // matched elsewhere and its reprojection under result's pose within the
  // chi2 gate; result's pose and n_inliers stay its own. Without them the
  // committed frame seeds the next motion model, counts map points as found
  // (culling) and gives a keyframe its associations with fewer points than
  // pass 1 had. Returns how many were added.
  int carry_over_matches(const PreparedFrame& frame, const PassResult& anchor, PassResult& result) const;

  // Accepts `result` for `frame` (usable: the keypoints allowed into new map
  // points); initialises the map from the first frame with enough stereo
  // points. Returns the pose the outputs publish.
  PoseEstimate commit(const PreparedFrame& frame, const PassResult& result,
                      const std::vector<std::uint8_t>& usable);

  // Matches the usable keypoints to the local map of `anchor` (its matched
  // points' keyframes) seen from anchor's pose, searching radius_px; no
  // pose is estimated. Per keypoint the point id, or kNoPoint. anchor_local:
  // as for estimate().
  std::vector<map::PointId> search_local_map(const PreparedFrame& frame,
                                             const std::vector<std::uint8_t>& usable,
                                             const PassResult& anchor, double radius_px,
                                             const AnchorLocalMap* anchor_local = nullptr) const;

  // search_local_map(), then per keypoint the world position of the point it
  // matched (nullopt where none, or the point is no longer good).
  std::vector<std::optional<Eigen::Vector3d>> matched_map_points(
      const PreparedFrame& frame, const std::vector<std::uint8_t>& usable, const PassResult& anchor,
      double radius_px, const AnchorLocalMap* anchor_local = nullptr) const;

  // prepare + estimate(all keypoints) + commit: plain stereo SLAM (mode none).
  Expected<PoseEstimate> track(const StereoFrame& frame);

  // Relocalisation's candidate keyframes (Relocaliser::PlaceSource); call
  // before the first frame.
  void set_place_source(Relocaliser::PlaceSource source) { relocaliser_.set_place_source(std::move(source)); }

  const StereoCamera& camera() const { return camera_; }
  const TrackerCounters& counters() const { return counters_; }
  TrackingState state() const { return state_; }
  std::optional<SE3> last_T_world_cam() const;

  // The map around the camera was moved by `correction` (a loop closure:
  // p_world' = correction * p_world); the last pose and the recent centres
  // move with it, the velocity (a relative motion) stays. Call between
  // frames, on the tracking thread.
  void apply_map_correction(const SE3& correction);

 private:
  static constexpr int kMinInitialisationPoints = 100;  // stereo points to start a map (ORB-SLAM2)
  // A pose whose place is a guess (a provisional map) has this added to
  // each variance of its covariance (m², rad²): a place not known within a
  // kilometre, so that the published protection level raises the
  // integrity alert.
  static constexpr double kGuessedPlaceVariance = 1e6;

  // The motion model (relocaliser_ when it fails), then the local map; see
  // estimate().
  bool track_motion_model(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                          const SE3& predicted, PassResult& result) const;
  // When the motion model found too few matches: the reference keyframe's
  // local map searched from the predicted pose (ORB-SLAM2 tracks the
  // reference keyframe there) before the frame counts as lost.
  bool track_reference_map(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                           const SE3& predicted, PassResult& result) const;
  // `points` searched by projection from `predicted` (the window doubled
  // when too few match), then the pose refined on the matches: the motion
  // model's step, also used on the reference keyframe's local map.
  bool track_from_prediction(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                             const SE3& predicted, const std::vector<PointView>& points, SearchParams params,
                             std::vector<int>& match, PassResult& result) const;
  // For the log: the share of the distant background found
  // (far_found_share), or "none in view".
  std::string distant_found_text(const PassResult& result) const;
  // A relocalisation candidate's last word (Relocaliser::Verify): its local
  // map tracked (as track_local_map), then a precise pose that finds
  // kMinRelocalisationFoundShare of the map points in view and the distant
  // background (finds_distant_background).
  bool holds_as_relocalisation(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                               PassResult& candidate) const;
  // Without anchor: the local map of result's own matches, which stay.
  // With anchor: the anchor's local map (anchor_local when given), every
  // keypoint matched afresh.
  void track_local_map(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                       const PassResult* anchor, const AnchorLocalMap* anchor_local,
                       PassResult& result) const;
  // The local map of the keyframes observing `tracked` (per keypoint a point
  // or kNoPoint). keep_tracked: `match` gets the tracked keypoints' indices
  // into the result; else all keypoints start unmatched.
  std::vector<PointView> local_points(const PreparedFrame& frame, const std::vector<map::PointId>& tracked,
                                      bool keep_tracked, std::vector<int>& match) const;
  // Appends to `points` the views of those of `ids` that are still good
  // points, in the order of `ids` (on the pool when there is one).
  void append_point_views(const std::vector<map::PointId>& ids, std::vector<PointView>& points) const;
  // Keypoint k's reprojection error of p_world seen from T_cam_world within
  // the motion-only BA's chi2 gate (stereo or mono, by the keypoint).
  bool within_reprojection_gate(const PreparedFrame& frame, int k, const Eigen::Vector3d& p_world,
                                const SE3& T_cam_world) const;
  // What the searches need of a map point (with its observed span when
  // tracking.trust_established_map reads it).
  PointView point_view(const map::MapData& map, const map::MapPoint& point) const;
  // Motion-only BA over the matches in result.point_of_keypoint; drops
  // outliers and fills pose, covariance and inlier count.
  void optimise_pose(const PreparedFrame& frame, const std::vector<PointView>& points,
                     const std::vector<int>& match_of_keypoint, PassResult& result) const;

  // What a committed `result` means for a relocalisation's hold: precise
  // (good enough for OK), confirmed (counts towards the hold's end: precise
  // also with the map points' errors while held), dropped (a held
  // relocalisation that stopped being precise: LOST, relocalise anew), and
  // its close inliers (kMinOkCloseInliers: fewer, and it is not OK).
  struct HoldVerdict {
    bool precise = false;
    bool confirmed = false;
    bool dropped = false;
    int close_inliers = 0;
  };
  HoldVerdict judge_hold(const PreparedFrame& frame, const PassResult& result) const;
  // The state after a valid `result`: RECOVERING after a relocalisation
  // until the hold is over (see judge_hold()), and while too few close
  // inliers hold the pose; returns whether it relocalised. The end of the
  // hold after a join confirms the joined keyframes.
  bool update_state(const PassResult& result, const HoldVerdict& verdict);
  std::string state_reason(const PassResult& result, const HoldVerdict& verdict) const;  // empty when OK
  // Depth under which a stereo point counts as close (tracking.close_depth_baselines), m.
  double close_depth_m() const;
  // The map's first keyframe at the world origin from a frame with enough
  // usable stereo points (false without).
  bool initialise(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable);
  // commit() of a frame before the map exists: initialise() and the pose.
  void commit_initialisation(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                             PoseEstimate& pose);
  int usable_stereo_points(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable) const;

  // Provisional maps (provisional_map.cpp; docs/tracking/provisional_map.md).
  // A frame the site map could not track: counts the time lost with a view
  // and, once tracking.new_map_after_lost_s has passed, starts a
  // provisional map at the dead-reckoned pose (dropping an earlier one that
  // was never joined). True when it started one: `pose` is then filled.
  bool start_provisional_map_if_due(const PreparedFrame& frame, const std::vector<std::uint8_t>& usable,
                                    PoseEstimate& pose);
  // A tracked frame while a provisional map exists. Relocalised into the
  // site map: the provisional map is dropped and `result` stands. Else a
  // relocalisation among the site map's keyframes; when it holds, the
  // provisional map is moved onto the site map and `joined` (that
  // relocalisation) is what the frame commits. Returns the result to commit.
  const PassResult& settle_provisional_map(const PreparedFrame& frame,
                                           const std::vector<std::uint8_t>& usable, const PassResult& result,
                                           PassResult& joined);
  void drop_provisional_map(const char* why);
  // A joined provisional map whose hold was not confirmed before tracking
  // was lost: its keyframes are dropped as a provisional map's would be.
  void drop_unconfirmed_join();
  // Removes the keyframes with ids >= first (a provisional map's, joined or
  // not) with the mapper held and tells the mapper; returns how many
  // keyframes went. The callers count what they dropped.
  std::size_t drop_keyframes_from(map::KeyFrameId first);
  // The reference keyframe becomes the one sharing most of result's matches
  // (it stays when none is shared).
  void refer_to_most_shared_keyframe(const PassResult& result);
  // Whether most of result's matched points belong to the site map.
  bool matched_in_site_map(const PassResult& result) const;
  // The site map lost for tracking.new_map_after_lost_s: the last pose
  // carried on by the mean step before the loss, one step per frame lost.
  SE3 dead_reckoned_T_cam_world() const;
  // A tracked frame's step (its velocity), kept for a second; a frame
  // without one (lost, relocalised) forgets them.
  void remember_step(std::int64_t t_ns, const std::optional<SE3>& step);
  // Appends (t_ns, value) to a history (oldest first) and drops what is
  // more than span_ns older; a time earlier than the newest (a camera
  // reconnected, its clock restarted) starts the history anew. For
  // recent_centres_ and recent_steps_.
  template <typename Value>
  static void append_recent(std::deque<std::pair<std::int64_t, Value>>& history, std::int64_t t_ns,
                            const Value& value, std::int64_t span_ns) {
    if (!history.empty() && t_ns < history.back().first) history.clear();
    history.emplace_back(t_ns, value);
    while (history.front().first < t_ns - span_ns) history.pop_front();
  }
  // The mean of the remembered steps (on the tangent space); identity
  // without any.
  SE3 mean_recent_step() const;
  // Runs `change` on the map with the mapper held between keyframes.
  void with_mapper_held(const std::function<void(map::MapData&)>& change);
  // The motion model's pose for the next frame (the last pose without a
  // velocity).
  SE3 predicted_T_cam_world() const;
  // Where the points the last frame matched should be in the next one
  // (tracking.keep_tracked_corners; empty when off or lost).
  std::vector<features::CornerHint> corner_hints() const;
  bool need_keyframe(const PreparedFrame& frame, const PassResult& result,
                     const std::vector<std::uint8_t>& usable) const;
  void remember_centre(std::int64_t t_ns, const Eigen::Vector3d& centre_world);
  // The camera stood (moved less than `max_m`) over the last second; false
  // with less than a second of tracked frames behind it.
  bool stood_for_a_second(std::int64_t t_ns, const Eigen::Vector3d& centre_world, double max_m) const;
  // starts_provisional_map: the keyframe is the first of a provisional map
  // (marked so under the same lock).
  void create_keyframe(const PreparedFrame& frame, const PassResult& result,
                       const std::vector<std::uint8_t>& usable, bool starts_provisional_map = false);
  // create_keyframe when the map needs one and the pose has held; the new
  // keyframe becomes pose's reference (T_reference_cam = I).
  void create_keyframe_if_needed(const PreparedFrame& frame, const PassResult& result,
                                 const std::vector<std::uint8_t>& usable, PoseEstimate& pose);
  // Updates the close-point repeatability counters with a committed frame.
  void count_close_repeatability(const PreparedFrame& frame, const PassResult& result);
  // The map points' visible / found counts and the keyframes the frame
  // uses; updates map_travel_m_; sets pose's reference keyframe and the
  // pose relative to it.
  void record_in_map(const PassResult& result, PoseEstimate& pose);

  StereoCamera camera_;
  config::SiteposeConfig config_;
  map::SharedMap& map_;
  MapperLink mapper_;
  features::StereoExtractor extractor_;  // the masked area with a smaller budget of its own
  features::TaskPool* pool_;             // lent; may be nullptr
  optim::MotionOnlyBa motion_ba_;
  map::ScalePyramid pyramid_;

  TrackingState state_ = TrackingState::kLost;
  bool has_last_ = false;
  SE3 last_T_cam_world_;
  SE3 velocity_;  // T_cam_current_cam_last of the last step
  bool has_velocity_ = false;
  Relocaliser relocaliser_;
  RelocalisationHold hold_;                                 // since the last relocalisation
  std::vector<std::pair<map::PointId, int>> last_matches_;  // point, octave
  std::vector<map::PointId> last_close_points_;             // sorted; repeatability counters, map travel
  map::KeyFrameId reference_keyframe_ = map::kNoKeyFrame;
  // The last tracked frame's map::map_travel_at (PoseEstimate::map_travel_m);
  // a keyframe made from the frame keeps it.
  double map_travel_m_ = 0.0;
  std::int64_t last_keyframe_seq_ = -1;
  std::int64_t last_keyframe_t_ns_ = 0;
  // (t_ns, camera centre in the world) of the tracked frames of the last
  // two seconds, oldest first; cleared when tracking is lost.
  std::deque<std::pair<std::int64_t, Eigen::Vector3d>> recent_centres_;
  // (t_ns, velocity) of the tracked steps of the last second, oldest
  // first: dead reckoning carries their mean, not the last step, whose
  // vibration (roll, pitch) it would repeat for every frame lost.
  std::deque<std::pair<std::int64_t, SE3>> recent_steps_;
  // Since the site map was lost: frames lost, the mean step of the second
  // before the loss, and the first lost frame with enough stereo points for
  // a new map (-1: none yet). A frame tracked again resets them.
  int frames_lost_in_a_row_ = 0;
  SE3 velocity_at_loss_;
  std::int64_t lost_with_view_since_ns_ = -1;
  // The first keyframe of the provisional map (MapData::provisional_since,
  // kept here by its only writer); kNoKeyFrame: none.
  map::KeyFrameId provisional_since_ = map::kNoKeyFrame;
  // The join the last frames found (p_site = correction * p_provisional)
  // and in how many frames in a row it was found again.
  std::optional<SE3> join_correction_;
  int join_agreements_ = 0;
  // The first keyframe of a provisional map joined to the site map while the
  // relocalisation hold that follows the join has not ended
  // (MapData::joined_unconfirmed_since, kept here by its only writer):
  // their place rests on the join alone. kNoKeyFrame: none.
  map::KeyFrameId joined_unconfirmed_since_ = map::kNoKeyFrame;
  TrackerCounters counters_;
};

}  // namespace sitepose::tracking
