// An ORB-SLAM2 stereo settings file (--orbslam2-settings, OpenCV YAML): an
// accepted file holds a valid camera.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/config/orbslam2_settings.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  auto settings =
      config::load_orbslam2_settings_from_string(std::string(fuzz::as_text(data, size)), "fuzz.yaml");
  if (!settings) return 0;
  fuzz::require(settings->camera.validate().has_value(), "valid camera");
  config::SiteposeConfig config;
  config::apply_orbslam2_settings(*settings, config);
  return 0;
}
