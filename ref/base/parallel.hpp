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
#include <optional>
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

// The threads one outermost parallel_for (below) was given, shared by everything it runs: its
// workers and the helpers of calls nested in its tasks each hold one; a thread out of tasks frees
// its own, and the next nested call takes the free ones. A task that runs long beside short ones
// (the loop's check beside its fit) then gets their threads when they finish, and the calls never
// run more threads together than the outermost was given. Results never depend on who took what:
// each task writes its own slot.
class thread_team {
 public:
  explicit thread_team(unsigned free) : free_(static_cast<int>(free)) {}
  unsigned free() const { return static_cast<unsigned>(std::max(0, free_.load())); }
  // Up to `wanted` free threads, now.
  unsigned take(unsigned wanted) {
    int have = free_.load();
    while (have > 0 && wanted > 0) {
      const int t = std::min(have, static_cast<int>(wanted));
      if (free_.compare_exchange_weak(have, have - t)) return static_cast<unsigned>(t);
    }
    return 0;
  }
  void give_back() { ++free_; }

 private:
  std::atomic<int> free_;
};

// The team of the parallel_for whose task the calling thread runs; null outside any.
inline thread_team*& current_team() {
  thread_local thread_team* team = nullptr;
  return team;
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
// RUBREF_THREADS, else every hardware thread; inside a parallel_for's task, the caller's own and
// its team's free ones now), never more than there are tasks. The environment knob lets any
// command be run on any thread count, e.g. to check that its outputs do not depend on it
// (tests/determinism_test.sh).
inline unsigned thread_count(unsigned requested, std::size_t tasks) {
  unsigned n = requested;
  if (n == 0 && current_team() != nullptr) n = 1 + current_team()->free();
  if (n == 0) n = default_threads();
  if (n == 0) n = threads_from_environment();
  if (n == 0) n = std::max(1u, std::thread::hardware_concurrency());
  return static_cast<unsigned>(std::max<std::size_t>(1, std::min<std::size_t>(n, tasks)));
}

// Runs task(i) for i in [0, n). If tasks fail, the exception of the lowest failing index is
// rethrown after all threads have stopped (the one a single thread would meet first: indices are
// handed out in order, so every lower one has run); remaining tasks are skipped once one failed.
// The workers share the caller's stop source (ref/base/cancel.hpp), checked before each task.
// Outermost, the call runs thread_count(threads, n) workers and forms their team; nested in a
// task, the caller works and takes helpers from its team's free threads (at most `threads` in
// all where that is not 0).
template <class Task>
void parallel_for(std::size_t n, unsigned threads, Task&& task) {
  if (n == 0) return;
  const stop_source* stop = current_stop_source();
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::size_t error_index = n;
  std::mutex error_mutex;
  thread_team* team = current_team();
  std::optional<thread_team> own;
  unsigned helpers = 0;
  if (team == nullptr) {
    const unsigned given = thread_count(threads, std::numeric_limits<std::size_t>::max());
    helpers = thread_count(threads, n) - 1;
    team = &own.emplace(given - 1 - helpers);
  } else {
    const std::size_t wanted = std::min<std::size_t>(threads == 0 ? n : threads, n) - 1;
    helpers = team->take(static_cast<unsigned>(std::min<std::size_t>(wanted, std::numeric_limits<unsigned>::max())));
  }
  // A helper, and the caller of the outermost call, free their thread when out of tasks; the
  // caller of a nested call keeps its own for the task it returns to.
  const auto worker = [&](bool frees) {
    const stop_scope scope(stop);
    struct team_scope {
      thread_team* saved = current_team();
      explicit team_scope(thread_team* t) { current_team() = t; }
      ~team_scope() { current_team() = saved; }
    } in_team(team);
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
    if (frees) team->give_back();
  };
  std::vector<std::thread> pool;
  for (unsigned t = 0; t < helpers; ++t) pool.emplace_back(worker, true);
  worker(own.has_value());
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace rubref
