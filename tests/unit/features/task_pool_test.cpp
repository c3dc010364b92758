#include "sitepose/features/task_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace sitepose::features {
namespace {

TEST(TaskPool, RunsEveryJobOnceWithAnyNumberOfWorkers) {
  for (const int workers : {0, 1, 3}) {
    TaskPool pool(workers);
    EXPECT_EQ(pool.n_workers(), workers);
    for (const int n : {0, 1, 2, 37}) {
      std::vector<std::atomic<int>> calls(static_cast<std::size_t>(n));
      pool.run(n, [&](int i) { ++calls[static_cast<std::size_t>(i)]; });
      for (int i = 0; i < n; ++i)
        EXPECT_EQ(calls[static_cast<std::size_t>(i)].load(), 1) << workers << " " << i;
    }
  }
}

TEST(TaskPool, WithoutWorkersRunsInOrderOnTheCaller) {
  TaskPool pool(0);
  std::vector<int> order;
  const auto caller = std::this_thread::get_id();
  pool.run(5, [&](int i) {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    order.push_back(i);
  });
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4}));
}

TEST(TaskPool, UsesTheWorkersAndTheCaller) {
  TaskPool pool(1);
  // Two jobs that each wait for the other to start: they can only finish
  // when two threads run them at the same time.
  std::atomic<int> started{0};
  std::set<std::thread::id> threads;
  std::mutex threads_mutex;
  pool.run(2, [&](int) {
    ++started;
    while (started.load() < 2) std::this_thread::yield();
    const std::lock_guard lock(threads_mutex);
    threads.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(threads.size(), 2u);
  EXPECT_EQ(threads.count(std::this_thread::get_id()), 1u);
}

TEST(TaskPool, NestedRunsFinish) {
  TaskPool pool(2);
  std::atomic<int> inner{0};
  pool.run(4, [&](int) { pool.run(8, [&](int) { ++inner; }); });
  EXPECT_EQ(inner.load(), 32);
}

TEST(TaskPool, ConcurrentCallersEachGetTheirOwnJobs) {
  TaskPool pool(1);
  std::vector<int> sums(4, 0);
  std::vector<std::thread> callers;
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&, c] {
      std::vector<int> values(50, 0);
      for (int round = 0; round < 20; ++round) pool.run(50, [&](int i) { values[i] += i; });
      for (const int v : values) sums[c] += v;
    });
  }
  for (std::thread& t : callers) t.join();
  for (const int sum : sums) EXPECT_EQ(sum, 20 * (49 * 50 / 2));
}

TEST(TaskPool, RethrowsAJobsExceptionAfterTheOthersFinished) {
  for (const int workers : {0, 2}) {
    TaskPool pool(workers);
    std::atomic<int> finished{0};
    EXPECT_THROW(pool.run(6,
                          [&](int i) {
                            if (i == 2) throw std::runtime_error("job 2");
                            ++finished;
                          }),
                 std::runtime_error);
    EXPECT_EQ(finished.load(), 5) << workers;
    // The pool still works afterwards.
    std::atomic<int> again{0};
    pool.run(3, [&](int) { ++again; });
    EXPECT_EQ(again.load(), 3);
  }
}

// run_beside: own() stays on the caller while a worker already runs the
// jobs (own waits for a job to start: it cannot finish unless both run at
// once), and every job runs once.
TEST(TaskPool, RunBesideKeepsOwnOnTheCallerWhileTheWorkersRunTheJobs) {
  TaskPool pool(1);
  const auto caller = std::this_thread::get_id();
  std::atomic<int> started{0};
  std::vector<std::atomic<int>> calls(3);
  bool own_ran = false;
  pool.run_beside(
      3,
      [&](int i) {
        ++started;
        ++calls[static_cast<std::size_t>(i)];
      },
      [&] {
        EXPECT_EQ(std::this_thread::get_id(), caller);
        while (started.load() == 0) std::this_thread::yield();
        own_ran = true;
      });
  EXPECT_TRUE(own_ran);
  for (const auto& c : calls) EXPECT_EQ(c.load(), 1);
}

TEST(TaskPool, RunBesideWithoutWorkersRunsOwnThenTheJobsInOrder) {
  TaskPool pool(0);
  std::vector<int> order;
  pool.run_beside(
      3, [&](int i) { order.push_back(i); }, [&] { order.push_back(-1); });
  EXPECT_EQ(order, (std::vector<int>{-1, 0, 1, 2}));
}

// own's exception wins over a job's and comes after every job finished.
TEST(TaskPool, RunBesideRethrowsOwnsExceptionAfterTheJobs) {
  TaskPool pool(2);
  std::atomic<int> finished{0};
  try {
    pool.run_beside(
        6,
        [&](int i) {
          if (i == 1) throw std::logic_error("job 1");
          std::this_thread::sleep_for(std::chrono::milliseconds(2));
          ++finished;
        },
        [] { throw std::runtime_error("own"); });
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "own");
  }
  EXPECT_EQ(finished.load(), 5);
}

}  // namespace
}  // namespace sitepose::features
