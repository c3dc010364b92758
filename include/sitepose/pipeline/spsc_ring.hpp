#pragma once
// Bounded single-producer / single-consumer lock-free ring joining two
// pipeline stages (ARCHITECTURE.md: "a stage never blocks the one before it;
// when a ring is full the oldest frame is dropped and counted").
//
// Threads: exactly one producer thread calls try_push / push_drop_oldest;
// exactly one consumer thread calls try_pop / pop_wait. size(), drops(),
// capacity(), close() and closed() may be called from any thread.
// Ownership: elements are moved in and moved out; T only needs to be
// move-constructible (move-only types such as std::unique_ptr work). Elements
// still in the ring are destroyed with it.
//
// Slots carry sequence numbers (Vyukov's bounded queue): the slot of position
// p is free for p when seq == p and holds p when seq == p + 1; the consumer
// frees it for p + capacity. Positions are 64-bit: they never wrap.
//
// FullPolicy::kDropOldest - why a producer-side drop keeps SPSC correct. In a
// plain SPSC ring only the consumer advances the read index; if the producer
// advanced it to drop the oldest element while the consumer was moving that
// same element out, both would own it. Here the read index `tail_` is claimed
// by compare-and-swap from both sides, so each position has exactly one owner:
//  * the consumer claims position t (CAS t -> t+1), moves the element out and
//    frees the slot;
//  * a producer finding its slot still holding p - C (ring full) tries the
//    same CAS on p - C. Winning, it owns the oldest element: takes it out
//    (returned to the caller, counted in drops()) and reuses the slot at
//    once. Losing means the consumer is moving that element out right now:
//    the producer waits for that single move (brief spin, then
//    std::atomic::wait) - the only time a producer ever waits.
// FullPolicy::kReject rings have no push_drop_oldest, so the consumer owns
// `tail_` alone and pops without a CAS or fence (the faster hand-over for
// lossless streams, e.g. keyframes to the local mapper).
//
// Blocking: pop_wait() spins briefly, then sleeps on a futex-backed
// std::atomic::wait while the ring is empty. A push publishes with a seq_cst
// store and then reads the consumer's "sleeping" flag with a seq_cst load;
// the consumer raises the flag the same way before its last re-check
// (Dekker: either the consumer sees the element or the producer sees the
// flag), so no wake-up is lost; only the first push after the consumer fell
// asleep pays for a futex wake. No standalone fences: ThreadSanitizer models
// these orderings.

#include <atomic>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <optional>
#include <string_view>
#include <utility>

#include "sitepose/core/expected.hpp"

namespace sitepose::pipeline {

// Cache line of the x86-64 and aarch64 targets; the producer's and the
// consumer's hot words live on separate lines so they do not false-share.
inline constexpr std::size_t kCacheLineBytes = 64;
inline constexpr std::size_t kMaxRingCapacity = std::size_t{1} << 30;

// Checks a configured capacity: a power of two in [2, 2^30]. `key` names the
// config key in the error ("pipeline.capture_ring_capacity = 6: must be a
// power of two in [2, 1073741824]").
Status check_ring_capacity(std::string_view key, std::size_t capacity);

enum class FullPolicy {
  kReject,      // try_push fails when full (lossless streams)
  kDropOldest,  // push_drop_oldest evicts the oldest (frames, poses)
};

template <typename T, FullPolicy kPolicy = FullPolicy::kDropOldest>
class SpscRing {
 public:
  // `capacity` must pass check_ring_capacity (a programmer error otherwise:
  // config values are validated before a ring is built).
  explicit SpscRing(std::size_t capacity)
      : capacity_(capacity), mask_(capacity - 1), slots_(new Slot[capacity]) {
    SITEPOSE_CHECK(capacity >= 2 && capacity <= kMaxRingCapacity && std::has_single_bit(capacity));
    for (std::size_t i = 0; i < capacity; ++i) slots_[i].seq.store(i, std::memory_order_relaxed);
  }
  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;
  ~SpscRing() {
    const std::uint64_t head = head_.load(std::memory_order_relaxed);
    for (std::uint64_t t = tail_.load(std::memory_order_relaxed); t != head; ++t) {
      std::destroy_at(slot(t).ptr());
    }
  }

