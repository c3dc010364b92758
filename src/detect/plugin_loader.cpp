#include "sitepose/detect/plugin_loader.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "sitepose/detect/plugin_abi.h"
#include "sitepose/detect/plugin_calls.hpp"

namespace sitepose::detect {
namespace {

constexpr std::size_t kErrLen = 512;

// Closes the library when the last owner goes (after the handle is destroyed).
struct LibraryCloser {
  void operator()(void* lib) const {
    if (lib != nullptr) dlclose(lib);
  }
};
using LibraryPtr = std::unique_ptr<void, LibraryCloser>;

sp_image to_sp_image(const cv::Mat& image) {
  sp_image out{};
  out.width = image.cols;
  out.height = image.rows;
  out.stride_bytes = static_cast<std::int32_t>(image.step[0]);
  out.data = image.data;
  return out;
}

std::string error_text(const std::array<char, kErrLen>& err) {
  return {err.begin(), std::find(err.begin(), err.end(), '\0')};
}

std::string or_no_message(const std::string& text) {
  return text.empty() ? std::string("(no message)") : text;
}

// An image the ABI can carry: 8-bit single channel, non-empty, contiguous rows.
Status check_frame(const StereoFrame& frame, const std::string& name) {
  const auto bad = [&](const char* what) {
    return make_error(ErrorCode::kInvalidArgument,
                      "detector " + name + ": frame " + std::to_string(frame.seq) + ": " + what);
  };
  if (frame.left.empty() || frame.right.empty()) return bad("empty left or right image");
  if (frame.left.type() != CV_8UC1 || frame.right.type() != CV_8UC1) {
    return bad("images must be CV_8UC1");
  }
  if (frame.left.size() != frame.right.size()) return bad("left and right sizes differ");
  return ok_status();
}

class PluginDetector final : public Detector {
 public:
  PluginDetector(std::unique_ptr<PluginCalls> calls, PluginLoadOptions options)
      : calls_(std::move(calls)),
        name_(options.name),
        options_(std::move(options)),
        buffer_(static_cast<std::size_t>(std::max(1, options_.capacity))) {
    const std::uint32_t caps = calls_->capabilities();
    capabilities_.has_segmentation = (caps & SP_DETECTOR_CAP_SEGMENTATION) != 0;
    capabilities_.tracks_ids = (caps & SP_DETECTOR_CAP_TRACKS_IDS) != 0;
  }

  const std::string& name() const override { return name_; }
  DetectorCapabilities capabilities() const override { return capabilities_; }
  DetectorHealth health() const override { return health_; }

  Expected<std::vector<Detection>> detect(const StereoFrame& frame) override {
    SITEPOSE_TRY_STATUS(check_frame(frame, name_));
    ++health_.frames;
    const sp_image left = to_sp_image(frame.left);
    const sp_image right = to_sp_image(frame.right);
    std::string err;
    std::int32_t count = 0;
    std::fill(buffer_.begin(), buffer_.end(), sp_detection{});
    const int rc = calls_->detect(left, right, frame.t_ns(), frame.seq, buffer_.data(),
                                  static_cast<std::int32_t>(buffer_.size()), &count, err);
    if (rc != 0 || count < 0) {
      ++health_.failed_calls;
      const std::string why =
          rc != 0 ? or_no_message(err) : "returned a negative count " + std::to_string(count);
      return make_error(ErrorCode::kRuntime,
                        "detector " + name_ + ": frame " + std::to_string(frame.seq) + ": " + why);
    }
    const auto capacity = static_cast<std::int32_t>(buffer_.size());
    if (count > capacity) health_.dropped_detections += count - capacity;
    const cv::Rect image_rect(0, 0, frame.left.cols, frame.left.rows);
    std::vector<Detection> out;
    std::set<std::uint16_t> seen;
    for (std::int32_t i = 0; i < std::min(count, capacity); ++i) {
      auto detection = validate(buffer_[static_cast<std::size_t>(i)], image_rect);
      if (!detection || !seen.insert(detection->instance).second) {
        ++health_.dropped_detections;
        continue;
      }
      if (detection->score < options_.min_score) continue;
      out.push_back(std::move(*detection));
    }
    health_.detections += static_cast<std::int64_t>(out.size());
    return out;
  }

