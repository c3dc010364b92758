#pragma once
// Typed configuration of sitepose: one struct per module, defaults here,
// units in field names. Loaded and validated by load_config() (config.hpp);
// config/sitepose.yaml documents every key. Thresholds cite METHOD.md.
//
// Adding a key: add the field here with its default, add it with its rule
// to its section's table in src/config/config.cpp (which reads, validates and
// writes it), document it in config/sitepose.yaml (a test compares the file
// with the table).

#include <optional>
#include <string>
#include <vector>

#include "sitepose/core/channel_order.hpp"
#include "sitepose/core/stereo_camera.hpp"

namespace sitepose::config {

// Optional camera override; sequences normally bring calib.txt.
struct CameraConfig {
  std::optional<StereoCamera> stereo;  // absent = take it from the source
  // Colour image files (sequences, replay) are made gray in this order;
  // cameras deliver gray, Bayer or YUV, whose pixel format says the order.
  ChannelOrder channel_order = ChannelOrder::kBgr;

  // StereoCamera (core) has no operator==; compare every field here.
  friend bool operator==(const CameraConfig& a, const CameraConfig& b);
};

// ORB extraction (METHOD.md "Core tracker"; ORB-SLAM2 defaults).
struct OrbConfig {
  int n_features = 1500;      // per image, spread over the pyramid
  double scale_factor = 1.2;  // between pyramid levels
  int n_levels = 8;
  // FAST thresholds, a ladder per cell: a first pass over each level at
  // strong_fast_threshold; a cell it leaves empty falls back to
  // ini_fast_threshold, then min_fast_threshold. A strong threshold not above
  // ini_fast_threshold (0) leaves ORB-SLAM2's two steps.
  int strong_fast_threshold = 0;
  int ini_fast_threshold = 20;  // ORB-SLAM2's first threshold
  int min_fast_threshold = 7;   // fallback when a cell yields nothing
  int grid_cell_px = 35;        // cell size of the candidate grid

  bool operator==(const OrbConfig&) const = default;
};

// Stereo matching on rectified pairs.
struct StereoMatchConfig {
  double min_disparity_px = 0.5;    // ~ 1400 m at fx 700, b 1 m
  double max_disparity_px = 250.0;  // ~ 2.8 m at fx 700, b 1 m
  // Of 256 bits: ORB-SLAM2's TH_HIGH. Its stereo matcher's 75 left 70 % of
  // the keypoints without depth at our 1 m baseline (docs/tracking/extraction.md).
  int max_descriptor_distance = 100;
  int sad_half_window_px = 5;  // 11x11 SAD patch for sub-pixel refinement
  int row_band_px = 2;         // search +- rows around the epipolar row, scaled by level

  bool operator==(const StereoMatchConfig&) const = default;
};

// Tracking: motion model, local map, motion-only BA, keyframes.
struct TrackingConfig {
  double close_depth_baselines = 40.0;   // points nearer than 40 b have reliable depth
  int motion_ba_rounds = 4;              // optimise -> reclassify outliers, 4 times
  int motion_ba_iterations = 10;         // per round
  double chi2_mono = 5.991;              // 2 dof, 95 %
  double chi2_stereo = 7.815;            // 3 dof, 95 %
  int min_inliers_ok = 30;               // fewer inliers -> RECOVERING
  int min_inliers_recovering = 12;       // fewer -> LOST
  int relocalisation_hold_frames = 3;    // RECOVERING -> OK after this many confirmed frames in a row
  int keyframe_max_interval_frames = 0;  // 0 = one second of frames
  double keyframe_tracked_ratio = 0.75;  // new keyframe if tracked/ref < ratio (all, or background alone)
  int keyframe_min_close_points = 100;   // need close points: add when fewer tracked
  int keyframe_new_close_points = 70;    // ... and more than this many could be created
  // Fresh map points cannot outvote the established map, a frame that sees
  // too little of it is not OK, and no keyframe from the reference
  // keyframe's viewpoint (tracking/pose_refinement.hpp,
  // docs/tracking/standing.md).
  bool trust_established_map = true;
  // Extraction keeps the corners the last frame matched, found again near
  // their predicted projections (features::CornerHint), before spreading
  // the rest of the budget (docs/tracking/extraction.md).
  bool keep_tracked_corners = true;
  // A keyframe also when the camera is this share of the frame's median
  // stereo depth away from its reference keyframe and from every keyframe
  // sharing a good part of its matches (a strip driven again keeps its
  // keyframes); 0 = off (the ORB-SLAM2 rules alone).
  // keep_tracked_corners wants it (docs/tracking/extraction.md).
  double keyframe_travel_depth_share = 0.05;
  // Lost this long (counted from the first lost frame with enough stereo
  // points for a map): a provisional map at the dead-reckoned pose, RECOVERING
  // until relocalised in the site map and joined to it; 0 = stay LOST
  // (tracking/tracker.hpp, docs/tracking/provisional_map.md).
  double new_map_after_lost_s = 3.0;

