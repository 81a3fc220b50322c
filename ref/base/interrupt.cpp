#include "ref/base/interrupt.hpp"

#include <pthread.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <mutex>
#include <set>
#include <string>
#include <system_error>
#include <thread>

namespace rubref {

namespace {

// Recursive: while_not_interrupted's f registers paths. The clean-up keeps it until the process ends.
std::recursive_mutex registry_mutex;
std::set<std::filesystem::path>& registry() {
  static std::set<std::filesystem::path> paths;
  return paths;
}
std::set<pid_t>& children() {
  static std::set<pid_t> pids;
  return pids;
}
sigset_t handled;  // written once by install_interrupt_cleanup, before any other thread exists

[[noreturn]] void wait_and_clean_up(sigset_t signals) {
  int sig = 0;
  while (sigwait(&signals, &sig) != 0) {
  }
  std::size_t removed = 0;
  {
    const std::lock_guard lock(registry_mutex);
    for (const pid_t child : children()) ::kill(child, sig);
    for (const auto& p : registry()) {
      std::error_code ec;
      removed += std::filesystem::remove_all(p, ec) > 0 ? 1 : 0;
    }
    registry().clear();
    const std::string msg = "rubref: interrupted (" + std::string(strsignal(sig)) + "); removed " + std::to_string(removed) +
                            " unfinished output(s)\n";
    [[maybe_unused]] const auto n = ::write(STDERR_FILENO, msg.data(), msg.size());
    // Die of the signal itself, so the parent sees 128 + signal. The registry stays locked: no
    // staging path can be added while the process ends.
    ::signal(sig, SIG_DFL);
    sigset_t one;
    sigemptyset(&one);
    sigaddset(&one, sig);
    pthread_sigmask(SIG_UNBLOCK, &one, nullptr);
    ::raise(sig);
  }
  std::_Exit(128 + sig);
}

}  // namespace

void install_interrupt_cleanup() {
  sigemptyset(&handled);
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction now {};
    if (sigaction(sig, nullptr, &now) == 0 && now.sa_handler == SIG_IGN) continue;  // nohup: stays ignored
    sigaddset(&handled, sig);
  }
  pthread_sigmask(SIG_BLOCK, &handled, nullptr);
  std::thread(wait_and_clean_up, handled).detach();
}

sigset_t interrupt_signals() { return handled; }

void register_staging(const std::filesystem::path& p) {
  const std::lock_guard lock(registry_mutex);
  registry().insert(p);
}

void unregister_staging(const std::filesystem::path& p) {
  const std::lock_guard lock(registry_mutex);
  registry().erase(p);
}

void while_not_interrupted(const std::function<void()>& f) {
  const std::lock_guard lock(registry_mutex);
  f();
}

void register_child(pid_t pid) {
  const std::lock_guard lock(registry_mutex);
  children().insert(pid);
}

void unregister_child(pid_t pid) {
  const std::lock_guard lock(registry_mutex);
  children().erase(pid);
}

}  // namespace rubref
