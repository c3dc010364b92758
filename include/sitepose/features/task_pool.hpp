#pragma once
// A fixed set of worker threads for extraction's independent jobs (the two
// images of a stereo pair, the masked area's share). Whoever runs the
// pipeline owns the pool (SlamSystem, a tool) and lends it to the
// algorithms, so no algorithm starts threads per frame.
//
// run(n, job) calls job(0) ... job(n - 1) on the workers and on the calling
// thread, and returns when all have finished. The caller takes jobs too, so
// a job may call run() again without deadlock, and a pool of 0 workers runs
// every job on the caller, in order. Jobs must write their results by index:
// which thread runs which job is not fixed. An exception thrown by a job is
// rethrown by run() (the first one; the other jobs still finish).
// run_beside(n, job, own) runs own() on the calling thread while the
// workers start on the jobs, then joins them: for work that must stay on the
// caller's thread (a detector bound to it) and can overlap the jobs.
// Threads: run() and run_beside() may be called from several threads at once.

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace sitepose::features {

class TaskPool {
 public:
  // n_workers >= 0 threads, started here and joined by the destructor.
  explicit TaskPool(int n_workers);
  ~TaskPool();
  TaskPool(const TaskPool&) = delete;
  TaskPool& operator=(const TaskPool&) = delete;

  int n_workers() const { return static_cast<int>(workers_.size()); }
  void run(int n_jobs, const std::function<void(int)>& job);
  // own() on this thread beside the jobs (on a pool of 0 workers: own(),
  // then the jobs). An exception from own() is rethrown once the jobs are
  // done (before one from a job).
  void run_beside(int n_jobs, const std::function<void(int)>& job, const std::function<void()>& own);

 private:
  struct Batch;
  void work();
  // Takes the next job of the front batch; call with mutex_ held.
  static int take_job(Batch& batch, std::deque<std::shared_ptr<Batch>>& queue);
  // Runs job `index` of `batch` with the lock released, then counts it.
  static void execute(Batch& batch, int index, std::unique_lock<std::mutex>& lock);
  // Queues a batch of the jobs for the workers and wakes them.
  std::shared_ptr<Batch> post(int n_jobs, const std::function<void(int)>& job);
  // Takes the batch's jobs no worker has taken, waits for the others and
  // rethrows the first job's exception.
  void join(Batch& batch);

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Batch>> queue_;  // batches with jobs not yet taken
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace sitepose::features
