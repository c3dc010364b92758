// The sitepose configuration's table: every key of config/sitepose.yaml
// once, with its rule. Bounds reject values that break the algorithm (a
// negative count, a ratio outside [0, 1]); the defaults are the struct
// initialisers of sitepose_config.hpp, their sources in config/sitepose.yaml
// and METHOD.md.

#include "sitepose/config/config.hpp"

#include <optional>
#include <string>

#include "detail/orb_limits.hpp"
#include "sitepose/core/echo.hpp"
#include "sitepose/core/enum_names.hpp"

namespace sitepose::config {

namespace {

Section<StereoCamera> stereo_camera_section() {
  // A partial override would mix two calibrations: all keys or none.
  Section<StereoCamera> s;
  s.required("fx", &StereoCamera::fx, positive())
      .required("fy", &StereoCamera::fy, positive())
      .required("cx", &StereoCamera::cx, non_negative())
      .required("cy", &StereoCamera::cy, non_negative())
      .required("baseline_m", &StereoCamera::baseline_m, positive())
      .required("width", &StereoCamera::width, positive())
      .required("height", &StereoCamera::height, positive())
      .check([](const ReadKeys& keys, const StereoCamera& cam) {
        if (!keys.all_valid()) return;
        if (const Status valid = cam.validate(); !valid) keys.map().report_here(valid.error().message);
      });
  return s;
}

Section<CameraConfig> camera_section() {
  Section<CameraConfig> s;
  s.choice("channel_order", &CameraConfig::channel_order,
           {Choice<ChannelOrder>{ChannelOrder::kBgr, "bgr"}, Choice<ChannelOrder>{ChannelOrder::kRgb, "rgb"}})
      .optional_section("stereo", &CameraConfig::stereo, stereo_camera_section(),
                        "stereo calibration from the sequence (calib.txt)");
  return s;
}

Section<OrbConfig> orb_section() {
  Section<OrbConfig> s;
  s.key("n_features", &OrbConfig::n_features, in_range(detail::kMinOrbFeatures, detail::kMaxOrbFeatures))
      .key("scale_factor", &OrbConfig::scale_factor, greater_than(1.0), at_most(detail::kMaxScaleFactor))
      .key("n_levels", &OrbConfig::n_levels, in_range(1, detail::kMaxLevels))
      .key("strong_fast_threshold", &OrbConfig::strong_fast_threshold, in_range(0, detail::kMaxFastThreshold))
      .key("ini_fast_threshold", &OrbConfig::ini_fast_threshold, in_range(1, detail::kMaxFastThreshold))
      .key("min_fast_threshold", &OrbConfig::min_fast_threshold, in_range(1, detail::kMaxFastThreshold))
      .key("grid_cell_px", &OrbConfig::grid_cell_px, in_range(8, 500))
      .check([](const ReadKeys& keys, const OrbConfig& orb) {
        if (keys.valid("min_fast_threshold") && orb.min_fast_threshold > orb.ini_fast_threshold) {
          keys.report("min_fast_threshold",
                      "must be <= orb.ini_fast_threshold (" + std::to_string(orb.ini_fast_threshold) + ")");
        }
      });
  return s;
}

Section<StereoMatchConfig> stereo_section() {
  Section<StereoMatchConfig> s;
  s.key("min_disparity_px", &StereoMatchConfig::min_disparity_px, positive())
      .key("max_disparity_px", &StereoMatchConfig::max_disparity_px, positive())
      .key("max_descriptor_distance", &StereoMatchConfig::max_descriptor_distance, in_range(0, 256))
      .key("sad_half_window_px", &StereoMatchConfig::sad_half_window_px, in_range(1, 30))
      .key("row_band_px", &StereoMatchConfig::row_band_px, in_range(0, 20))
      .check([](const ReadKeys& keys, const StereoMatchConfig& stereo) {
        if (keys.valid("max_disparity_px") && stereo.max_disparity_px <= stereo.min_disparity_px) {
          keys.report("max_disparity_px", "must be > stereo.min_disparity_px (" +
                                              detail::number_text(stereo.min_disparity_px) + ")");
        }
      });
  return s;
}

Section<TrackingConfig> tracking_section() {
  using T = TrackingConfig;
  Section<T> s;
  s.key("close_depth_baselines", &T::close_depth_baselines, positive(),
        at_most(detail::kMaxCloseDepthBaselines))
      .key("motion_ba_rounds", &T::motion_ba_rounds, in_range(1, 20))
      .key("motion_ba_iterations", &T::motion_ba_iterations, in_range(1, 200))
      .key("chi2_mono", &T::chi2_mono, positive())
      .key("chi2_stereo", &T::chi2_stereo, positive())
      // A stereo pose has 6 dof; below ~10 inliers "tracking OK" means nothing.
      .key("min_inliers_ok", &T::min_inliers_ok, at_least(10))
      .key("min_inliers_recovering", &T::min_inliers_recovering, at_least(3))
      .key("relocalisation_hold_frames", &T::relocalisation_hold_frames, in_range(1, 100))
      .key("keyframe_max_interval_frames", &T::keyframe_max_interval_frames, non_negative())
      .key("keyframe_tracked_ratio", &T::keyframe_tracked_ratio, greater_than(0.0), at_most(1.0))
      .key("keyframe_min_close_points", &T::keyframe_min_close_points, non_negative())
      .key("keyframe_new_close_points", &T::keyframe_new_close_points, non_negative())
      .key("trust_established_map", &T::trust_established_map)
      .key("keep_tracked_corners", &T::keep_tracked_corners)
      .key("keyframe_travel_depth_share", &T::keyframe_travel_depth_share, non_negative(), at_most(1.0))
      .key("new_map_after_lost_s", &T::new_map_after_lost_s, non_negative(), at_most(3600.0))
      .check([](const ReadKeys& keys, const T& tracking) {
        if (keys.valid("min_inliers_recovering") &&
            tracking.min_inliers_recovering > tracking.min_inliers_ok) {
          keys.report("min_inliers_recovering",
                      "must be <= tracking.min_inliers_ok (" + std::to_string(tracking.min_inliers_ok) + ")");
        }
      });
  return s;
}

Section<MappingConfig> mapping_section() {
  Section<MappingConfig> s;
  s.key("enabled", &MappingConfig::enabled)
      .key("local_ba_keyframes", &MappingConfig::local_ba_keyframes, in_range(1, 100))
      .key("local_ba_iterations", &MappingConfig::local_ba_iterations, in_range(1, 200))
      .key("keyframe_redundancy", &MappingConfig::keyframe_redundancy, greater_than(0.0), at_most(1.0))
      .key("min_point_observations", &MappingConfig::min_point_observations, in_range(1, 20))
      .key("site_culling", &MappingConfig::site_culling)
      .key("site_radius_m", &MappingConfig::site_radius_m, positive(), at_most(100.0))
      .key("site_angle_deg", &MappingConfig::site_angle_deg, positive(), at_most(180.0))
      .key("loop_closing", &MappingConfig::loop_closing);
  return s;
}

Section<DynamicConfig> dynamic_section() {
  using D = DynamicConfig;
  Section<D> s;
  s.parsed(
       "mode", &D::mode, [](const std::string& t) { return parse_masking_mode(t); },
       [](MaskingMode m) { return to_string(m); })
      .key("tau_mar", &D::tau_mar, in_range(0.0, 1.0))
      .parsed(
          "classifier", &D::classifier, [](const std::string& t) { return parse_classifier_mode(t); },
          [](ClassifierMode m) { return to_string(m); })
      .key("sigma_bkg_m", &D::sigma_bkg_m, positive())
      .key("static_inlier_fraction", &D::static_inlier_fraction, greater_than(0.0), at_most(1.0))
      .key("reference_offset_frames", &D::reference_offset_frames, in_range(0, 1000))
      .key("min_reference_parallax_m", &D::min_reference_parallax_m, non_negative())
      .key("chi2_static_3dof", &D::chi2_static_3dof, positive())
      .key("hysteresis_frames", &D::hysteresis_frames, in_range(1, 100))
      .key("min_object_points", &D::min_object_points, in_range(1, 10000))
      // An empty list is allowed: then only class-free detectors mark objects.
      .key("dynamic_classes", &D::dynamic_classes, each(non_empty()));
  return s;
}

bool is_plugin_path(const std::string& name) {
  return name.size() > 3 && name.compare(name.size() - 3, 3, ".so") == 0;
}

Section<DetectorConfig> detector_section() {
  using D = DetectorConfig;
  Section<D> s;
  s.key("name", &D::name,
        make_rule(
            [](const std::string& name) {
              return name == "labels" || name == "stereo-geometric" || name == "opencv-dnn" ||
                     is_plugin_path(name);
            },
            "expected one of: labels, stereo-geometric, opencv-dnn, or a plugin path ending in "
            ".so"))
      .key("model_config", &D::model_config)
      .key("model_weights", &D::model_weights)
      .key("score_threshold", &D::score_threshold, in_range(0.0, 1.0))
      .key("labels_latency_ms", &D::labels_latency_ms, in_range(0.0, 10000.0))
      .key("labels_miss_probability", &D::labels_miss_probability, in_range(0.0, 1.0))
      .key("labels_jitter_px", &D::labels_jitter_px, in_range(0.0, 1000.0))
      .key("labels_seed", &D::labels_seed)
      .key("geometric_max_range_m", &D::geometric_max_range_m, in_range(3.0, 1000.0))
      .key("geometric_min_height_m", &D::geometric_min_height_m, in_range(0.2, 10.0))
      .key("dnn_classes_file", &D::dnn_classes_file)
      .key("dnn_input_width_px", &D::dnn_input_width_px, in_range(1, 8192))
      .key("dnn_input_height_px", &D::dnn_input_height_px, in_range(1, 8192))
      .check([](const ReadKeys& keys, const D& detector) {
        // The dnn detector cannot start without weights: say so at load time.
        // (model_config may stay empty: a TensorFlow .pb is a single file.)
        if (detector.name == "opencv-dnn" && detector.model_weights.empty()) {
          keys.report("model_weights", "required when detector.name is opencv-dnn");
        }
      });
  return s;
}

Section<LoggingConfig> logging_section() {
  Section<LoggingConfig> s;
  s.key("level", &LoggingConfig::level, one_of({"trace", "debug", "info", "warn", "error", "off"}));
  return s;
}

Section<SiteposeConfig> make_sitepose_sections() {
  using C = SiteposeConfig;
  Section<C> s;
  s.section("camera", &C::camera, camera_section())
      .section("orb", &C::orb, orb_section())
      .section("stereo", &C::stereo, stereo_section())
      .section("tracking", &C::tracking, tracking_section())
      .section("mapping", &C::mapping, mapping_section())
      .section("dynamic", &C::dynamic, dynamic_section())
      .section("detector", &C::detector, detector_section())
      .section("logging", &C::logging, logging_section());
  return s;
}

Expected<SiteposeConfig> finish_loading(const YamlReader& reader) {
  SiteposeConfig config;
  sitepose_sections().read(reader.root(), config);
  SITEPOSE_TRY_STATUS(reader.finish());
  return config;
}

}  // namespace

const Section<SiteposeConfig>& sitepose_sections() {
  static const Section<SiteposeConfig> sections = make_sitepose_sections();
  return sections;
}

std::string to_yaml(const SiteposeConfig& config) { return write_yaml(sitepose_sections(), config); }

Expected<SiteposeConfig> load_config(const std::string& path) {
  SITEPOSE_TRY(const std::string text, read_yaml_file(path));
  return load_config_from_string(text, path);
}

Expected<SiteposeConfig> load_config_from_string(std::string_view text, const std::string& source_name) {
  // yaml-cpp accepts OpenCV's "%YAML:1.0" header, and every key would then
  // be reported unknown; name the likely mix-up instead.
  if (text.substr(0, 6) == "%YAML:") {
    return make_error(ErrorCode::kInvalidArgument,
                      source_name +
                          ":1: this is an OpenCV FileStorage file (%YAML:1.0), such as "
                          "ORB-SLAM2 settings, not a sitepose configuration (see "
                          "config/sitepose.yaml); ORB-SLAM2 settings are read by "
                          "load_orbslam2_settings");
  }
  SITEPOSE_TRY(const YamlReader reader, YamlReader::from_string(text, source_name));
  return finish_loading(reader);
}

bool operator==(const CameraConfig& a, const CameraConfig& b) {
  if (a.channel_order != b.channel_order) return false;
  if (a.stereo.has_value() != b.stereo.has_value()) return false;
  if (!a.stereo) return true;
  const StereoCamera& x = *a.stereo;
  const StereoCamera& y = *b.stereo;
  return x.fx == y.fx && x.fy == y.fy && x.cx == y.cx && x.cy == y.cy && x.baseline_m == y.baseline_m &&
         x.width == y.width && x.height == y.height;
}

// ---- enums ----------------------------------------------------------------

constexpr auto kMaskingModeNames = enum_names<MaskingMode>({{MaskingMode::kNone, "none"},
                                                            {MaskingMode::kBbox, "bbox"},
                                                            {MaskingMode::kPixel, "pixel"},
                                                            {MaskingMode::kHierarchical, "hierarchical"},
                                                            {MaskingMode::kFull, "full"}},
                                                           "unknown");

const char* to_string(MaskingMode mode) { return kMaskingModeNames.name(mode); }

constexpr auto kClassifierModeNames = enum_names<ClassifierMode>(
    {{ClassifierMode::kPaper, "paper"}, {ClassifierMode::kSitepose, "sitepose"}}, "unknown");

const char* to_string(ClassifierMode mode) { return kClassifierModeNames.name(mode); }

const char* masking_mode_names() { return "none|bbox|pixel|hierarchical|full"; }
const char* classifier_mode_names() { return "paper|sitepose"; }

Expected<MaskingMode> parse_masking_mode(std::string_view name) {
  if (const std::optional<MaskingMode> mode = kMaskingModeNames.parse(name)) return *mode;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown masking mode \"" + echo_value(name) +
                        "\" (expected one of: " + kMaskingModeNames.joined(", ") + ")");
}

Expected<ClassifierMode> parse_classifier_mode(std::string_view name) {
  if (const std::optional<ClassifierMode> mode = kClassifierModeNames.parse(name)) return *mode;
  return make_error(ErrorCode::kInvalidArgument,
                    "unknown classifier \"" + echo_value(name) +
                        "\" (expected one of: " + kClassifierModeNames.joined(", ") + ")");
}

}  // namespace sitepose::config
