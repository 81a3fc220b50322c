#pragma once
// An interrupted run leaves nothing behind: SIGINT, SIGTERM and SIGHUP end the process after the
// staging files and folders of the outputs in progress are removed (atomic_output and
// staged_directory register them here). The exit status is the signal's usual one (128 + signal).

#include <signal.h>

#include <filesystem>
#include <functional>

namespace rubref {

// Call once, first thing in main, before any thread starts. It blocks the signals in the calling
// thread, which every later thread inherits, and waits for them on a thread of its own, where
// removing files is safe (a signal handler could not). A signal ignored at start (nohup) stays
// ignored. Without this call (a library user) the registry below is kept but nothing waits.
void install_interrupt_cleanup();

// The signals install_interrupt_cleanup() waits for (empty before it is called). A child process
// (python for the figures) gets them back at their default action and unblocked, so the
// terminal's Ctrl-C ends it too.
sigset_t interrupt_signals();

// Paths removed (recursively) when the process is interrupted, until unregistered.
void register_staging(const std::filesystem::path& p);
void unregister_staging(const std::filesystem::path& p);

// Runs f where no clean-up can run meanwhile: what creates a staging path or anything inside one
// (a folder, a file) runs so, or it could re-create a path the clean-up has just removed (the run
// is not stopped while its clean-up runs). Once a clean-up has begun, f never runs: the process is
// ending. f may register and unregister paths.
void while_not_interrupted(const std::function<void()>& f);

// A child process (python drawing into a staging folder) is sent the same signal first.
void register_child(pid_t pid);
void unregister_child(pid_t pid);

}  // namespace rubref
