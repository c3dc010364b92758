#include "sitepose/features/task_pool.hpp"

#include <algorithm>
#include <exception>

#include "sitepose/core/expected.hpp"

namespace sitepose::features {

struct TaskPool::Batch {
  const std::function<void(int)>* job = nullptr;
  int n_jobs = 0;
  int next = 0;              // guarded by the pool's mutex
  int finished = 0;          // guarded by the pool's mutex
  std::exception_ptr error;  // the first one a job threw; guarded by the mutex
  std::condition_variable done;
};

TaskPool::TaskPool(int n_workers) {
  SITEPOSE_CHECK(n_workers >= 0);
  workers_.reserve(static_cast<std::size_t>(n_workers));
  for (int i = 0; i < n_workers; ++i) workers_.emplace_back([this] { work(); });
}

TaskPool::~TaskPool() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

int TaskPool::take_job(Batch& batch, std::deque<std::shared_ptr<Batch>>& queue) {
  const int index = batch.next++;
  if (batch.next == batch.n_jobs) {
    queue.erase(std::find_if(queue.begin(), queue.end(), [&](const auto& b) { return b.get() == &batch; }));
  }
  return index;
}

void TaskPool::execute(Batch& batch, int index, std::unique_lock<std::mutex>& lock) {
  lock.unlock();
  std::exception_ptr error;
  try {
    (*batch.job)(index);
  } catch (...) {
    error = std::current_exception();
  }
  lock.lock();
  if (error && !batch.error) batch.error = error;
  if (++batch.finished == batch.n_jobs) batch.done.notify_all();
}

void TaskPool::work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stopping, nothing left
    const std::shared_ptr<Batch> batch = queue_.front();
    execute(*batch, take_job(*batch, queue_), lock);
  }
}

void TaskPool::run(int n_jobs, const std::function<void(int)>& job) {
  if (n_jobs <= 0) return;
  if (workers_.empty() || n_jobs == 1) {
    std::exception_ptr error;
    for (int i = 0; i < n_jobs; ++i) {
      try {
        job(i);
      } catch (...) {
        if (!error) error = std::current_exception();
      }
    }
    if (error) std::rethrow_exception(error);
    return;
  }
  join(*post(n_jobs, job));
}

void TaskPool::run_beside(int n_jobs, const std::function<void(int)>& job, const std::function<void()>& own) {
  if (workers_.empty() || n_jobs <= 0) {
    own();
    run(n_jobs, job);
    return;
  }
  const std::shared_ptr<Batch> batch = post(n_jobs, job);
  std::exception_ptr own_error;
  try {
    own();
  } catch (...) {
    own_error = std::current_exception();
  }
  if (own_error) {
    try {
      join(*batch);
    } catch (...) {  // own's exception is the one reported
    }
    std::rethrow_exception(own_error);
  }
  join(*batch);
}

std::shared_ptr<TaskPool::Batch> TaskPool::post(int n_jobs, const std::function<void(int)>& job) {
  auto batch = std::make_shared<Batch>();
  batch->job = &job;
  batch->n_jobs = n_jobs;
  {
    const std::lock_guard lock(mutex_);
    queue_.push_back(batch);
  }
  wake_.notify_all();
  return batch;
}

void TaskPool::join(Batch& batch) {
  std::unique_lock lock(mutex_);
  while (batch.next < batch.n_jobs) execute(batch, take_job(batch, queue_), lock);
  batch.done.wait(lock, [&] { return batch.finished == batch.n_jobs; });
  if (batch.error) std::rethrow_exception(batch.error);
}

}  // namespace sitepose::features
