// sitepose's configuration YAML (run --config): an accepted file writes
// back (to_yaml) to text that reads again to the same text.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/config/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  auto config = config::load_config_from_string(fuzz::as_text(data, size), "fuzz.yaml");
  if (!config) return 0;
  const std::string written = config::to_yaml(*config);
  auto again = config::load_config_from_string(written, "written.yaml");
  fuzz::require(again.has_value(), "to_yaml output reads back");
  fuzz::require(config::to_yaml(*again) == written, "to_yaml round trip");
  return 0;
}
