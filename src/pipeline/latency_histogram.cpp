#include "sitepose/pipeline/latency_histogram.hpp"

#include <algorithm>
#include <cmath>

namespace sitepose::pipeline {
namespace {

const double kLogGrowth = std::log(LatencyHistogram::kGrowth);

// Bucket 0 holds [0, first edge); bucket i >= 1 holds
// [first * g^(i-1), first * g^i); the last one also everything above.
int bucket_of(double ms) {
  if (!(ms >= LatencyHistogram::kFirstEdgeMs)) return 0;  // also NaN
  const double i = std::floor(std::log(ms / LatencyHistogram::kFirstEdgeMs) / kLogGrowth) + 1.0;
  return static_cast<int>(std::min<double>(i, LatencyHistogram::kBuckets - 1));
}

double bucket_middle_ms(int i) {
  if (i == 0) return LatencyHistogram::kFirstEdgeMs / 2;
  // Geometric middle of [first * g^(i-1), first * g^i).
  return LatencyHistogram::kFirstEdgeMs * std::pow(LatencyHistogram::kGrowth, i - 0.5);
}

}  // namespace

void LatencyHistogram::record_ms(double ms) {
  counts_[bucket_of(ms)].fetch_add(1, std::memory_order_relaxed);
}

std::uint64_t LatencyHistogram::count() const {
  std::uint64_t n = 0;
  for (const auto& c : counts_) n += c.load(std::memory_order_relaxed);
  return n;
}

double LatencyHistogram::percentile_ms(double q) const {
  std::array<std::uint64_t, kBuckets> snapshot;
  std::uint64_t n = 0;
  for (int i = 0; i < kBuckets; ++i) {
    snapshot[i] = counts_[i].load(std::memory_order_relaxed);
    n += snapshot[i];
  }
  if (n == 0) return 0.0;
  // Nearest rank: the smallest sample with at least q * n samples at or below it.
  const double clamped = std::clamp(q, 0.0, 1.0);
  const std::uint64_t rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(clamped * n)));
  std::uint64_t seen = 0;
  for (int i = 0; i < kBuckets; ++i) {
    seen += snapshot[i];
    if (seen >= rank) return bucket_middle_ms(i);
  }
  return bucket_middle_ms(kBuckets - 1);
}

}  // namespace sitepose::pipeline