  // Producer. Moves `value` in and returns true, or returns false when the
  // ring is full and leaves `value` untouched.
  bool try_push(T&& value) {
    const std::uint64_t p = head_.load(std::memory_order_relaxed);
    Slot& s = slot(p);
    if (s.seq.load(std::memory_order_acquire) != p) return false;
    publish(s, p, std::move(value));
    return true;
  }

  // Producer. Always stores `value`; when the ring is full the oldest element
  // is removed first, counted in drops() and returned (so the caller can
  // recycle its buffers or log it). Returns nullopt when nothing was dropped,
  // including the rare case where the consumer took the oldest concurrently.
  std::optional<T> push_drop_oldest(T&& value) requires(kPolicy == FullPolicy::kDropOldest) {
    const std::uint64_t p = head_.load(std::memory_order_relaxed);
    Slot& s = slot(p);
    std::optional<T> dropped;
    if (s.seq.load(std::memory_order_acquire) != p) {  // full: slot holds p - C
      std::uint64_t oldest = p - capacity_;
      if (tail_.compare_exchange_strong(oldest, oldest + 1, std::memory_order_acq_rel,
                                        std::memory_order_acquire)) {
        dropped.emplace(std::move(*s.ptr()));
        std::destroy_at(s.ptr());
        drops_.store(drops_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      } else {
        wait_for_slot_release(s, p);
      }
    }
    publish(s, p, std::move(value));
    return dropped;
  }

  // Any thread. After close(), pop_wait() returns nullopt once the ring is
  // drained instead of sleeping; pushes still work (a stage drains on stop).
  void close() {
    closed_.store(true, std::memory_order_seq_cst);
    wake(consumer_wake_);
  }
  bool closed() const { return closed_.load(std::memory_order_acquire); }

  // Consumer. The oldest element, or nullopt when empty. Never blocks.
  std::optional<T> try_pop() {
    std::uint64_t t = tail_.load(std::memory_order_acquire);
    for (;;) {
      Slot& s = slot(t);
      if (s.seq.load(std::memory_order_acquire) != t + 1) {
        if constexpr (kPolicy == FullPolicy::kReject) return std::nullopt;
        // Either empty, or the producer dropped position t meanwhile.
        const std::uint64_t now = tail_.load(std::memory_order_acquire);
        if (now == t) return std::nullopt;
        t = now;
        continue;
      }
      if constexpr (kPolicy == FullPolicy::kReject) {
        tail_.store(t + 1, std::memory_order_relaxed);  // consumer-owned
        return take(s, t);
      } else {
        if (tail_.compare_exchange_weak(t, t + 1, std::memory_order_acq_rel,
                                        std::memory_order_acquire)) {
          std::optional<T> out = take(s, t);                   // seq_cst release of the slot ...
          wake_if_waiting(producer_waiting_, producer_wake_);  // ... then the flag
          return out;
        }
        // CAS failed: the producer dropped t; `t` now holds the new tail.
      }
    }
  }

  // Consumer. Blocks (no polling) until an element arrives; nullopt once the
  // ring is closed and empty.
  std::optional<T> pop_wait() {
    for (;;) {
      // Brief spin first: a consumer that keeps up would otherwise sleep
      // after nearly every element and cost the producer a futex wake each.
      for (int i = 0; i < kSpinsBeforeSleep; ++i) {
        if (auto v = try_pop()) return v;
        cpu_relax();
      }
      if (closed_.load(std::memory_order_acquire)) {
        return try_pop();  // an element pushed just before close()
      }
      const std::uint32_t ticket = consumer_wake_.load(std::memory_order_acquire);
      consumer_waiting_.store(true, std::memory_order_seq_cst);  // flag, then re-check
      if (nonempty_seq_cst()) {
        consumer_waiting_.store(false, std::memory_order_relaxed);
        continue;
      }
      if (!closed_.load(std::memory_order_acquire)) {
        consumer_wake_.wait(ticket, std::memory_order_acquire);
      }
      consumer_waiting_.store(false, std::memory_order_relaxed);
    }
  }

  std::size_t capacity() const { return capacity_; }
  // Elements dropped by push_drop_oldest since construction.
  std::uint64_t drops() const { return drops_.load(std::memory_order_relaxed); }
  // Approximate depth when read from a third thread (health export).
  std::size_t size() const {
    const std::uint64_t t = tail_.load(std::memory_order_acquire);
    const std::uint64_t h = head_.load(std::memory_order_acquire);
    return h > t ? static_cast<std::size_t>(h - t) : 0;
  }

 private:
  struct Slot {
    std::atomic<std::uint64_t> seq{0};
    alignas(T) unsigned char storage[sizeof(T)];
    T* ptr() { return std::launder(reinterpret_cast<T*>(storage)); }
  };

  static constexpr int kSpinsBeforeSleep = 256;  // a few microseconds

  Slot& slot(std::uint64_t position) { return slots_[position & mask_]; }

  void publish(Slot& s, std::uint64_t p, T&& value) {
    std::construct_at(reinterpret_cast<T*>(s.storage), std::move(value));
    // seq_cst store, then the seq_cst flag load in wake_if_waiting: pairs
    // with pop_wait's flag store + nonempty_seq_cst() (Dekker).
    s.seq.store(p + 1, std::memory_order_seq_cst);
    head_.store(p + 1, std::memory_order_release);
    wake_if_waiting(consumer_waiting_, consumer_wake_);
  }

  // Moves the element of claimed position t out and frees its slot (seq_cst
  // under kDropOldest: pairs with the waiting producer's flag, Dekker).
  std::optional<T> take(Slot& s, std::uint64_t t) {
    std::optional<T> out(std::move(*s.ptr()));
    std::destroy_at(s.ptr());
    s.seq.store(t + capacity_, kPolicy == FullPolicy::kDropOldest ? std::memory_order_seq_cst
                                                                  : std::memory_order_release);
    return out;
  }

  // The consumer's re-check after raising its flag.
  bool nonempty_seq_cst() {
    const std::uint64_t t = tail_.load(std::memory_order_seq_cst);
    return slot(t).seq.load(std::memory_order_seq_cst) == t + 1;
  }

  void wait_for_slot_release(Slot& s, std::uint64_t p) {
    for (int i = 0; i < kSpinsBeforeSleep; ++i) {  // the move is usually done by now
      if (s.seq.load(std::memory_order_acquire) == p) return;
      cpu_relax();
    }
    for (;;) {
      const std::uint32_t ticket = producer_wake_.load(std::memory_order_acquire);
      producer_waiting_.store(true, std::memory_order_seq_cst);  // flag, then re-check
      if (s.seq.load(std::memory_order_seq_cst) == p) break;
      producer_wake_.wait(ticket, std::memory_order_acquire);
    }
    producer_waiting_.store(false, std::memory_order_relaxed);
  }

  static void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__)
    asm volatile("yield");
#endif
  }

