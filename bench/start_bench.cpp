// Process start of the `rubref` command (issue 46; linked into contact_bench, the one suite): spawn, run, wait, for commands that do no
// numerical work, against /bin/true as the floor of any process on this machine. A script that
// calls rubref thousands of times pays this each time; the goal is <= 2 ms for every command that
// does not need MPI (`rubref` never loads MPI: ref/app/study_mpi.hpp). And one whole numerical
// command, `rubref orbit` on the paper's case (shooting, a record CSV and a summary written), the
// command-line side of the race against SciPy (issue 63 item 7: within 1 ms of /bin/true).
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace {

// One spawn-and-wait of `argv`, output to /dev/null; throws if it fails or exits non-zero.
void run_once(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t out;
  posix_spawn_file_actions_init(&out);
  posix_spawn_file_actions_addopen(&out, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&out, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, argv[0], &out, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&out);
  if (spawned != 0) throw std::runtime_error("cannot spawn " + args[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw std::runtime_error(args[0] + " failed");
}

void process_start(benchmark::State& state, std::vector<std::string> args) {
  try {
    run_once(args);  // warm the page cache
  } catch (const std::exception& e) {
    state.SkipWithError(e.what());
    return;
  }
  for (auto _ : state) run_once(args);
}

const std::string kRubref = RUBREF_EXECUTABLE;

// `rubref orbit --out DIR/orbit.csv --force` in a fresh temporary folder, removed afterwards.
void orbit_process(benchmark::State& state) {
  std::string dir = (std::filesystem::temp_directory_path() / "rubref-start-XXXXXX").string();
  if (mkdtemp(dir.data()) == nullptr) {
    state.SkipWithError("cannot make a temporary folder");
    return;
  }
  process_start(state, {kRubref, "orbit", "--out", dir + "/orbit.csv", "--force"});
  std::filesystem::remove_all(dir);
}

}  // namespace

BENCHMARK_CAPTURE(process_start, bin_true, std::vector<std::string>{"/bin/true"})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(process_start, rubref_version, std::vector<std::string>{kRubref, "--version"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(process_start, rubref_variants, std::vector<std::string>{kRubref, "variants"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(process_start, rubref_params, std::vector<std::string>{kRubref, "params"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(orbit_process)->Name("process_start/rubref_orbit")->Unit(benchmark::kMillisecond)->UseRealTime();
