// Reading sitepose.yaml into SiteposeConfig: one function per section, each
// key with its rule. Bounds reject values that break the algorithm (a
// negative count, a ratio outside [0, 1]); the defaults' sources are in
// config/sitepose.yaml and METHOD.md.

#include "sitepose/config/config.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "detail/orb_limits.hpp"
#include "sitepose/core/echo.hpp"

namespace sitepose::config {

namespace {

void read_camera(const YamlMap& section, CameraConfig& camera) {
  if (!section.has("stereo")) return;
  const YamlMap stereo = section.map("stereo");
  // A partial override would mix two calibrations: all fields or none.
  StereoCamera cam;
  bool complete = true;
  complete &= stereo.read_required("fx", cam.fx, positive());
  complete &= stereo.read_required("fy", cam.fy, positive());
  complete &= stereo.read_required("cx", cam.cx, non_negative());
  complete &= stereo.read_required("cy", cam.cy, non_negative());
  complete &= stereo.read_required("baseline_m", cam.baseline_m, positive());
  complete &= stereo.read_required("width", cam.width, positive());
  complete &= stereo.read_required("height", cam.height, positive());
  if (!complete) return;
  if (const Status valid = cam.validate(); !valid) {
    stereo.report_here(valid.error().message);
    return;
  }
  camera.stereo = cam;
}

void read_orb(const YamlMap& section, OrbConfig& orb) {
  section.read("n_features", orb.n_features, in_range(detail::kMinOrbFeatures, detail::kMaxOrbFeatures));
  section.read("scale_factor", orb.scale_factor, greater_than(1.0), at_most(detail::kMaxScaleFactor));
  section.read("n_levels", orb.n_levels, in_range(1, detail::kMaxLevels));
  section.read("ini_fast_threshold", orb.ini_fast_threshold, in_range(1, detail::kMaxFastThreshold));
  if (section.read("min_fast_threshold", orb.min_fast_threshold,
                   in_range(1, detail::kMaxFastThreshold)) &&
      orb.min_fast_threshold > orb.ini_fast_threshold) {
    section.report("min_fast_threshold", "must be <= orb.ini_fast_threshold (" +
                                             std::to_string(orb.ini_fast_threshold) + ")");
  }
  section.read("grid_cell_px", orb.grid_cell_px, in_range(8, 500));
}

void read_stereo(const YamlMap& section, StereoMatchConfig& stereo) {
  section.read("min_disparity_px", stereo.min_disparity_px, positive());
  if (section.read("max_disparity_px", stereo.max_disparity_px, positive()) &&
      stereo.max_disparity_px <= stereo.min_disparity_px) {
    section.report("max_disparity_px", "must be > stereo.min_disparity_px (" +
                                           detail::number_text(stereo.min_disparity_px) + ")");
  }
  section.read("max_descriptor_distance", stereo.max_descriptor_distance, in_range(0, 256));
  section.read("sad_half_window_px", stereo.sad_half_window_px, in_range(1, 30));
  section.read("row_band_px", stereo.row_band_px, in_range(0, 20));
}

void read_tracking(const YamlMap& section, TrackingConfig& tracking) {
  section.read("close_depth_baselines", tracking.close_depth_baselines, positive(),
               at_most(detail::kMaxCloseDepthBaselines));
  section.read("motion_ba_rounds", tracking.motion_ba_rounds, in_range(1, 20));
  section.read("motion_ba_iterations", tracking.motion_ba_iterations, in_range(1, 200));
  section.read("chi2_mono", tracking.chi2_mono, positive());
  section.read("chi2_stereo", tracking.chi2_stereo, positive());
  // A stereo pose has 6 dof; below ~10 inliers "tracking OK" means nothing.
  section.read("min_inliers_ok", tracking.min_inliers_ok, at_least(10));
  if (section.read("min_inliers_recovering", tracking.min_inliers_recovering, at_least(3)) &&
      tracking.min_inliers_recovering > tracking.min_inliers_ok) {
    section.report("min_inliers_recovering", "must be <= tracking.min_inliers_ok (" +
                                                 std::to_string(tracking.min_inliers_ok) + ")");
  }
  section.read("keyframe_max_interval_frames", tracking.keyframe_max_interval_frames,
               non_negative());
  section.read("keyframe_tracked_ratio", tracking.keyframe_tracked_ratio, greater_than(0.0),
               at_most(1.0));
  section.read("keyframe_min_close_points", tracking.keyframe_min_close_points, non_negative());
  section.read("keyframe_new_close_points", tracking.keyframe_new_close_points, non_negative());
}

void read_mapping(const YamlMap& section, MappingConfig& mapping) {
  section.read("enabled", mapping.enabled);
  section.read("local_ba_keyframes", mapping.local_ba_keyframes, in_range(1, 100));
  section.read("local_ba_iterations", mapping.local_ba_iterations, in_range(1, 200));
  section.read("keyframe_redundancy", mapping.keyframe_redundancy, greater_than(0.0),
               at_most(1.0));
  section.read("min_point_observations", mapping.min_point_observations, in_range(1, 20));
}

void read_dynamic(const YamlMap& section, DynamicConfig& dynamic) {
  section.read_parsed("mode", dynamic.mode,
                      [](const std::string& s) { return parse_masking_mode(s); });
  section.read("tau_mar", dynamic.tau_mar, in_range(0.0, 1.0));
  section.read_parsed("classifier", dynamic.classifier,
                      [](const std::string& s) { return parse_classifier_mode(s); });
  section.read("sigma_bkg_m", dynamic.sigma_bkg_m, positive());
  section.read("static_inlier_fraction", dynamic.static_inlier_fraction, greater_than(0.0),
               at_most(1.0));
  section.read("reference_offset_frames", dynamic.reference_offset_frames, in_range(0, 1000));
  section.read("min_reference_parallax_m", dynamic.min_reference_parallax_m, non_negative());
  section.read("chi2_static_3dof", dynamic.chi2_static_3dof, positive());
  section.read("hysteresis_frames", dynamic.hysteresis_frames, in_range(1, 100));
  section.read("min_object_points", dynamic.min_object_points, in_range(1, 10000));
  // An empty list is allowed: then only class-free detectors mark objects.
  section.read("dynamic_classes", dynamic.dynamic_classes, each(non_empty()));
}

bool is_plugin_path(const std::string& name) {
  return name.size() > 3 && name.compare(name.size() - 3, 3, ".so") == 0;
}

void read_detector(const YamlMap& section, DetectorConfig& detector) {
  section.read("name", detector.name,
               make_rule(
                   [](const std::string& name) {
                     return name == "labels" || name == "stereo-geometric" ||
                            name == "opencv-dnn" || is_plugin_path(name);
                   },
                   "expected one of: labels, stereo-geometric, opencv-dnn, or a plugin path "
                   "ending in .so"));
  section.read("model_config", detector.model_config);
  section.read("model_weights", detector.model_weights);
  section.read("score_threshold", detector.score_threshold, in_range(0.0, 1.0));
  section.read("labels_latency_ms", detector.labels_latency_ms, in_range(0.0, 10000.0));
  section.read("labels_miss_probability", detector.labels_miss_probability, in_range(0.0, 1.0));
  section.read("labels_jitter_px", detector.labels_jitter_px, in_range(0.0, 1000.0));
  section.read("labels_seed", detector.labels_seed);
  section.read("geometric_max_range_m", detector.geometric_max_range_m, in_range(3.0, 1000.0));
  section.read("geometric_min_height_m", detector.geometric_min_height_m, in_range(0.2, 10.0));
  section.read("dnn_classes_file", detector.dnn_classes_file);
  section.read("dnn_input_width_px", detector.dnn_input_width_px, in_range(1, 8192));
  section.read("dnn_input_height_px", detector.dnn_input_height_px, in_range(1, 8192));
  if (detector.name == "opencv-dnn") {
    // The dnn detector cannot start without weights: say so at load time.
    // (model_config may stay empty: a TensorFlow .pb is a single file.)
    if (detector.model_weights.empty()) {
      section.report("model_weights", "required when detector.name is opencv-dnn");
    }
  }
}

void read_logging(const YamlMap& section, LoggingConfig& logging) {
  section.read("level", logging.level, one_of({"trace", "debug", "info", "warn", "error", "off"}));
}

Expected<SiteposeConfig> finish_loading(const YamlReader& reader) {
  SiteposeConfig config;
  read_config(reader.root(), config);
  SITEPOSE_TRY_STATUS(reader.finish());
  return config;
}

}  // namespace

void read_config(const YamlMap& root, SiteposeConfig& config) {
  read_camera(root.map("camera"), config.camera);
  read_orb(root.map("orb"), config.orb);
  read_stereo(root.map("stereo"), config.stereo);
  read_tracking(root.map("tracking"), config.tracking);
  read_mapping(root.map("mapping"), config.mapping);
  read_dynamic(root.map("dynamic"), config.dynamic);
  read_detector(root.map("detector"), config.detector);
  read_logging(root.map("logging"), config.logging);
}

Expected<SiteposeConfig> load_config(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return make_error(ErrorCode::kNotFound,
                      "cannot open config file " + path + ": " + std::strerror(errno));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return make_error(ErrorCode::kIoError, "cannot read config file " + path);
  return load_config_from_string(text.str(), path);
}

Expected<SiteposeConfig> load_config_from_string(std::string_view text,
                                                 const std::string& source_name) {
  // yaml-cpp accepts OpenCV's "%YAML:1.0" header, and every key would then
  // be reported unknown; name the likely mix-up instead.
  if (text.substr(0, 6) == "%YAML:") {
    return make_error(ErrorCode::kInvalidArgument,
                      source_name + ":1: this is an OpenCV FileStorage file (%YAML:1.0), such as "
                                    "ORB-SLAM2 settings, not a sitepose configuration (see "
                                    "config/sitepose.yaml); ORB-SLAM2 settings are read by "
                                    "load_orbslam2_settings");
  }
  SITEPOSE_TRY(const YamlReader reader, YamlReader::from_string(text, source_name));
  return finish_loading(reader);
}

bool operator==(const CameraConfig& a, const CameraConfig& b) {
  if (a.stereo.has_value() != b.stereo.has_value()) return false;
  if (!a.stereo) return true;
  const StereoCamera& x = *a.stereo;
  const StereoCamera& y = *b.stereo;
  return x.fx == y.fx && x.fy == y.fy && x.cx == y.cx && x.cy == y.cy &&
         x.baseline_m == y.baseline_m && x.width == y.width && x.height == y.height;
}

// ---- enums ----------------------------------------------------------------

const char* to_string(MaskingMode mode) {
  switch (mode) {
    case MaskingMode::kNone: return "none";
    case MaskingMode::kBbox: return "bbox";
    case MaskingMode::kPixel: return "pixel";
    case MaskingMode::kHierarchical: return "hierarchical";
    case MaskingMode::kFull: return "full";
  }
  return "unknown";
}

const char* to_string(ClassifierMode mode) {
  switch (mode) {
    case ClassifierMode::kPaper: return "paper";
    case ClassifierMode::kSitepose: return "sitepose";
  }
  return "unknown";
}

const char* masking_mode_names() { return "none|bbox|pixel|hierarchical|full"; }
const char* classifier_mode_names() { return "paper|sitepose"; }

Expected<MaskingMode> parse_masking_mode(std::string_view name) {
  for (MaskingMode mode : {MaskingMode::kNone, MaskingMode::kBbox, MaskingMode::kPixel,
                           MaskingMode::kHierarchical, MaskingMode::kFull}) {
    if (name == to_string(mode)) return mode;
  }
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown masking mode \"" + echo_value(name) +
                        "\" (expected one of: none, bbox, pixel, hierarchical, full)");
}

Expected<ClassifierMode> parse_classifier_mode(std::string_view name) {
  for (ClassifierMode mode : {ClassifierMode::kPaper, ClassifierMode::kSitepose}) {
    if (name == to_string(mode)) return mode;
  }
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown classifier \"" + echo_value(name) +
                        "\" (expected one of: paper, sitepose)");
}

}  // namespace sitepose::config
