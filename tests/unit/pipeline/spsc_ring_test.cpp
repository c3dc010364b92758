#include "sitepose/pipeline/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <thread>
#include <vector>

namespace sitepose::pipeline {
namespace {

constexpr std::uint64_t kMovedFrom = ~std::uint64_t{0};

// Busy-work per move in the current thread: a consumer with slow moves
// spends most of its time between claiming an element and freeing its slot,
// so preemption and the producer's concurrent drop land in that window.
thread_local int t_move_spins = 0;
thread_local volatile int spin_sink = 0;

// Move-only element that marks its moved-from husk, so a double hand-out or a
// read of a moved-from slot shows up as a wrong id.
struct MoveOnlyId {
  explicit MoveOnlyId(std::uint64_t v) : id(v) {}
  MoveOnlyId(const MoveOnlyId&) = delete;
  MoveOnlyId& operator=(const MoveOnlyId&) = delete;
  MoveOnlyId(MoveOnlyId&& o) noexcept : id(o.id) {
    for (int k = 0; k < t_move_spins; ++k) spin_sink = spin_sink + 1;
    o.id = kMovedFrom;
  }
  MoveOnlyId& operator=(MoveOnlyId&& o) noexcept {
    id = o.id;
    o.id = kMovedFrom;
    return *this;
  }
  std::uint64_t id;
};

// Counts live instances to check the ring destroys exactly what it holds.
struct Counted {
  static inline int live = 0;
  explicit Counted(int v) : value(v) { ++live; }
  Counted(Counted&& o) noexcept : value(o.value) { ++live; }
  Counted(const Counted&) = delete;
  ~Counted() { --live; }
  int value;
};

template <typename R>
concept CanDropOldest = requires(R& r, int v) {
  r.push_drop_oldest(std::move(v));
};
static_assert(CanDropOldest<SpscRing<int>>);
static_assert(!CanDropOldest<SpscRing<int, FullPolicy::kReject>>);

TEST(SpscRing, CheckCapacityNamesKeyAndRule) {
  EXPECT_TRUE(check_ring_capacity("k", 2).has_value());
  EXPECT_TRUE(check_ring_capacity("k", 1024).has_value());
  EXPECT_TRUE(check_ring_capacity("k", kMaxRingCapacity).has_value());
  for (std::size_t bad : {std::size_t{0}, std::size_t{1}, std::size_t{6}, kMaxRingCapacity * 2}) {
    const Status st = check_ring_capacity("pipeline.ring_capacity", bad);
    ASSERT_FALSE(st.has_value()) << bad;
    EXPECT_EQ(st.error().code, ErrorCode::kInvalidArgument);
    EXPECT_NE(st.error().message.find("pipeline.ring_capacity = " + std::to_string(bad)),
              std::string::npos)
        << st.error().message;
    EXPECT_NE(st.error().message.find("power of two"), std::string::npos);
  }
}

template <typename Ring>
void check_fifo_full_empty() {
  Ring ring(4);
  EXPECT_EQ(ring.capacity(), 4u);
  EXPECT_FALSE(ring.try_pop().has_value());
  for (int lap = 0; lap < 3; ++lap) {  // several laps exercise the sequence numbers
    for (int i = 0; i < 4; ++i) {
      int v = 10 * lap + i;
      EXPECT_TRUE(ring.try_push(std::move(v)));
      EXPECT_EQ(ring.size(), static_cast<std::size_t>(i + 1));
    }
    int extra = 99;
    EXPECT_FALSE(ring.try_push(std::move(extra)));
    for (int i = 0; i < 4; ++i) {
      const auto v = ring.try_pop();
      ASSERT_TRUE(v.has_value());
      EXPECT_EQ(*v, 10 * lap + i);
    }
    EXPECT_FALSE(ring.try_pop().has_value());
    EXPECT_EQ(ring.size(), 0u);
  }
  EXPECT_EQ(ring.drops(), 0u);
}

TEST(SpscRing, FifoAndFullAndEmptySingleThread) {
  check_fifo_full_empty<SpscRing<int, FullPolicy::kReject>>();
  check_fifo_full_empty<SpscRing<int, FullPolicy::kDropOldest>>();
}

TEST(SpscRing, FailedTryPushLeavesValueWithCaller) {
  SpscRing<std::unique_ptr<int>, FullPolicy::kReject> ring(2);
  EXPECT_TRUE(ring.try_push(std::make_unique<int>(1)));
  EXPECT_TRUE(ring.try_push(std::make_unique<int>(2)));
  auto keep = std::make_unique<int>(3);
  EXPECT_FALSE(ring.try_push(std::move(keep)));
  ASSERT_NE(keep, nullptr);
  EXPECT_EQ(*keep, 3);
}

TEST(SpscRing, DropOldestReturnsAndCountsTheOldest) {
  SpscRing<std::unique_ptr<int>> ring(4);
  for (int i = 0; i < 4; ++i)
    EXPECT_FALSE(ring.push_drop_oldest(std::make_unique<int>(i)).has_value());
  for (int i = 4; i < 10; ++i) {
    auto dropped = ring.push_drop_oldest(std::make_unique<int>(i));
    ASSERT_TRUE(dropped.has_value());
    ASSERT_NE(*dropped, nullptr);
    EXPECT_EQ(**dropped, i - 4);
    EXPECT_EQ(ring.size(), 4u);
  }
  EXPECT_EQ(ring.drops(), 6u);
  for (int i = 6; i < 10; ++i) {  // the newest four survive, in order
    auto v = ring.try_pop();
    ASSERT_TRUE(v.has_value());
    EXPECT_EQ(**v, i);
  }
  EXPECT_FALSE(ring.try_pop().has_value());
  // Not full: no drop.
  EXPECT_FALSE(ring.push_drop_oldest(std::make_unique<int>(42)).has_value());
  EXPECT_EQ(ring.drops(), 6u);
}

TEST(SpscRing, DestroysExactlyTheElementsItHolds) {
  Counted::live = 0;
  {
    SpscRing<Counted> ring(8);
    for (int i = 0; i < 5; ++i) EXPECT_TRUE(ring.try_push(Counted(i)));
    EXPECT_EQ(Counted::live, 5);
    { auto v = ring.try_pop(); }
    EXPECT_EQ(Counted::live, 4);
    for (int i = 0; i < 10; ++i) ring.push_drop_oldest(Counted(100 + i));
    EXPECT_EQ(Counted::live, 8);
  }
  EXPECT_EQ(Counted::live, 0);
}

TEST(SpscRing, PopWaitWakesOnPushAndEndsOnClose) {
  SpscRing<int, FullPolicy::kReject> ring(2);
  std::vector<int> got;
  std::thread consumer([&] {
    while (auto v = ring.pop_wait()) got.push_back(*v);
  });
  for (int i = 0; i < 1000; ++i) {
    int v = i;
    while (!ring.try_push(std::move(v))) std::this_thread::yield();
  }
  ring.close();
  consumer.join();
  ASSERT_EQ(got.size(), 1000u);
  for (int i = 0; i < 1000; ++i) EXPECT_EQ(got[i], i);
  EXPECT_TRUE(ring.closed());
}

TEST(SpscRing, PopWaitReturnsElementsPushedBeforeClose) {
  SpscRing<int> ring(4);
  EXPECT_TRUE(ring.try_push(7));
  ring.close();
  auto v = ring.pop_wait();
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(*v, 7);
  EXPECT_FALSE(ring.pop_wait().has_value());
}

// ~10 million items; ThreadSanitizer slows every atomic ~20x, so its runs
// (which look for races, not for rare interleavings by volume) use 1 million.
#if defined(__SANITIZE_THREAD__)
constexpr std::uint64_t kStressItems = 1'000'000;
#else
constexpr std::uint64_t kStressItems = 10'000'000;
#endif

// Lossless: every item arrives exactly once and in order.
template <FullPolicy kPolicy>
void run_lossless_stress() {
  SpscRing<MoveOnlyId, kPolicy> ring(1024);
  std::uint64_t received = 0;
  std::uint64_t out_of_order = 0;
  std::thread consumer([&] {
    while (auto v = ring.pop_wait()) {
      if (v->id != received) ++out_of_order;
      ++received;
    }
  });
  for (std::uint64_t i = 0; i < kStressItems; ++i) {
    MoveOnlyId item(i);
    while (!ring.try_push(std::move(item))) std::this_thread::yield();
  }
  ring.close();
  consumer.join();
  EXPECT_EQ(received, kStressItems);
  EXPECT_EQ(out_of_order, 0u);
  EXPECT_EQ(ring.drops(), 0u);
}

TEST(SpscRingStress, TwoThreadsInOrderNoLossRejectPolicy) {
  run_lossless_stress<FullPolicy::kReject>();
}

TEST(SpscRingStress, TwoThreadsInOrderNoLossDropOldestRingUsedLosslessly) {
  run_lossless_stress<FullPolicy::kDropOldest>();
}

// Dropping: every id is either delivered or handed back as dropped, never
// both, never neither; both streams are in order and drops() counts exactly
// the dropped ones. A small ring and a consumer slower than the producer
// (its time spent inside the move out of a claimed slot) make drops and
// concurrent claims of the oldest element frequent.
void run_drop_stress(std::size_t capacity, int producer_work, int consumer_move_spins,
                     bool producer_yields) {
  SpscRing<MoveOnlyId> ring(capacity);
  std::vector<bool> delivered(kStressItems, false);
  std::vector<bool> dropped(kStressItems, false);
  std::uint64_t bad_consumer = 0;
  std::thread consumer([&] {
    std::uint64_t last = 0;
    bool first = true;
    t_move_spins = consumer_move_spins;
    while (auto v = ring.pop_wait()) {
      const std::uint64_t id = v->id;
      if (id >= kStressItems || (!first && id <= last)) {
        ++bad_consumer;
      } else {
        delivered[id] = true;
      }
      first = false;
      last = id;
    }
  });
  std::uint64_t n_dropped = 0;
  std::uint64_t bad_producer = 0;
  std::uint64_t last_dropped = 0;
  volatile int producer_sink = 0;
  for (std::uint64_t i = 0; i < kStressItems; ++i) {
    for (int k = 0; k < producer_work; ++k) producer_sink = producer_sink + k;
    // On a loaded machine the two threads may share one core: yielding now
    // and then lets the consumer interleave instead of draining once a slice.
    if (producer_yields && (i & 255) == 0) std::this_thread::yield();
    if (auto d = ring.push_drop_oldest(MoveOnlyId(i))) {
      if (d->id >= kStressItems || (n_dropped > 0 && d->id <= last_dropped)) {
        ++bad_producer;
      } else {
        dropped[d->id] = true;
      }
      last_dropped = d->id;
      ++n_dropped;
    }
  }
  ring.close();
  consumer.join();
  EXPECT_EQ(bad_consumer, 0u);
  EXPECT_EQ(bad_producer, 0u);
  EXPECT_EQ(ring.drops(), n_dropped);
  EXPECT_GT(n_dropped, 0u) << "the test did not exercise dropping";
  std::printf("capacity %zu: %llu delivered, %llu dropped\n", capacity,
              static_cast<unsigned long long>(kStressItems - n_dropped),
              static_cast<unsigned long long>(n_dropped));
  std::uint64_t both = 0;
  std::uint64_t neither = 0;
  for (std::uint64_t i = 0; i < kStressItems; ++i) {
    both += delivered[i] && dropped[i];
    neither += !delivered[i] && !dropped[i];
  }
  EXPECT_EQ(both, 0u);
  EXPECT_EQ(neither, 0u);
}

TEST(SpscRingStress, TwoThreadsDropOldestExactAccountingSmallRing) {
  run_drop_stress(4, 20, 30, true);
}

TEST(SpscRingStress, TwoThreadsDropOldestExactAccountingSlowConsumer) {
  run_drop_stress(64, 0, 50, true);
}

// A consumer that is nearly always mid-move and a producer that never
// yields: whenever the consumer is preempted (or merely slow on its own core)
// the producer laps the ring and finds the oldest slot claimed - it must wait
// for that move instead of taking the element too.
TEST(SpscRingStress, TwoThreadsDropOldestProducerMeetsConsumerMidMove) {
  run_drop_stress(1024, 0, 2000, false);
}

}  // namespace
}  // namespace sitepose::pipeline
