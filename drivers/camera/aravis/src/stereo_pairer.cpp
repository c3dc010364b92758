#include "sitepose/drivers/aravis/stereo_pairer.hpp"

namespace sitepose::drivers::aravis {

void StereoPairer::push(Side side, CameraFrame frame) {
  queue(side).push_back(std::move(frame));
  while (queue(side).size() > options_.max_pending) drop_front(side);
}

void StereoPairer::drop_front(Side side) {
  queue(side).pop_front();
  if (!paired_once_) {
    ++counts_.skipped_at_start;  // the other camera has not started yet
  } else {
    ++(side == Side::kLeft ? counts_.unpaired_left : counts_.unpaired_right);
  }
}

std::optional<FramePair> StereoPairer::pop() {
  auto& left = queue(Side::kLeft);
  auto& right = queue(Side::kRight);
  while (!left.empty() && !right.empty()) {
    const std::int64_t dt = key(left.front()) - key(right.front());
    if (dt > options_.tolerance_ns) {
      drop_front(Side::kRight);  // the right frame is older than any left one to come
    } else if (dt < -options_.tolerance_ns) {
      drop_front(Side::kLeft);
    } else {
      FramePair pair{std::move(left.front()), std::move(right.front())};
      left.pop_front();
      right.pop_front();
      ++counts_.pairs;
      paired_once_ = true;
      return pair;
    }
  }
  return std::nullopt;
}

void StereoPairer::reset() {
  while (!queue(Side::kLeft).empty()) drop_front(Side::kLeft);
  while (!queue(Side::kRight).empty()) drop_front(Side::kRight);
  paired_once_ = false;
}

}  // namespace sitepose::drivers::aravis
