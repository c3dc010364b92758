#pragma once
// The two halves of a plugin Detector (plugin_loader.hpp):
//   * PluginLibrary: the plugin's C entry points, dlopen()ed and checked
//     (every ABI symbol present, the ABI version equal). Used in this
//     process and by sitepose-detector-host in its own.
//   * PluginCalls: how the Detector reaches detect() and segment() of a
//     created plugin: in this process (function pointers) or in a child
//     process (isolated_detector.hpp). make_plugin_detector() puts the
//     validation of plugin_loader.hpp on top of either, so the output of an
//     isolated plugin is checked exactly like that of an in-process one.

#include <cstdint>
#include <memory>
#include <string>

#include "sitepose/core/expected.hpp"
#include "sitepose/detect/detector.hpp"
#include "sitepose/detect/plugin_abi.h"
#include "sitepose/detect/plugin_loader.hpp"

namespace sitepose::detect {

struct PluginApi {
  sp_abi_version_fn abi_version = nullptr;
  sp_create_fn create = nullptr;
  sp_capabilities_fn capabilities = nullptr;
  sp_detect_fn detect = nullptr;
  sp_segment_fn segment = nullptr;
  sp_destroy_fn destroy = nullptr;
};

// A loaded plugin library and the handle create() gave; destroy() and
// dlclose() run when the last owner goes.
class CreatedPlugin {
 public:
  virtual ~CreatedPlugin() = default;
  virtual const PluginApi& api() const = 0;
  virtual sp_detector* handle() const = 0;
};

// dlopen(path) (RTLD_NODELETE is not set: the library is closed after
// destroy()), every symbol resolved, the version checked, create(config)
// called. Errors as load_detector_plugin() documents them.
Expected<std::unique_ptr<CreatedPlugin>> create_plugin(const std::string& path,
                                                       const std::string& config_yaml);

class PluginCalls {
 public:
  virtual ~PluginCalls() = default;
  // SP_DETECTOR_CAP_* bits.
  virtual std::uint32_t capabilities() const = 0;
  // As sp_detect_fn / sp_segment_fn of plugin_abi.h; `error` gets the
  // message of a non-zero return.
  virtual int detect(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
                     sp_detection* out, std::int32_t capacity, std::int32_t* count, std::string& error) = 0;
  virtual int segment(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
                      const sp_detection* detections, std::int32_t n_detections, std::uint16_t* mask,
                      std::int32_t mask_stride_px, std::string& error) = 0;
};

// Calls a created plugin in this process.
std::unique_ptr<PluginCalls> in_process_calls(std::unique_ptr<CreatedPlugin> plugin);

// The validating Detector over `calls` (options.capacity >= 1; name as
// PluginLoadOptions::name, which must be set).
std::unique_ptr<Detector> make_plugin_detector(std::unique_ptr<PluginCalls> calls, PluginLoadOptions options);

}  // namespace sitepose::detect
