// `sitepose bench ring`: throughput (items/s) of the pipeline's SPSC ring
// (both full policies) from a producer thread to a consumer thread, against a
// bounded mutex + std::deque + condition variable queue, and the ratios. Google
// Benchmark runs the timing; --benchmark_* flags are passed through.

#include <benchmark/benchmark.h>

#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "command_registry.hpp"
#include "interrupt.hpp"
#include "sitepose/pipeline/spsc_ring.hpp"

namespace sitepose::cli {
namespace {

// The baseline: what a stage hand-over looks like without the ring.
template <typename T>
class MutexQueue {
 public:
  explicit MutexQueue(std::size_t capacity) : capacity_(capacity) {}
  bool try_push(T&& value) {
    {
      std::lock_guard lock(mutex_);
      if (items_.size() >= capacity_) return false;
      items_.push_back(std::move(value));
    }
    not_empty_.notify_one();
    return true;
  }
  std::optional<T> pop_wait() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return !items_.empty() || closed_; });
    if (items_.empty()) return std::nullopt;
    std::optional<T> out(std::move(items_.front()));
    items_.pop_front();
    return out;
  }
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    not_empty_.notify_one();
  }

 private:
  const std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_empty_;
  std::deque<T> items_;
  bool closed_ = false;
};

constexpr char kRingName[] = "spsc_ring";                  // FullPolicy::kReject
constexpr char kRingDropName[] = "spsc_ring_drop_policy";  // kDropOldest ring, used losslessly
constexpr char kMutexName[] = "mutex_deque";

// Lossless transfer of `items` integers: the producer yields while the queue
// is full, the consumer blocks while it is empty (the same policy for both).
template <typename Queue>
void transfer(benchmark::State& state, std::size_t capacity, std::uint64_t items) {
  for (auto _ : state) {
    if (interrupted()) {  // Ctrl-C: this and the benchmarks after it report the error
      state.SkipWithError("interrupted");
      break;
    }
    Queue queue(capacity);
    std::uint64_t sum = 0;
    std::thread consumer([&] {
      while (auto v = queue.pop_wait()) sum += *v;
    });
    for (std::uint64_t i = 0; i < items; ++i) {
      std::uint64_t v = i;
      while (!queue.try_push(std::move(v))) std::this_thread::yield();
    }
    queue.close();
    consumer.join();
    if (sum != items * (items - 1) / 2) {
      state.SkipWithError("lost or duplicated items");
      break;
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * items));
}

// transfer<Queue> as a Google Benchmark named `name` (wall-clock time, ms).
template <typename Queue>
void register_transfer(const char* name, std::size_t capacity, std::uint64_t items) {
  benchmark::RegisterBenchmark(name, [=](benchmark::State& s) { transfer<Queue>(s, capacity, items); })
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond);
}

// Console output as usual, plus items/s per benchmark for the ratio.
class RateReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      const auto it = run.counters.find("items_per_second");
      if (run.error_occurred || it == run.counters.end()) continue;
      const std::string& name = run.run_name.function_name;
      // Prefer the mean over repetitions; otherwise the (last) plain run.
      if (run.run_type == Run::RT_Aggregate && run.aggregate_name != "mean") continue;
      if (run.run_type == Run::RT_Aggregate || !has_mean_[name]) {
        rate_[name] = it->second.value;
        has_mean_[name] = run.run_type == Run::RT_Aggregate;
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  std::optional<double> rate(const std::string& name) const {
    const auto it = rate_.find(name);
    return it == rate_.end() ? std::nullopt : std::optional<double>(it->second);
  }

 private:
  std::map<std::string, double> rate_;
  std::map<std::string, bool> has_mean_;
};

int run_bench_ring(std::size_t capacity, std::uint64_t items,
                   const std::vector<std::string>& extras) {
  install_interrupt_handlers();
  if (auto st = pipeline::check_ring_capacity("--capacity", capacity); !st) {
    return fail("bench ring", st.error().message, 2);
  }
  if (items < 1) return fail("bench ring", "--items = 0: must be >= 1", 2);
  std::vector<std::string> args{"sitepose bench ring"};
  for (const auto& e : extras) {
    if (e.rfind("--benchmark_", 0) != 0) {
      return fail("bench ring",
                  "unknown argument '" + e + "' (only --benchmark_*=VALUE flags pass through)", 2);
    }
    args.push_back(e);
  }
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  int argc = static_cast<int>(argv.size());
  benchmark::Initialize(&argc, argv.data());
  if (benchmark::ReportUnrecognizedArguments(argc, argv.data())) return 2;

  register_transfer<pipeline::SpscRing<std::uint64_t, pipeline::FullPolicy::kReject>>(kRingName, capacity, items);
  register_transfer<pipeline::SpscRing<std::uint64_t, pipeline::FullPolicy::kDropOldest>>(kRingDropName, capacity,
                                                                                         items);
  register_transfer<MutexQueue<std::uint64_t>>(kMutexName, capacity, items);

  std::printf(
      "producer -> consumer on two threads, %llu uint64 items per iteration, capacity %zu\n",
      static_cast<unsigned long long>(items), capacity);
  std::fflush(stdout);
  RateReporter reporter;
  const std::size_t ran = benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  if (ran == 0) return fail("bench ring", "no benchmark matched --benchmark_filter", 2);
  for (const auto& e : extras) {
    if (e == "--benchmark_list_tests" || e == "--benchmark_list_tests=true")
      return 0;  // nothing ran
  }
  const auto mutex = reporter.rate(kMutexName);
  for (const char* name : {kRingName, kRingDropName, kMutexName}) {
    if (const auto r = reporter.rate(name)) std::printf("%s: %.3g items/s\n", name, *r);
  }
  for (const char* name : {kRingName, kRingDropName}) {
    const auto ring = reporter.rate(name);
    if (ring && mutex && *mutex > 0) {
      std::printf("ratio %s / %s: %.2f\n", name, kMutexName, *ring / *mutex);
    } else {
      std::printf("ratio %s / %s: not measured (both must run without error)\n", name, kMutexName);
    }
  }
  return interrupted() ? report_interrupted("bench ring", "printed the rates measured before it") : 0;
}

const CommandRegistrar kBenchRing{
    {"bench", "ring",
     "Throughput (items/s) of the SPSC ring (both full policies) vs a mutex+deque queue between "
     "two "
     "threads, and the ratios",
     [](CLI::App& sub) -> CommandAction {
       auto capacity = std::make_shared<std::size_t>(1024);
       auto items = std::make_shared<std::uint64_t>(1u << 20);
       sub.add_option("--capacity", *capacity, "queue capacity (a power of two)")
           ->capture_default_str();
       sub.add_option("--items", *items, "items transferred per benchmark iteration")
           ->capture_default_str();
       sub.allow_extras();
       sub.footer(
           "Google Benchmark flags pass through as --benchmark_NAME=VALUE, e.g. "
           "--benchmark_repetitions=3 --benchmark_min_time=2.");
       return
           [&sub, capacity, items] { return run_bench_ring(*capacity, *items, sub.remaining()); };
     }}};

}  // namespace
}  // namespace sitepose::cli
