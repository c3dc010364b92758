#include "sitepose/detect/create_detector.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string_view>

#include <yaml-cpp/yaml.h>

#include "sitepose/detect/plugin_loader.hpp"

namespace sitepose::detect {
namespace {

namespace fs = std::filesystem;

bool is_builtin(const std::string& name) {
  return name == "labels" || name == "stereo-geometric" || name == "opencv-dnn";
}

std::string file_name(std::string name) {
  for (char& c : name) {
    if (c == '-') c = '_';
  }
  return "libsitepose_detector_" + name + ".so";
}

std::vector<fs::path> search_dirs() {
  std::vector<fs::path> dirs;
  if (const char* env = std::getenv("SITEPOSE_DETECTOR_PLUGIN_DIR"); env != nullptr && *env) {
    dirs.emplace_back(env);
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path() / ".." / "lib" / "sitepose" / "detectors");
  dirs.emplace_back(SITEPOSE_DETECTOR_BUILD_DIR);
  return dirs;
}

void emit_camera(YAML::Emitter& out, const StereoCamera& cam) {
  out << YAML::Key << "fx" << YAML::Value << cam.fx;
  out << YAML::Key << "fy" << YAML::Value << cam.fy;
  out << YAML::Key << "cx" << YAML::Value << cam.cx;
  out << YAML::Key << "cy" << YAML::Value << cam.cy;
  out << YAML::Key << "baseline_m" << YAML::Value << cam.baseline_m;
}

}  // namespace

Expected<std::string> builtin_plugin_path(const std::string& name) {
  if (!is_builtin(name)) {
    return make_error(ErrorCode::kInvalidArgument,
                      "detector " + name +
                          ": not a built-in detector (expected labels, stereo-geometric, "
                          "opencv-dnn, or a path to a plugin .so)");
  }
  std::string searched;
  for (const fs::path& dir : search_dirs()) {
    const fs::path candidate = dir / file_name(name);
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return fs::weakly_canonical(candidate, ec).string();
    searched += (searched.empty() ? "" : ", ") + dir.string();
  }
  return make_error(ErrorCode::kNotFound, "detector " + name + ": " + file_name(name) + " not found in: " +
                                              searched + " (set SITEPOSE_DETECTOR_PLUGIN_DIR)");
}

Expected<std::string> plugin_config_yaml(const config::DetectorConfig& config,
                                         const DetectorContext& context) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  if (config.name == "labels") {
    if (context.sequence_dir.empty()) {
      return make_error(ErrorCode::kInvalidArgument,
                        "detector labels needs a sequence directory (labels/boxes.csv); "
                        "live cameras need another detector");
    }
    out << YAML::Key << "sequence_dir" << YAML::Value << context.sequence_dir;
    out << YAML::Key << "latency_ms" << YAML::Value << config.labels_latency_ms;
    out << YAML::Key << "miss_probability" << YAML::Value << config.labels_miss_probability;
    out << YAML::Key << "jitter_px" << YAML::Value << config.labels_jitter_px;
    out << YAML::Key << "seed" << YAML::Value << config.labels_seed;
  } else if (config.name == "stereo-geometric") {
    if (!context.camera) {
      return make_error(ErrorCode::kInvalidArgument,
                        "detector stereo-geometric needs the rectified stereo camera");
    }
    emit_camera(out, *context.camera);
    out << YAML::Key << "max_range_m" << YAML::Value << config.geometric_max_range_m;
    out << YAML::Key << "min_height_m" << YAML::Value << config.geometric_min_height_m;
  } else if (config.name == "opencv-dnn") {
    out << YAML::Key << "model_config" << YAML::Value << config.model_config;
    out << YAML::Key << "model_weights" << YAML::Value << config.model_weights;
    out << YAML::Key << "classes_file" << YAML::Value << config.dnn_classes_file;
    out << YAML::Key << "input_width_px" << YAML::Value << config.dnn_input_width_px;
    out << YAML::Key << "input_height_px" << YAML::Value << config.dnn_input_height_px;
    out << YAML::Key << "score_threshold" << YAML::Value << config.score_threshold;
  } else {
    if (!context.sequence_dir.empty()) {
      out << YAML::Key << "sequence_dir" << YAML::Value << context.sequence_dir;
    }
    if (context.camera) {
      out << YAML::Key << "camera" << YAML::Value << YAML::BeginMap;
      emit_camera(out, *context.camera);
      out << YAML::Key << "width" << YAML::Value << context.camera->width;
      out << YAML::Key << "height" << YAML::Value << context.camera->height;
      out << YAML::EndMap;
    }
    out << YAML::Key << "model_config" << YAML::Value << config.model_config;
    out << YAML::Key << "model_weights" << YAML::Value << config.model_weights;
    out << YAML::Key << "score_threshold" << YAML::Value << config.score_threshold;
  }
  out << YAML::EndMap;
  if (!out.good()) {
    return make_error(ErrorCode::kRuntime,
                      "detector " + config.name + ": cannot write the plugin config: " + out.GetLastError());
  }
  return std::string(out.c_str());
}

Expected<std::unique_ptr<Detector>> create_detector(const config::DetectorConfig& config,
                                                    const DetectorContext& context,
                                                    const IsolationOptions& isolation) {
  std::string path = config.name;
  if (is_builtin(config.name)) {
    SITEPOSE_TRY(path, builtin_plugin_path(config.name));
  }
  SITEPOSE_TRY(std::string yaml, plugin_config_yaml(config, context));
  PluginLoadOptions options;
  options.min_score = config.score_threshold;
  options.name = config.name;
  if (isolation.in_child_process && !is_builtin(config.name)) {
    return load_isolated_plugin(path, yaml, options, isolation);
  }
  return load_detector_plugin(path, yaml, options);
}

std::vector<std::string> add_inherent_dynamic_classes(const config::DetectorConfig& detector,
                                                      config::DynamicConfig& dynamic) {
  std::vector<std::string> added;
  if (detector.name == "stereo-geometric") {
    const auto& classes = dynamic.dynamic_classes;
    if (std::find(classes.begin(), classes.end(), "object") == classes.end()) {
      dynamic.dynamic_classes.push_back("object");
      added.push_back("object");
    }
  }
  return added;
}

}  // namespace sitepose::detect
