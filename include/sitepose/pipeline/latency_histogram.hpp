#pragma once
// Lock-free histogram of durations for health export: one stage thread
// records, any thread reads percentiles. Buckets grow geometrically by 7 %
// from 10 us, so a percentile is exact to within about 4 % up to minutes.
// Memory order: relaxed counters; a reader may see a sample in flight
// missing, which a health snapshot tolerates.

#include <array>
#include <atomic>
#include <cstdint>

namespace sitepose::pipeline {

class LatencyHistogram {
 public:
  // Any thread. Negative durations count as 0.
  void record_ms(double ms);
  // q in [0, 1]: the geometric middle of the bucket holding the q-quantile
  // (nearest rank); 0 when empty.
  double percentile_ms(double q) const;
  std::uint64_t count() const;

  static constexpr int kBuckets = 256;
  static constexpr double kFirstEdgeMs = 0.01;
  static constexpr double kGrowth = 1.07;

 private:
  std::array<std::atomic<std::uint64_t>, kBuckets> counts_{};
};

}  // namespace sitepose::pipeline
