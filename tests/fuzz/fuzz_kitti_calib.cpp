// A sequence's calib.txt (KITTI P0/P1 lines): an accepted file holds
// positive finite focal lengths and baseline and a finite principal point
// (the image size, and with it the plausibility check, comes from the
// images).
#include <cmath>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/io/kitti_calib.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  const fuzz::InputFile file(data, size);
  auto camera = io::read_kitti_calib(file.path());
  if (!camera) return 0;
  const StereoCamera& c = *camera;
  fuzz::require(std::isfinite(c.fx) && std::isfinite(c.fy) && c.fx > 0 && c.fy > 0, "focal lengths > 0");
  fuzz::require(std::isfinite(c.cx) && std::isfinite(c.cy), "finite principal point");
  fuzz::require(std::isfinite(c.baseline_m) && c.baseline_m > 0, "baseline > 0");
  return 0;
}
