// What a detector plugin hands back across the C ABI (plugin_abi.h): the
// test plugin fuzz_plugin.c returns the fuzzer's bytes as its capabilities,
// return code, count, detections and mask; the host's checked copies must
// keep what detector.hpp promises.
#include <dlfcn.h>

#include <set>

#include <opencv2/core.hpp>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/detect/plugin_abi.h"
#include "sitepose/detect/plugin_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  // Loaded once for good: under libFuzzer the plugin registers its coverage
  // counters when loaded, and the loader's dlclose() after each input would
  // unmap them under the fuzzer's feet (a SEGV in libFuzzer's own loop).
  static void* const keep_loaded = dlopen(SITEPOSE_FUZZ_PLUGIN, RTLD_NOW | RTLD_NODELETE);
  (void)keep_loaded;
  static const char* kHex = "0123456789abcdef";
  std::string config = "hex: ";
  for (std::size_t i = 0; i < size; ++i) {
    config += kHex[data[i] >> 4];
    config += kHex[data[i] & 15];
  }
  detect::PluginLoadOptions options;
  options.capacity = 8;
  auto detector = detect::load_detector_plugin(SITEPOSE_FUZZ_PLUGIN, config, options);
  if (!detector) return 0;
  StereoFrame frame;
  frame.left = cv::Mat(24, 32, CV_8UC1, cv::Scalar(128));
  frame.right = frame.left.clone();
  auto detections = (*detector)->detect(frame);
  if (!detections) return 0;
  const cv::Rect image(0, 0, frame.left.cols, frame.left.rows);
  std::set<std::uint16_t> instances;
  for (const auto& d : *detections) {
    fuzz::require(d.score >= 0.0 && d.score <= 1.0, "score in 0..1");
    fuzz::require(d.instance > 0 && instances.insert(d.instance).second, "unique instance > 0");
    fuzz::require(!d.box.empty() && (d.box & image) == d.box, "box inside the image");
    fuzz::require(!d.class_name.empty() && d.class_name.size() < SP_CLASS_NAME_LEN, "class name");
  }
  if (!(*detector)->capabilities().has_segmentation) return 0;
  auto mask = (*detector)->segment(frame, *detections);
  if (!mask) return 0;
  fuzz::require(mask->size() == frame.left.size() && mask->type() == CV_16UC1, "mask size and type");
  for (int v = 0; v < mask->rows; ++v) {
    for (int u = 0; u < mask->cols; ++u) {
      const std::uint16_t id = mask->at<std::uint16_t>(v, u);
      if (id == 0) continue;
      bool inside = false;
      for (const auto& d : *detections) inside |= d.instance == id && d.box.contains(cv::Point(u, v));
      fuzz::require(inside, "mask pixel inside its detection's box");
    }
  }
  return 0;
}
