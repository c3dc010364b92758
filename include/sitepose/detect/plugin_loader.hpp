#pragma once
// Loads a detector plugin (a shared library with the C ABI of plugin_abi.h)
// and wraps it as a Detector that validates everything the plugin returns.
//
// Loading: dlopen(path, RTLD_NOW | RTLD_LOCAL) — every undefined symbol is
// resolved at load time and the plugin's symbols stay private to it. Errors
// (kNotFound for a missing file, kUnsupported otherwise; each message names
// the path): the file does not load (dlerror() quoted), a symbol of the ABI
// is missing (named), the ABI version differs (both versions named), or
// sitepose_detector_create() fails (the plugin's message quoted).
//
// Validation per detection (dropped and counted in
// DetectorHealth::dropped_detections, never a failed call): score NaN,
// infinite or negative (a score > 1 is clamped to 1), instance 0, duplicate
// instance in one frame, class name not NUL-terminated or empty, box with
// w <= 0 or h <= 0, box with nothing left after clipping to the image
// (partly outside boxes are clipped), entries beyond `capacity`. Scores below
// `min_score` are filtered out without counting (that is thresholding, not
// garbage).
//
// Lifetime: the Detector owns the library handle; dlclose() runs after the
// plugin's destroy() when the Detector is destroyed.

#include <memory>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/detect/detector.hpp"

namespace sitepose::detect {

struct PluginLoadOptions {
  int capacity = 256;       // detections read per frame (array given to the plugin)
  double min_score = 0.0;   // detections scoring below are filtered out
  std::string name;         // Detector::name(); empty = the path
};

// `config_yaml` is handed verbatim to sitepose_detector_create().
Expected<std::unique_ptr<Detector>> load_detector_plugin(const std::string& path,
                                                         const std::string& config_yaml,
                                                         const PluginLoadOptions& options = {});

}  // namespace sitepose::detect
