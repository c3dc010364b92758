#include "sitepose/drivers/v4l2/timestamp_pairer.hpp"

namespace sitepose::drivers::v4l2 {

void TimestampPairer::drop_front(int side) {
  queues_[side].pop_front();
  ++(side == 0 ? counts_.unpaired_left : counts_.unpaired_right);
}

void TimestampPairer::push(Side side, RawFrame frame) {
  const int s = static_cast<int>(side);
  queues_[s].push_back(std::move(frame));
  while (queues_[s].size() > max_pending_) drop_front(s);
}

std::optional<std::pair<RawFrame, RawFrame>> TimestampPairer::pop() {
  auto& left = queues_[0];
  auto& right = queues_[1];
  while (!left.empty() && !right.empty()) {
    const std::int64_t dt = left.front().t_ns - right.front().t_ns;
    if (dt > tolerance_ns_) {
      drop_front(1);  // the right frame is older than any left frame still to come
    } else if (-dt > tolerance_ns_) {
      drop_front(0);
    } else {
      std::pair<RawFrame, RawFrame> pair{std::move(left.front()), std::move(right.front())};
      left.pop_front();
      right.pop_front();
      ++counts_.pairs;
      return pair;
    }
  }
  return std::nullopt;
}

void TimestampPairer::reset() {
  while (!queues_[0].empty()) drop_front(0);
  while (!queues_[1].empty()) drop_front(1);
}

}  // namespace sitepose::drivers::v4l2
