#pragma once
// Independent tasks on several threads. Each task writes only its own result slot, so the
// outcome is the same, bit for bit, whatever the number of threads.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdlib>
#include <exception>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ref/base/cancel.hpp"
#include "ref/base/errors.hpp"

namespace rubref {

// The process's default thread count: 0 (every hardware thread) unless set, e.g. by a command's
// --threads. Library calls that take no thread count (the rig, identification's fits, the loop,
// validation's diagnosis) use it; the result does not depend on it (below).
inline std::atomic<unsigned>& default_threads() {
  static std::atomic<unsigned> n{0};
  return n;
}
inline void set_default_threads(unsigned n) { default_threads() = n; }

// The threads a task of parallel_for (below) may use for a parallel_for of its own: its outer
// call's threads shared among that call's workers; 0 outside any. Nested calls then never run more
// threads than the outer call was given (the loop's two fits, each with its candidates).
inline unsigned& nested_thread_budget() {
  thread_local unsigned n = 0;
  return n;
}

// RUBREF_THREADS as a thread count: 0 when unset; input_error unless a whole number 1..4096.
inline unsigned threads_from_environment() {
  const char* env = std::getenv("RUBREF_THREADS");
  if (env == nullptr) return 0;
  char* end = nullptr;
  const long v = std::strtol(env, &end, 10);
  if (*env == '\0' || *end != '\0' || v < 1 || v > 4096)
    throw input_error("RUBREF_THREADS must be a whole number from 1 to 4096 (got '" + std::string(env) + "')");
  return static_cast<unsigned>(v);
}

// Threads to use for `requested` (0: the default above if set, else the environment's
// RUBREF_THREADS, else every hardware thread), never more than there are tasks. The environment
// knob lets any command be run on any thread count, e.g. to check that its outputs do not depend
// on it (tests/determinism_test.sh).
inline unsigned thread_count(unsigned requested, std::size_t tasks) {
  unsigned n = requested;
  if (n == 0) n = nested_thread_budget();
  if (n == 0) n = default_threads();
  if (n == 0) n = threads_from_environment();
  if (n == 0) n = std::max(1u, std::thread::hardware_concurrency());
  return static_cast<unsigned>(std::max<std::size_t>(1, std::min<std::size_t>(n, tasks)));
}

// Runs task(i) for i in [0, n). If tasks fail, the exception of the lowest failing index is
// rethrown after all threads have stopped (the one a single thread would meet first: indices are
// handed out in order, so every lower one has run); remaining tasks are skipped once one failed.
// The workers share the caller's stop source (ref/base/cancel.hpp), checked before each task.
template <class Task>
void parallel_for(std::size_t n, unsigned threads, Task&& task) {
  const stop_source* stop = current_stop_source();
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::size_t error_index = n;
  std::mutex error_mutex;
  const unsigned count = thread_count(threads, n);
  const unsigned share = std::max(1u, thread_count(threads, std::numeric_limits<std::size_t>::max()) / count);
  const auto worker = [&] {
    const stop_scope scope(stop);
    struct budget_scope {
      unsigned saved = nested_thread_budget();
      explicit budget_scope(unsigned b) { nested_thread_budget() = b; }
      ~budget_scope() { nested_thread_budget() = saved; }
    } budget(share);
    for (std::size_t i; !failed && (i = next++) < n;) {
      try {
        throw_if_stop_requested();
        task(i);
      } catch (...) {
        const std::lock_guard lock(error_mutex);
        if (i < error_index) error = std::current_exception(), error_index = i;
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < count; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace rubref
