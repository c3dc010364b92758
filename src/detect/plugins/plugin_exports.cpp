// The C ABI of plugin_abi.h on top of plugin::PluginImpl. Nothing thrown
// inside a plugin may cross into the host: every entry point catches.

#include <algorithm>
#include <cstring>
#include <exception>
#include <string>

#include "plugin_support.hpp"

#define SP_EXPORT extern "C" __attribute__((visibility("default")))

struct sp_detector {
  std::unique_ptr<sitepose::detect::plugin::PluginImpl> impl;
};

namespace sitepose::detect::plugin {

sp_detection make_detection(const std::string& class_name, float score, const cv::Rect& box,
                            std::uint16_t instance) {
  sp_detection d{};
  const std::size_t n = std::min(class_name.size(), sizeof(d.class_name) - 1);
  std::memcpy(d.class_name, class_name.data(), n);
  d.score = score;
  d.x = box.x;
  d.y = box.y;
  d.w = box.width;
  d.h = box.height;
  d.instance = instance;
  return d;
}

}  // namespace sitepose::detect::plugin

namespace {

using sitepose::detect::plugin::PluginImpl;

void write_error(char* err, size_t errlen, const std::string& message) {
  if (err == nullptr || errlen == 0) return;
  const std::size_t n = std::min(message.size(), errlen - 1);
  std::memcpy(err, message.data(), n);
  err[n] = '\0';
}

cv::Mat wrap(const sp_image* image) {
  if (image == nullptr || image->data == nullptr || image->width <= 0 || image->height <= 0) {
    return cv::Mat();
  }
  // The host owns the pixels; the plugin only reads them.
  return cv::Mat(image->height, image->width, CV_8UC1, const_cast<uint8_t*>(image->data),
                 static_cast<std::size_t>(image->stride_bytes));
}

// Runs f() and turns an Expected error or an exception into a message.
template <typename F>
int guarded(char* err, size_t errlen, F&& f) {
  try {
    const sitepose::Status status = f();
    if (!status) {
      write_error(err, errlen, status.error().message);
      return 1;
    }
    return 0;
  } catch (const std::exception& e) {
    write_error(err, errlen, std::string("exception: ") + e.what());
  } catch (...) {
    write_error(err, errlen, "unknown exception");
  }
  return 1;
}

}  // namespace

SP_EXPORT uint32_t sitepose_detector_abi_version(void) { return SITEPOSE_DETECTOR_ABI_VERSION; }

SP_EXPORT sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen) {
  sp_detector* handle = nullptr;
  guarded(err, errlen, [&]() -> sitepose::Status {
    YAML::Node root = YAML::Load(config != nullptr ? config : "");
    if (!root.IsMap() && !root.IsNull()) {
      return sitepose::make_error(sitepose::ErrorCode::kInvalidArgument,
                                  "config must be a YAML mapping");
    }
    if (root.IsNull()) root = YAML::Node(YAML::NodeType::Map);
    auto impl = sitepose::detect::plugin::make_plugin(root);
    if (!impl) return sitepose::Unexpected{impl.error()};
    handle = new sp_detector{std::move(impl).value()};
    return sitepose::ok_status();
  });
  return handle;
}

SP_EXPORT uint32_t sitepose_detector_capabilities(const sp_detector* handle) {
  return handle != nullptr ? handle->impl->capabilities() : 0u;
}

SP_EXPORT int sitepose_detector_detect(sp_detector* handle, const sp_image* left,
                                       const sp_image* right, int64_t t_ns, int64_t seq,
                                       sp_detection* out, int32_t capacity, int32_t* count,
                                       char* err, size_t errlen) {
  return guarded(err, errlen, [&]() -> sitepose::Status {
    if (handle == nullptr || out == nullptr || count == nullptr || capacity < 0) {
      return sitepose::make_error(sitepose::ErrorCode::kInvalidArgument, "null argument");
    }
    const cv::Mat l = wrap(left), r = wrap(right);
    if (l.empty() || r.empty()) {
      return sitepose::make_error(sitepose::ErrorCode::kInvalidArgument, "empty image");
    }
    auto detections = handle->impl->detect(l, r, t_ns, seq);
    if (!detections) return sitepose::Unexpected{detections.error()};
    const auto n = static_cast<int32_t>(detections->size());
    std::copy_n(detections->begin(), std::min(n, capacity), out);
    *count = n;
    return sitepose::ok_status();
  });
}

SP_EXPORT int sitepose_detector_segment(sp_detector* handle, const sp_image* left,
                                        const sp_image* right, int64_t t_ns, int64_t seq,
                                        const sp_detection* detections, int32_t n_detections,
                                        uint16_t* mask, int32_t mask_stride_px, char* err,
                                        size_t errlen) {
  return guarded(err, errlen, [&]() -> sitepose::Status {
    if (handle == nullptr || mask == nullptr || n_detections < 0 ||
        (detections == nullptr && n_detections > 0)) {
      return sitepose::make_error(sitepose::ErrorCode::kInvalidArgument, "null argument");
    }
    const cv::Mat l = wrap(left), r = wrap(right);
    if (l.empty() || r.empty() || mask_stride_px < l.cols) {
      return sitepose::make_error(sitepose::ErrorCode::kInvalidArgument,
                                  "empty image or mask stride below the width");
    }
    cv::Mat m(l.rows, l.cols, CV_16UC1, mask,
              static_cast<std::size_t>(mask_stride_px) * sizeof(uint16_t));
    const std::vector<sp_detection> input(detections, detections + n_detections);
    return handle->impl->segment(l, r, t_ns, seq, input, m);
  });
}

SP_EXPORT void sitepose_detector_destroy(sp_detector* handle) { delete handle; }
