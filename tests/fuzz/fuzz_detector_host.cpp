// A message from sitepose-detector-host (or to it): siteposed decodes what
// a crashed or hostile host may send. A message that decodes encodes back
// to exactly the same bytes (one encoding per message), and a frame it
// names fits the size limits.
#include <algorithm>

#include "fuzz_check.hpp"
#include "sitepose/detector_host/protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  auto decoded = detector_host::decode(std::span(data, size));
  if (!decoded) return 0;
  const std::vector<std::uint8_t> again = detector_host::encode(*decoded);
  fuzz::require(again.size() == size && std::equal(again.begin(), again.end(), data),
                "re-encodes to the input");
  if (const auto* d = std::get_if<detector_host::DetectRequest>(&decoded->message)) {
    fuzz::require(detector_host::shm_bytes(d->frame) <=
                      4ull * detector_host::kMaxImageSide * detector_host::kMaxImageSide,
                  "frame within the limits");
  }
  return 0;
}
