// to_yaml: the resolved configuration in the layout of config/sitepose.yaml.
// Numbers use the shortest text that reads back to the same double, so
// load_config(to_yaml(c)) == c.

#include <string>

#include "sitepose/config/config.hpp"

namespace sitepose::config {

namespace {

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          static const char kHex[] = "0123456789abcdef";
          out += "\\x";
          out += kHex[(c >> 4) & 0xf];
          out += kHex[c & 0xf];
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

class Writer {
 public:
  void section(const char* name) { text_ += std::string(name) + ":\n"; }
  void key(const char* name, const std::string& value, int indent = 2) {
    text_ += std::string(indent, ' ') + name + ": " + value + "\n";
  }
  void key(const char* name, double value, int indent = 2) {
    key(name, detail::number_text(value), indent);
  }
  void key(const char* name, int value, int indent = 2) {
    key(name, std::to_string(value), indent);
  }
  void key(const char* name, bool value, int indent = 2) {
    key(name, std::string(value ? "true" : "false"), indent);
  }
  void text(const std::string& line) { text_ += line + "\n"; }
  std::string take() { return std::move(text_); }

 private:
  std::string text_;
};

}  // namespace

std::string to_yaml(const SiteposeConfig& config) {
  Writer w;
  if (config.camera.stereo) {
    const StereoCamera& cam = *config.camera.stereo;
    w.section("camera");
    w.text("  stereo:");
    w.key("fx", cam.fx, 4);
    w.key("fy", cam.fy, 4);
    w.key("cx", cam.cx, 4);
    w.key("cy", cam.cy, 4);
    w.key("baseline_m", cam.baseline_m, 4);
    w.key("width", cam.width, 4);
    w.key("height", cam.height, 4);
  } else {
    w.text("camera: {}  # stereo calibration from the sequence (calib.txt)");
  }

  const OrbConfig& orb = config.orb;
  w.section("orb");
  w.key("n_features", orb.n_features);
  w.key("scale_factor", orb.scale_factor);
  w.key("n_levels", orb.n_levels);
  w.key("ini_fast_threshold", orb.ini_fast_threshold);
  w.key("min_fast_threshold", orb.min_fast_threshold);
  w.key("grid_cell_px", orb.grid_cell_px);

  const StereoMatchConfig& stereo = config.stereo;
  w.section("stereo");
  w.key("min_disparity_px", stereo.min_disparity_px);
  w.key("max_disparity_px", stereo.max_disparity_px);
  w.key("max_descriptor_distance", stereo.max_descriptor_distance);
  w.key("sad_half_window_px", stereo.sad_half_window_px);
  w.key("row_band_px", stereo.row_band_px);

  const TrackingConfig& tracking = config.tracking;
  w.section("tracking");
  w.key("close_depth_baselines", tracking.close_depth_baselines);
  w.key("motion_ba_rounds", tracking.motion_ba_rounds);
  w.key("motion_ba_iterations", tracking.motion_ba_iterations);
  w.key("chi2_mono", tracking.chi2_mono);
  w.key("chi2_stereo", tracking.chi2_stereo);
  w.key("min_inliers_ok", tracking.min_inliers_ok);
  w.key("min_inliers_recovering", tracking.min_inliers_recovering);
  w.key("keyframe_max_interval_frames", tracking.keyframe_max_interval_frames);
  w.key("keyframe_tracked_ratio", tracking.keyframe_tracked_ratio);
  w.key("keyframe_min_close_points", tracking.keyframe_min_close_points);
  w.key("keyframe_new_close_points", tracking.keyframe_new_close_points);

  const MappingConfig& mapping = config.mapping;
  w.section("mapping");
  w.key("enabled", mapping.enabled);
  w.key("local_ba_keyframes", mapping.local_ba_keyframes);
  w.key("local_ba_iterations", mapping.local_ba_iterations);
  w.key("keyframe_redundancy", mapping.keyframe_redundancy);
  w.key("min_point_observations", mapping.min_point_observations);

  const DynamicConfig& dynamic = config.dynamic;
  w.section("dynamic");
  w.key("mode", std::string(to_string(dynamic.mode)));
  w.key("tau_mar", dynamic.tau_mar);
  w.key("classifier", std::string(to_string(dynamic.classifier)));
  w.key("sigma_bkg_m", dynamic.sigma_bkg_m);
  w.key("static_inlier_fraction", dynamic.static_inlier_fraction);
  w.key("reference_offset_frames", dynamic.reference_offset_frames);
  w.key("min_reference_parallax_m", dynamic.min_reference_parallax_m);
  w.key("chi2_static_3dof", dynamic.chi2_static_3dof);
  w.key("hysteresis_frames", dynamic.hysteresis_frames);
  w.key("min_object_points", dynamic.min_object_points);
  std::string classes = "[";
  for (std::size_t i = 0; i < dynamic.dynamic_classes.size(); ++i) {
    if (i > 0) classes += ", ";
    classes += quoted(dynamic.dynamic_classes[i]);
  }
  w.key("dynamic_classes", classes + "]");

  const DetectorConfig& detector = config.detector;
  w.section("detector");
  w.key("name", quoted(detector.name));
  w.key("model_config", quoted(detector.model_config));
  w.key("model_weights", quoted(detector.model_weights));
  w.key("score_threshold", detector.score_threshold);
  w.key("labels_latency_ms", detector.labels_latency_ms);
  w.key("labels_miss_probability", detector.labels_miss_probability);
  w.key("labels_jitter_px", detector.labels_jitter_px);
  w.key("labels_seed", detector.labels_seed);
  w.key("geometric_max_range_m", detector.geometric_max_range_m);
  w.key("geometric_min_height_m", detector.geometric_min_height_m);
  w.key("dnn_classes_file", quoted(detector.dnn_classes_file));
  w.key("dnn_input_width_px", detector.dnn_input_width_px);
  w.key("dnn_input_height_px", detector.dnn_input_height_px);

  w.section("logging");
  w.key("level", quoted(config.logging.level));
  return w.take();
}

}  // namespace sitepose::config
