// siteposed's settings YAML (--config): an accepted file writes back
// (to_yaml, what --check-config prints) to text that reads again.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/daemon/daemon_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  const std::string text(fuzz::as_text(data, size));
  auto config = daemon::load_daemon_config_from_string(text, "fuzz.yaml", "/nonexistent-fuzz-base");
  if (!config) return 0;
  const std::string written = daemon::to_yaml(*config);
  auto again = daemon::load_daemon_config_from_string(written, "written.yaml", "/nonexistent-fuzz-base");
  fuzz::require(again.has_value(), "to_yaml output reads back");
  fuzz::require(daemon::to_yaml(*again) == written, "to_yaml round trip");
  return 0;
}
