#include "sitepose/pipeline/health.hpp"

#include <fmt/format.h>

namespace sitepose::pipeline {

std::uint64_t PipelineHealth::total_drops() const {
  std::uint64_t n = 0;
  for (const auto& s : stages) n += s.drops;
  return n;
}

std::string format_status(const PipelineHealth& h) {
  std::string drops;
  for (std::size_t i = 1; i < h.stages.size(); ++i) {  // capture has no ring before it
    if (i > 1) drops += '/';
    drops += std::to_string(h.stages[i].drops);
  }
  std::string text = fmt::format("{} {:.1f} fps, {} frames, drops {}, stalls {}, latency p50 {:.1f} ms p99 {:.1f} ms",
                                 to_string(h.state), h.fps, h.frames_tracked,
                                 drops.empty() ? "0" : drops, h.stalls, h.latency_p50_ms,
                                 h.latency_p99_ms);
  if (!h.outputs.empty()) {
    text += ", errors";
    for (const auto& o : h.outputs) text += fmt::format(" {} {}", o.name, o.errors);
  }
  if (h.state != TrackingState::kOk && !h.state_reason.empty()) {
    text += " (" + h.state_reason + ")";
  }
  return text;
}

}  // namespace sitepose::pipeline
