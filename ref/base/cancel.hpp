#pragma once
// Cooperative cancellation of a long library call. A front end that keeps its process alive
// across an interrupt (Python's Ctrl-C, docs/python.md) runs the call under a stop_scope and
// requests the stop from another thread; the integrator's step loop and parallel_for check it
// and throw `cancelled`, which unwinds through the same destructors as an error (staged outputs
// are removed: nothing partial is left). The command line does not use it: it ends the whole
// process on a signal (ref/base/interrupt.hpp).

#include <atomic>

namespace rubref {

// Thrown where a stop was requested. Deliberately not a std::exception, like
// boost::thread_interrupted: the handlers that turn a failed evaluation into a result
// (catch (const std::exception&)) must let it pass.
struct cancelled {};

class stop_source {
 public:
  void request_stop() { requested_.store(true, std::memory_order_relaxed); }
  bool stop_requested() const { return requested_.load(std::memory_order_relaxed); }

 private:
  std::atomic<bool> requested_{false};
};

// The calling thread's stop source (nullptr: none, the call cannot be cancelled).
inline const stop_source*& current_stop_source() {
  thread_local const stop_source* source = nullptr;
  return source;
}

// Makes `s` the calling thread's stop source for the scope's lifetime (parallel_for hands it on
// to its workers).
class stop_scope {
 public:
  explicit stop_scope(const stop_source* s) : previous_(current_stop_source()) { current_stop_source() = s; }
  ~stop_scope() { current_stop_source() = previous_; }
  stop_scope(const stop_scope&) = delete;
  stop_scope& operator=(const stop_scope&) = delete;

 private:
  const stop_source* previous_;
};

// Throws `cancelled` if the calling thread's stop was requested: one thread-local load and one
// relaxed atomic load, cheap enough for every integration step.
inline void throw_if_stop_requested() {
  if (const stop_source* s = current_stop_source(); s != nullptr && s->stop_requested()) throw cancelled{};
}

}  // namespace rubref