  Expected<cv::Mat> segment(const StereoFrame& frame, const std::vector<Detection>& detections) override {
    if (!capabilities_.has_segmentation) {
      return make_error(ErrorCode::kUnsupported, "detector " + name_ + " has no pixel segmentation");
    }
    SITEPOSE_TRY_STATUS(check_frame(frame, name_));
    ++health_.segment_calls;
    std::vector<sp_detection> input;
    input.reserve(detections.size());
    for (const Detection& d : detections) {
      sp_detection s{};
      const std::size_t n = std::min(d.class_name.size(), sizeof(s.class_name) - 1);
      std::memcpy(s.class_name, d.class_name.data(), n);
      s.score = static_cast<float>(d.score);
      s.x = d.box.x;
      s.y = d.box.y;
      s.w = d.box.width;
      s.h = d.box.height;
      s.instance = d.instance;
      input.push_back(s);
    }
    cv::Mat mask(frame.left.size(), CV_16UC1, cv::Scalar(0));
    const sp_image left = to_sp_image(frame.left);
    const sp_image right = to_sp_image(frame.right);
    std::string err;
    const int rc = calls_->segment(left, right, frame.t_ns(), frame.seq, input.data(),
                                   static_cast<std::int32_t>(input.size()), mask.ptr<std::uint16_t>(),
                                   static_cast<std::int32_t>(mask.step[0] / sizeof(std::uint16_t)), err);
    if (rc != 0) {
      ++health_.failed_calls;
      return make_error(ErrorCode::kRuntime, "detector " + name_ + ": segment frame " +
                                                 std::to_string(frame.seq) + ": " + or_no_message(err));
    }
    health_.cleared_mask_pixels += clear_outside_boxes(mask, detections);
    return mask;
  }

 private:
  // A checked copy of one plugin detection, or nullopt when it is garbage.
  static std::optional<Detection> validate(const sp_detection& raw, const cv::Rect& image_rect) {
    const char* end = std::find(raw.class_name, raw.class_name + sizeof(raw.class_name), '\0');
    if (end == raw.class_name + sizeof(raw.class_name) || end == raw.class_name) {
      return std::nullopt;
    }
    if (!std::isfinite(raw.score) || raw.score < 0.0f) return std::nullopt;
    if (raw.instance == 0 || raw.w <= 0 || raw.h <= 0) return std::nullopt;
    // 64-bit corners: x + w of two large int32 must not overflow.
    const std::int64_t x0 = std::max<std::int64_t>(raw.x, image_rect.x);
    const std::int64_t y0 = std::max<std::int64_t>(raw.y, image_rect.y);
    const std::int64_t x1 = std::min<std::int64_t>(std::int64_t{raw.x} + raw.w, image_rect.br().x);
    const std::int64_t y1 = std::min<std::int64_t>(std::int64_t{raw.y} + raw.h, image_rect.br().y);
    if (x1 <= x0 || y1 <= y0) return std::nullopt;
    Detection d;
    d.class_name.assign(raw.class_name, end);
    d.score = std::min(1.0, static_cast<double>(raw.score));
    d.box = cv::Rect(static_cast<int>(x0), static_cast<int>(y0), static_cast<int>(x1 - x0),
                     static_cast<int>(y1 - y0));
    d.instance = raw.instance;
    return d;
  }

  // Keeps a pixel only when its id is a detection's and it lies in that box.
  static std::int64_t clear_outside_boxes(cv::Mat& mask, const std::vector<Detection>& detections) {
    std::vector<const cv::Rect*> box_of(65536, nullptr);
    for (const Detection& d : detections) box_of[d.instance] = &d.box;
    std::int64_t cleared = 0;
    for (int v = 0; v < mask.rows; ++v) {
      auto* row = mask.ptr<std::uint16_t>(v);
      for (int u = 0; u < mask.cols; ++u) {
        if (row[u] == 0) continue;
        const cv::Rect* box = box_of[row[u]];
        if (box == nullptr || !box->contains(cv::Point(u, v))) {
          row[u] = 0;
          ++cleared;
        }
      }
    }
    return cleared;
  }

  std::unique_ptr<PluginCalls> calls_;
  std::string name_;
  PluginLoadOptions options_;
  DetectorCapabilities capabilities_;
  DetectorHealth health_;
  std::vector<sp_detection> buffer_;
};

template <typename Fn>
bool resolve(void* lib, const char* symbol, Fn& out, std::vector<std::string>& missing) {
  dlerror();
  void* p = dlsym(lib, symbol);
  if (p == nullptr) {
    missing.emplace_back(symbol);
    return false;
  }
  out = reinterpret_cast<Fn>(p);
  return true;
}

class LoadedPlugin final : public CreatedPlugin {
 public:
  LoadedPlugin(LibraryPtr library, PluginApi api, sp_detector* handle)
      : library_(std::move(library)), api_(api), handle_(handle) {}
  ~LoadedPlugin() override { api_.destroy(handle_); }
  LoadedPlugin(const LoadedPlugin&) = delete;
  LoadedPlugin& operator=(const LoadedPlugin&) = delete;
  const PluginApi& api() const override { return api_; }
  sp_detector* handle() const override { return handle_; }