  bool operator==(const TrackingConfig&) const = default;
};

// Local mapping thread.
struct MappingConfig {
  bool enabled = true;
  int local_ba_keyframes = 10;  // covisible keyframes optimised
  int local_ba_iterations = 10;
  double keyframe_redundancy = 0.9;  // cull a keyframe when >= 90 % of its points are seen by 3 others
  int min_point_observations = 3;    // a new point seen by fewer keyframes after 3 KFs is culled
  // Site-map culling (mapping/site_culling.hpp): redundant keyframes within
  // site_radius_m and site_angle_deg of a new keyframe, over the whole map.
  bool site_culling = false;
  double site_radius_m = 1.0;
  double site_angle_deg = 15.0;
  // Loop closing (loop/loop_closer.hpp): only with a place-recognition
  // vocabulary (slam::SlamOptions::vocabulary).
  bool loop_closing = false;

  bool operator==(const MappingConfig&) const = default;
};

enum class MaskingMode { kNone, kBbox, kPixel, kHierarchical, kFull };
enum class ClassifierMode { kPaper, kSitepose };

// Dynamic layer: Algorithm 1 (masking) and Algorithm 2 (motion states).
struct DynamicConfig {
  MaskingMode mode = MaskingMode::kFull;
  double tau_mar = 0.5;  // pixel masks when mar >= tau_mar
  ClassifierMode classifier = ClassifierMode::kSitepose;
  double sigma_bkg_m = 0.12;               // paper: std of static point errors
  double static_inlier_fraction = 0.7;     // static if > 70 % of points agree
  int reference_offset_frames = 0;         // paper mode N; 0 = fps / 2.5 rounded
  double min_reference_parallax_m = 0.15;  // sitepose mode: reference by parallax
  double chi2_static_3dof = 7.815;         // sitepose mode: Mahalanobis gate
  int hysteresis_frames = 2;               // sitepose mode: frames to flip a state
  int min_object_points = 8;               // fewer -> unknown (stays masked)
  std::vector<std::string> dynamic_classes{"truck", "roller", "excavator", "loader",
                                           "dozer", "car",    "person",    "machine"};

  bool operator==(const DynamicConfig&) const = default;
};

struct DetectorConfig {
  std::string name = "labels";  // labels | stereo-geometric | opencv-dnn | path to a plugin .so
  std::string model_config;     // opencv-dnn: model description file
  std::string model_weights;    // opencv-dnn: weights file
  double score_threshold = 0.3;
  // labels: simulated detector latency and noise for robustness tests
  // (deterministic per seed, frame and instance).
  double labels_latency_ms = 0.0;        // sleep per detect call
  double labels_miss_probability = 0.0;  // probability that a box is missed
  double labels_jitter_px = 0.0;         // std dev of each box edge's shift
  int labels_seed = 1;
  // stereo-geometric (weight-free): what counts as an object.
  double geometric_max_range_m = 16.0;  // farther pixels are background
  double geometric_min_height_m = 0.4;  // height above the fitted ground plane
  // opencv-dnn (YOLO-style output): class names and network input size.
  std::string dnn_classes_file;  // one name per line; empty = class0, class1, ...
  int dnn_input_width_px = 416;
  int dnn_input_height_px = 416;

  bool operator==(const DetectorConfig&) const = default;
};

struct LoggingConfig {
  std::string level = "info";

  bool operator==(const LoggingConfig&) const = default;
};

struct SiteposeConfig {
  CameraConfig camera;
  OrbConfig orb;
  StereoMatchConfig stereo;
  TrackingConfig tracking;
  MappingConfig mapping;
  DynamicConfig dynamic;
  DetectorConfig detector;
  LoggingConfig logging;

  bool operator==(const SiteposeConfig&) const = default;
};

const char* to_string(MaskingMode mode);
const char* to_string(ClassifierMode mode);

}  // namespace sitepose::config
