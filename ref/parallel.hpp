#pragma once
// Independent tasks on several threads. Each task writes only its own result slot, so the
// outcome is the same, bit for bit, whatever the number of threads.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rubref {

// Threads to use for `requested` (0: every hardware thread), never more than there are tasks.
inline unsigned thread_count(unsigned requested, std::size_t tasks) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const unsigned n = requested == 0 ? hw : requested;
  return static_cast<unsigned>(std::max<std::size_t>(1, std::min<std::size_t>(n, tasks)));
}

// Runs task(i) for i in [0, n). The first exception thrown by a task is rethrown after all
// threads have stopped; remaining tasks are skipped once one has failed.
template <class Task>
void parallel_for(std::size_t n, unsigned threads, Task&& task) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto worker = [&] {
    for (std::size_t i; !failed && (i = next++) < n;) {
      try {
        task(i);
      } catch (...) {
        const std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
        failed = true;
      }
    }
  };
  const unsigned count = thread_count(threads, n);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < count; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace rubref
