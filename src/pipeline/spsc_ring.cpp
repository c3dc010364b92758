#include "sitepose/pipeline/spsc_ring.hpp"

#include <string>

namespace sitepose::pipeline {

Status check_ring_capacity(std::string_view key, std::size_t capacity) {
  if (capacity >= 2 && capacity <= kMaxRingCapacity && std::has_single_bit(capacity)) {
    return ok_status();
  }
  return make_error(ErrorCode::kInvalidArgument, std::string(key) + " = " +
                                                     std::to_string(capacity) +
                                                     ": must be a power of two in [2, " +
                                                     std::to_string(kMaxRingCapacity) + "]");
}

}  // namespace sitepose::pipeline
