// A gnss_fix_t LCM message as it arrives on the GNSS channel: decoded and
// checked like LcmGnssSubscriber does; an accepted fix encodes and decodes
// back to the same fix.
#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/output/lcm_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  auto message = output::decode_lcm<sitepose::gnss_fix_t>(data, size);
  if (!message) return 0;
  auto fix = output::from_lcm_gnss_fix(*message);
  if (!fix) return 0;
  auto bytes = output::encode_lcm(output::to_lcm_gnss_fix(*fix));
  fuzz::require(bytes.has_value(), "an accepted fix encodes");
  auto again = output::decode_lcm<sitepose::gnss_fix_t>(bytes->data(), bytes->size());
  fuzz::require(again.has_value() && output::from_lcm_gnss_fix(*again).has_value(), "encoded fix decodes");
  fuzz::require(output::from_lcm_gnss_fix(*again)->t_ns == fix->t_ns, "time round trip");
  return 0;
}
