#include "sitepose/drivers/aravis/clock_mapper.hpp"

#include <algorithm>

namespace sitepose::drivers::aravis {

std::int64_t ClockMapper::map(std::int64_t camera_t_ns, std::int64_t host_arrival_ns) {
  offsets_.push_back(host_arrival_ns - camera_t_ns);
  while (offsets_.size() > window_) offsets_.pop_front();
  return camera_t_ns + offset_ns();
}

std::int64_t ClockMapper::offset_ns() const {
  return offsets_.empty() ? 0 : *std::min_element(offsets_.begin(), offsets_.end());
}

}  // namespace sitepose::drivers::aravis
