#pragma once
// One ring between two stages (SpscRing, spsc_ring.hpp) with the overflow
// policy the source asks for (FrameSource::live()):
//   kDropOldest - the producer never waits; a full ring drops its oldest
//                 packet, counted (live sources: the newest pose matters most);
//   kBlock      - the producer waits for room (a counting semaphore of free
//                 slots, so the ring never overflows): lossless, for
//                 recordings replayed as fast as possible.
// Threads: push() and wake_producer() from the producer stage / the
// stopping thread, pop() from the consumer stage; close() from any thread
// (the producer at its end of stream); depth()/drops() from any thread.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <semaphore>
#include <utility>

#include "sitepose/pipeline/spsc_ring.hpp"

namespace sitepose::pipeline {

enum class OverflowPolicy { kDropOldest, kBlock };

template <typename T>
class Link {
 public:
  Link(std::size_t capacity, OverflowPolicy policy)
      : ring_(capacity), policy_(policy), free_slots_(static_cast<std::ptrdiff_t>(capacity)) {}

  // Producer. Always stores `item`. kBlock waits for a free slot first; a
  // wake_producer() (stop) lets it through at once, and the ring then drops
  // its oldest packet if full (counted): the stages are stopping anyway.
  void push(T&& item) {
    if (policy_ == OverflowPolicy::kBlock) free_slots_.acquire();
    (void)ring_.push_drop_oldest(std::move(item));
  }

  // Consumer. Blocks until a packet arrives; nullopt once closed and drained.
  std::optional<T> pop() {
    std::optional<T> item = ring_.pop_wait();
    if (item && policy_ == OverflowPolicy::kBlock) free_slots_.release();
    return item;
  }

  // Consumer. Discards what is queued (a stop), returning how many.
  std::uint64_t discard() {
    std::uint64_t n = 0;
    while (ring_.try_pop()) {
      if (policy_ == OverflowPolicy::kBlock) free_slots_.release();
      ++n;
    }
    return n;
  }

  void close() { ring_.close(); }
  // Releases a producer blocked in push() (kBlock); harmless otherwise.
  void wake_producer() {
    if (policy_ == OverflowPolicy::kBlock) free_slots_.release();
  }

  std::uint64_t depth() const { return ring_.size(); }
  std::uint64_t drops() const { return ring_.drops(); }
  OverflowPolicy policy() const { return policy_; }

 private:
  SpscRing<T> ring_;
  OverflowPolicy policy_;
  std::counting_semaphore<> free_slots_;
};

}  // namespace sitepose::pipeline
