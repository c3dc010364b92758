#pragma once
// C++ side of a sitepose detector plugin: a plugin implements PluginImpl and
// make_plugin(); plugin_exports.cpp turns that into the C ABI of
// plugin_abi.h (exception guards, error strings, image wrapping). Compiled
// into each plugin shared library, never into the sitepose libraries.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <opencv2/core.hpp>

#include "sitepose/core/expected.hpp"
#include "sitepose/detect/plugin_abi.h"

namespace sitepose::detect::plugin {

class PluginImpl {
 public:
  virtual ~PluginImpl() = default;
  virtual std::uint32_t capabilities() const = 0;
  // left/right wrap the host's buffers (CV_8UC1, read-only, valid during the call).
  virtual Expected<std::vector<sp_detection>> detect(const cv::Mat& left, const cv::Mat& right,
                                                     std::int64_t t_ns, std::int64_t seq) = 0;
  // mask wraps the host's zeroed CV_16UC1 buffer.
  virtual Status segment(const cv::Mat& left, const cv::Mat& right, std::int64_t t_ns, std::int64_t seq,
                         const std::vector<sp_detection>& detections, cv::Mat& mask) = 0;
};

// Defined by each plugin: parses the create() config (a YAML mapping).
Expected<std::unique_ptr<PluginImpl>> make_plugin(const YAML::Node& config);

// Reading options from the create() config: every key must be known; errors
// name the key, the value and the expectation.
class OptionReader {
 public:
  OptionReader(const YAML::Node& root, std::string plugin) : root_(root), plugin_(std::move(plugin)) {}

  template <typename T>
  Status read(const std::string& key, T& out, bool required = false) {
    known_.push_back(key);
    const YAML::Node node = root_[key];
    if (!node) {
      if (required) return fail(key + ": required key missing");
      return ok_status();
    }
    try {
      out = node.as<T>();
    } catch (const std::exception&) {
      return fail(key + " = " + YAML::Dump(node) + ": wrong type");
    }
    return ok_status();
  }
  // Unknown keys are errors (a typo must not silently keep a default).
  Status finish() const {
    for (const auto& kv : root_) {
      const std::string key = kv.first.as<std::string>();
      bool ok = false;
      for (const auto& k : known_) ok = ok || k == key;
      if (!ok) {
        std::string list;
        for (const auto& k : known_) list += (list.empty() ? "" : ", ") + k;
        return fail(key + ": unknown key (expected one of: " + list + ")");
      }
    }
    return ok_status();
  }
  Unexpected fail(const std::string& what) const {
    return make_error(ErrorCode::kInvalidArgument, plugin_ + " config: " + what);
  }
  // Bounds of a value read (after finish(), so that a typo is named first);
  // NaN is outside both.
  Status require_non_negative(const std::string& key, double value) const {
    if (value >= 0.0) return ok_status();
    return fail(key + " must be >= 0");
  }
  Status require_unit_interval(const std::string& key, double value) const {
    if (value >= 0.0 && value <= 1.0) return ok_status();
    return fail(key + " must be in [0, 1]");
  }

 private:
  YAML::Node root_;
  std::string plugin_;
  std::vector<std::string> known_;
};

// A detection record with the class name copied (truncated to fit).
sp_detection make_detection(const std::string& class_name, float score, const cv::Rect& box,
                            std::uint16_t instance);

}  // namespace sitepose::detect::plugin
