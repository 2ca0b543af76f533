#include "collision_response/core/worker_pool.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace collision_response::core {

WorkerPool::WorkerPool(int threads) {
  if (threads < 1 || threads > 256) {
    throw std::invalid_argument("WorkerPool: threads must lie in [1, 256] (" +
                                std::to_string(threads) + ")");
  }
  workers_.reserve(static_cast<std::size_t>(threads - 1));
  for (int k = 1; k < threads; ++k) workers_.emplace_back([this] { workerLoop(); });
}

WorkerPool::~WorkerPool() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  work_available_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

bool WorkerPool::work(Job& job) {
  std::size_t done = 0;
  for (;;) {
    const std::size_t i = job.next.fetch_add(1, std::memory_order_relaxed);
    if (i >= job.count) break;
    if (!job.failed.load(std::memory_order_acquire)) {
      try {
        (*job.task)(i);
      } catch (...) {
        bool expected = false;
        if (job.failed.compare_exchange_strong(expected, true, std::memory_order_acq_rel))
          job.error = std::current_exception();
      }
    }
    ++done;
  }
  // The thread that brings `finished` to count is the last: every task has returned.
  return done > 0 && job.finished.fetch_add(done, std::memory_order_acq_rel) + done == job.count;
}

void WorkerPool::workerLoop() {
  for (;;) {
    std::shared_ptr<Job> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      work_available_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
      if (stopping_) return;
      job = jobs_.front();
      // A job whose indices are all claimed needs no more helpers: drop it from the list.
      if (job->next.load(std::memory_order_relaxed) >= job->count) {
        jobs_.erase(jobs_.begin());
        continue;
      }
    }
    if (work(*job)) {
      const std::lock_guard<std::mutex> lock(mutex_);
      job_done_.notify_all();
    }
  }
}

void WorkerPool::parallelFor(std::size_t count, const std::function<void(std::size_t)>& task) {
  if (count == 0) return;
  auto job = std::make_shared<Job>();
  job->count = count;
  job->task = &task;
  const bool helped = !workers_.empty() && count > 1;
  if (helped) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      jobs_.push_back(job);
    }
    work_available_.notify_all();
  }
  bool last = work(*job);
  if (helped) {
    std::unique_lock<std::mutex> lock(mutex_);
    jobs_.erase(std::remove(jobs_.begin(), jobs_.end(), job), jobs_.end());
    if (!last) {
      job_done_.wait(lock,
                     [&] { return job->finished.load(std::memory_order_acquire) == job->count; });
    }
  }
  (void)last;
  if (job->failed.load(std::memory_order_acquire)) std::rethrow_exception(job->error);
}

}  // namespace collision_response::core
