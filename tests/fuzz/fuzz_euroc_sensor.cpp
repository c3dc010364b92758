// An EuRoC camera sensor.yaml: an accepted file holds a finite pose and
// positive intrinsics.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/io/euroc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  const fuzz::InputFile file(data, size);
  auto cam0 = io::read_euroc_sensor_yaml(file.path());
  if (!cam0) return 0;
  fuzz::require_pose(cam0->T_body_cam);
  fuzz::require(cam0->fu > 0 && cam0->fv > 0 && cam0->width > 0 && cam0->height > 0, "positive intrinsics");
  return 0;
}
