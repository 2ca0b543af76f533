#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace collision_response::core {

/// A fixed set of worker threads for work that runs the solver many times (batches of scenes,
/// and the episodes, calibration and sampling built on them). parallelFor() spreads the indices
/// of one job over the workers and the calling thread: each thread claims the next index with one
/// atomic increment, so no lock is held while a task runs, and several callers (service threads
/// answering batches at once) run their jobs side by side, each thread helping every job that has
/// indices left. The solver keeps its scratch per thread (thread_local workspaces) and robots
/// share a const model, so tasks need no synchronisation of their own.
class WorkerPool {
 public:
  /// `threads` [1, 256]: the threads a job may use, the calling one included (threads - 1
  /// workers are started; 1: parallelFor() runs everything on the caller). Throws
  /// std::invalid_argument outside that range.
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  int threads() const { return static_cast<int>(workers_.size()) + 1; }

  /// Calls task(i) once for every i in [0, count) and returns when all have returned. The order
  /// and the threads are unspecified. If tasks throw, the remaining indices are skipped and the
  /// first exception is rethrown here once every running task has returned.
  void parallelFor(std::size_t count, const std::function<void(std::size_t)>& task);

 private:
  struct Job {
    std::size_t count = 0;
    const std::function<void(std::size_t)>* task = nullptr;
    std::atomic<std::size_t> next{0};      // the next index to claim
    std::atomic<std::size_t> finished{0};  // indices done (or skipped after a failure)
    std::atomic<bool> failed{false};
    std::exception_ptr error;  // the first failure, written once (guarded by failed)
  };

  /// Claims and runs indices of `job` until none are left; true if this call finished the job.
  static bool work(Job& job);
  void workerLoop();

  std::vector<std::thread> workers_;
  std::mutex mutex_;  // guards jobs_ and stopping_ (held only to add, find or remove a job)
  std::condition_variable work_available_;
  std::condition_variable job_done_;
  std::vector<std::shared_ptr<Job>> jobs_;  // jobs with indices still unclaimed
  bool stopping_ = false;
};

}  // namespace collision_response::core