 private:
  LibraryPtr library_;  // declared first: closed last
  PluginApi api_;
  sp_detector* handle_;
};

class InProcessCalls final : public PluginCalls {
 public:
  explicit InProcessCalls(std::unique_ptr<CreatedPlugin> plugin) : plugin_(std::move(plugin)) {}
  std::uint32_t capabilities() const override { return plugin_->api().capabilities(plugin_->handle()); }
  int detect(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
             sp_detection* out, std::int32_t capacity, std::int32_t* count, std::string& error) override {
    std::array<char, kErrLen> err{};
    const int rc = plugin_->api().detect(plugin_->handle(), &left, &right, t_ns, seq, out, capacity, count,
                                         err.data(), err.size());
    error = error_text(err);
    return rc;
  }
  int segment(const sp_image& left, const sp_image& right, std::int64_t t_ns, std::int64_t seq,
              const sp_detection* detections, std::int32_t n_detections, std::uint16_t* mask,
              std::int32_t mask_stride_px, std::string& error) override {
    std::array<char, kErrLen> err{};
    const int rc = plugin_->api().segment(plugin_->handle(), &left, &right, t_ns, seq, detections,
                                          n_detections, mask, mask_stride_px, err.data(), err.size());
    error = error_text(err);
    return rc;
  }

 private:
  std::unique_ptr<CreatedPlugin> plugin_;
};

}  // namespace

Expected<std::unique_ptr<CreatedPlugin>> create_plugin(const std::string& path,
                                                       const std::string& config_yaml) {
  const std::string where = "detector plugin " + path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return make_error(ErrorCode::kNotFound, where + ": no such file");
  }
  dlerror();
  LibraryPtr lib(dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL));
  if (!lib) {
    const char* why = dlerror();
    return make_error(ErrorCode::kUnsupported, where + ": cannot be loaded as a shared library: " +
                                                   (why != nullptr ? why : "unknown dlopen error"));
  }
  PluginApi api;
  std::vector<std::string> missing;
  resolve(lib.get(), SP_SYMBOL_ABI_VERSION, api.abi_version, missing);
  resolve(lib.get(), SP_SYMBOL_CREATE, api.create, missing);
  resolve(lib.get(), SP_SYMBOL_CAPABILITIES, api.capabilities, missing);
  resolve(lib.get(), SP_SYMBOL_DETECT, api.detect, missing);
  resolve(lib.get(), SP_SYMBOL_SEGMENT, api.segment, missing);
  resolve(lib.get(), SP_SYMBOL_DESTROY, api.destroy, missing);
  if (!missing.empty()) {
    std::string list;
    for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
    return make_error(ErrorCode::kUnsupported,
                      where + ": not a sitepose detector plugin: missing symbol(s) " + list);
  }
  const std::uint32_t version = api.abi_version();
  if (version != SITEPOSE_DETECTOR_ABI_VERSION) {
    return make_error(ErrorCode::kUnsupported,
                      where + ": ABI version " + std::to_string(version) + ", this sitepose expects " +
                          std::to_string(SITEPOSE_DETECTOR_ABI_VERSION) + " (rebuild the plugin)");
  }
  std::array<char, kErrLen> err{};
  sp_detector* handle = api.create(config_yaml.c_str(), err.data(), err.size());
  if (handle == nullptr) {
    return make_error(ErrorCode::kInvalidArgument,
                      where + ": create failed: " + or_no_message(error_text(err)));
  }
  return std::unique_ptr<CreatedPlugin>(std::make_unique<LoadedPlugin>(std::move(lib), api, handle));
}

std::unique_ptr<PluginCalls> in_process_calls(std::unique_ptr<CreatedPlugin> plugin) {
  return std::make_unique<InProcessCalls>(std::move(plugin));
}

std::unique_ptr<Detector> make_plugin_detector(std::unique_ptr<PluginCalls> calls,
                                               PluginLoadOptions options) {
  return std::make_unique<PluginDetector>(std::move(calls), std::move(options));
}

Expected<std::unique_ptr<Detector>> load_detector_plugin(const std::string& path,
                                                         const std::string& config_yaml,
                                                         const PluginLoadOptions& options) {
  if (options.capacity < 1) {
    return make_error(ErrorCode::kInvalidArgument, "detector plugin " + path + ": capacity = " +
                                                       std::to_string(options.capacity) + ": must be >= 1");
  }
  SITEPOSE_TRY(auto plugin, create_plugin(path, config_yaml));
  PluginLoadOptions named = options;
  if (named.name.empty()) named.name = path;
  return make_plugin_detector(in_process_calls(std::move(plugin)), std::move(named));
}

}  // namespace sitepose::detect
