#pragma once
// Creates the configured detector: a built-in name (labels |
// stereo-geometric | opencv-dnn) or a path to a plugin .so. Built-ins are
// plugins too, loaded through the same loader (plugin_loader.hpp).
//
// Where the built-in plugins are found (first hit wins):
//   1. $SITEPOSE_DETECTOR_PLUGIN_DIR, when set;
//   2. <directory of the running executable>/../lib/sitepose/detectors
//      (an installed layout: bin/sitepose next to lib/sitepose/detectors);
//   3. the build directory the plugins were built into (compiled in), so
//      binaries and tests run from the build tree without installing.
// File names: libsitepose_detector_<name with '-' as '_'>.so, e.g.
// libsitepose_detector_stereo_geometric.so.
//
// What each plugin is given (a YAML mapping, see plugin_abi.h):
//   labels:            sequence_dir, latency_ms, miss_probability, jitter_px,
//                      seed. Every labelled class is returned with its name;
//                      the masker filters by dynamic.dynamic_classes.
//   stereo-geometric:  fx, fy, cx, cy, baseline_m of the context camera,
//                      max_range_m, min_height_m.
//   opencv-dnn:        model_config, model_weights, classes_file,
//                      input_width_px, input_height_px, score_threshold.
//   a .so path:        sequence_dir (when known), camera {fx, fy, cx, cy,
//                      baseline_m, width, height} (when known), model_config,
//                      model_weights, score_threshold.
// DetectorConfig::score_threshold also filters every detector's output.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sitepose/config/sitepose_config.hpp"
#include "sitepose/core/expected.hpp"
#include "sitepose/core/stereo_camera.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/detect/isolated_detector.hpp"

namespace sitepose::detect {

struct DetectorContext {
  std::string sequence_dir;            // the sequence being run (labels); empty for live cameras
  std::optional<StereoCamera> camera;  // rectified camera of the frames (stereo-geometric)
};

// Path of a built-in plugin; kNotFound names every directory searched.
Expected<std::string> builtin_plugin_path(const std::string& name);

// The YAML text create() receives for this config and context; errors name
// the missing context (kInvalidArgument).
Expected<std::string> plugin_config_yaml(const config::DetectorConfig& config,
                                         const DetectorContext& context);

// `isolation`: a plugin .so path is run in sitepose-detector-host when
// isolation.in_child_process (isolated_detector.hpp); the built-ins always
// run in this process (they are part of sitepose, and tested with it).
Expected<std::unique_ptr<Detector>> create_detector(const config::DetectorConfig& config,
                                                    const DetectorContext& context,
                                                    const IsolationOptions& isolation = {});

// Adds to dynamic.dynamic_classes the classes the configured detector
// reports that are dynamic by construction: stereo-geometric's only class,
// "object" (anything standing above the ground); without it nothing would
// be masked. Returns the classes added (empty when none were missing).
std::vector<std::string> add_inherent_dynamic_classes(const config::DetectorConfig& detector,
                                                      config::DynamicConfig& dynamic);

}  // namespace sitepose::detect