  // The waker clears the flag, so only the first push after the sleeper went
  // to sleep pays for a futex wake, not every push until it runs again.
  static void wake_if_waiting(std::atomic<bool>& waiting, std::atomic<std::uint32_t>& word) {
    if (waiting.load(std::memory_order_seq_cst) &&
        waiting.exchange(false, std::memory_order_acq_rel)) {
      wake(word);
    }
  }

  static void wake(std::atomic<std::uint32_t>& word) {
    word.fetch_add(1, std::memory_order_release);
    word.notify_one();
  }

  // Read-only after construction.
  const std::size_t capacity_;
  const std::size_t mask_;
  const std::unique_ptr<Slot[]> slots_;
  // Producer-written.
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> head_{0};
  std::atomic<std::uint64_t> drops_{0};
  // Consumer-written; also claimed by the producer's CAS under kDropOldest.
  alignas(kCacheLineBytes) std::atomic<std::uint64_t> tail_{0};
  // Consumer's sleep flag and futex word.
  alignas(kCacheLineBytes) std::atomic<bool> consumer_waiting_{false};
  std::atomic<std::uint32_t> consumer_wake_{0};
  // Producer's sleep flag (kDropOldest only, rare) and futex word; read by
  // the consumer on every pop, so kept off the busy head_ line.
  alignas(kCacheLineBytes) std::atomic<bool> producer_waiting_{false};
  std::atomic<std::uint32_t> producer_wake_{0};
  std::atomic<bool> closed_{false};
};

}  // namespace sitepose::pipeline
