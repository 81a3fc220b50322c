#pragma once
// Independent tasks on several threads. Each task writes only its own result slot, so the
// outcome is the same, bit for bit, whatever the number of threads.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rubref {

// Threads to use for `requested` (0: the environment's RUBREF_THREADS if it is a number >= 1,
// else every hardware thread), never more than there are tasks. The knob lets the commands
// without a --threads option (rig, identify, loop) be run on any thread count, e.g. to check
// that their outputs do not depend on it (tests/determinism_test.sh).
inline unsigned thread_count(unsigned requested, std::size_t tasks) {
  unsigned n = requested;
  if (n == 0) {
    const char* env = std::getenv("RUBREF_THREADS");
    const long v = env ? std::strtol(env, nullptr, 10) : 0;
    n = v >= 1 && v <= 4096 ? static_cast<unsigned>(v) : std::max(1u, std::thread::hardware_concurrency());
  }
  return static_cast<unsigned>(std::max<std::size_t>(1, std::min<std::size_t>(n, tasks)));
}

// Runs task(i) for i in [0, n). If tasks fail, the exception of the lowest failing index is
// rethrown after all threads have stopped (the one a single thread would meet first: indices are
// handed out in order, so every lower one has run); remaining tasks are skipped once one failed.
template <class Task>
void parallel_for(std::size_t n, unsigned threads, Task&& task) {
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::size_t error_index = n;
  std::mutex error_mutex;
  const auto worker = [&] {
    for (std::size_t i; !failed && (i = next++) < n;) {
      try {
        task(i);
      } catch (...) {
        const std::lock_guard lock(error_mutex);
        if (i < error_index) error = std::current_exception(), error_index = i;
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
