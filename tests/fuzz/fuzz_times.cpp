// A sequence's times.txt: accepted times lie in 0..kMaxTimeS and are at
// least 1 ns apart once stamped in integer nanoseconds.
#include <cmath>

#include "fuzz_check.hpp"
#include "fuzz_input.hpp"
#include "sitepose/io/trajectory.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace sitepose;
  const fuzz::InputFile file(data, size);
  auto times = io::read_times(file.path());
  if (!times) return 0;
  long long previous_ns = -1;
  for (const double t : *times) {
    fuzz::require(t >= 0.0 && t <= io::kMaxTimeS, "time in 0..kMaxTimeS");
    const long long t_ns = std::llround(t * 1e9);
    fuzz::require(t_ns > previous_ns, "strictly increasing in ns");
    previous_ns = t_ns;
  }
  return 0;
}
