#include "ref/app/study_mpi.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <sstream>

#include "ref/base/errors.hpp"

#ifdef RUBREF_WITH_MPI
#include <mpi.h>
#endif

namespace rubref::study {

bool launched_by_mpi() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MPI_LOCALNRANKS"})
    if (std::getenv(var) != nullptr) return true;
  return false;
}

bool secondary_mpi_rank() {
  for (const char* var : {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"})
    if (const char* v = std::getenv(var); v != nullptr) return std::string(v) != "0";
  return false;
}

#ifndef RUBREF_WITH_MPI

bool built_with_mpi() { return false; }

void hand_over_to_mpi_engine(char** argv) {
  if (!launched_by_mpi()) return;
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return;  // no /proc: stay, and say below that this rubref has no MPI
  const std::filesystem::path engine = self.parent_path() / "rubref-mpi";
  if (!std::filesystem::exists(engine, ec)) return;
  ::execv(engine.c_str(), argv);
  throw input_error("cannot start " + engine.string() + " under mpirun: " + std::strerror(errno));
}

mpi_outcome run_study_mpi(const std::filesystem::path&, const spec&, unsigned, std::ostream*) {
  throw input_error("no rubref-mpi beside this rubref (configure with -DRUBREF_MPI=ON); under mpirun each process would run the whole study");
}

#else

bool built_with_mpi() { return true; }

void hand_over_to_mpi_engine(char**) {}

namespace {

// Rows as one text of lines, and back.
std::string to_text(const std::vector<std::vector<std::string>>& rows) {
  std::string text;
  for (const auto& r : rows) text += row_line(r) + "\n";
  return text;
}
std::vector<std::vector<std::string>> from_text(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::size_t start = 0;
    for (;;) {
      const std::size_t end = line.find(',', start);
      cells.push_back(line.substr(start, end - start));
      if (end == std::string::npos) break;
      start = end + 1;
    }
    rows.push_back(std::move(cells));
  }
  return rows;
}

// Rank 0's verdict on the folder, shared so that every rank stops on bad input.
void share_status(int& status, std::string& message, bool root) {
  MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
  int length = static_cast<int>(message.size());
  MPI_Bcast(&length, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!root) message.resize(static_cast<std::size_t>(length));
  if (length > 0) MPI_Bcast(message.data(), length, MPI_CHAR, 0, MPI_COMM_WORLD);
}

[[noreturn]] void stop_quietly(int status) {
  MPI_Finalize();
  std::exit(status);
}

}  // namespace

mpi_outcome run_study_mpi(const std::filesystem::path& dir, const spec& s, unsigned threads, std::ostream* progress) {
  int provided = 0;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);  // only the main thread calls MPI
  int rank = 0, ranks = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  mpi_outcome result;
  result.root = rank == 0;
  result.ranks = ranks;
  if (threads == 0) threads = 1;  // one thread per rank unless asked: ranks are usually one per core

  // Rank 0 opens the folder and lists the points still to compute.
  std::vector<unsigned long long> todo;
  int status = 0;
  std::string message;
  std::unique_ptr<journal> log;
  if (result.root) {
    try {
      open_study_folder(dir, canonical_text(s));
      const auto written = read_rows(dir, s);
      for (std::size_t i = 0; i < point_count(s); ++i)
        if (written.find(i) == written.end()) todo.push_back(i);
      result.outcome.already = point_count(s) - todo.size();
      require(todo.size() < (std::size_t{1} << 31), "an MPI study computes at most 2^31 points per run; split it with " + setting("shard"));
      log = std::make_unique<journal>(dir, s, shard{});
    } catch (const input_error& e) {
      status = 2;
      message = e.what();
    }
  }
  share_status(status, message, result.root);
  if (status != 0) {
    if (result.root) {
      MPI_Finalize();
      throw input_error(message);
    }
    stop_quietly(status);
  }
  unsigned long long count = todo.size();
  MPI_Bcast(&count, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
  todo.resize(count);
  if (count > 0) MPI_Bcast(todo.data(), static_cast<int>(count), MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);

  // Rounds: each rank computes its contiguous block of the round; rank 0 gathers and journals.
  const std::size_t per_rank = 64 * static_cast<std::size_t>(threads);
  const std::size_t round = per_rank * static_cast<std::size_t>(ranks);
  progress_meter meter(result.root ? progress : nullptr, point_count(s), result.outcome.already);
  for (std::size_t first = 0; first < todo.size(); first += round) {
    const std::size_t len = std::min(round, todo.size() - first);
    const std::size_t lo = first + len * static_cast<std::size_t>(rank) / static_cast<std::size_t>(ranks);
    const std::size_t hi = first + len * static_cast<std::size_t>(rank + 1) / static_cast<std::size_t>(ranks);
    std::vector<std::size_t> mine(todo.begin() + static_cast<std::ptrdiff_t>(lo), todo.begin() + static_cast<std::ptrdiff_t>(hi));
    std::string text;
    try {
      compute_points(s, mine, threads, mine.size() + 1, [&](std::vector<std::vector<std::string>>&& rows) { text += to_text(rows); });
    } catch (const std::exception& e) {  // evaluate() turns bad points into rows; anything else ends the run
      std::cerr << "rubref: error: rank " << rank << ": " << one_line(e.what()) << "\n";
      MPI_Abort(MPI_COMM_WORLD, 4);
    }
    int length = static_cast<int>(text.size());
    std::vector<int> lengths(result.root ? static_cast<std::size_t>(ranks) : 0), offsets(lengths.size());
    MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::string all;
    if (result.root) {
      int total = 0;
      for (std::size_t r = 0; r < lengths.size(); ++r) offsets[r] = total, total += lengths[r];
      all.resize(static_cast<std::size_t>(total));
    }
    MPI_Gatherv(text.data(), length, MPI_CHAR, all.data(), lengths.data(), offsets.data(), MPI_CHAR, 0, MPI_COMM_WORLD);
    if (result.root) {
      try {
        const auto rows = from_text(all);  // rank order is index order: blocks are contiguous
        log->append(rows);
        meter.add(rows.size());
      } catch (const std::exception& e) {
        std::cerr << "rubref: error: " << one_line(e.what()) << "\n";
        MPI_Abort(MPI_COMM_WORLD, 2);
      }
    }
  }
  if (!todo.empty()) meter.finish();
  result.outcome.computed = todo.size();
  log.reset();
  MPI_Finalize();
  if (result.root) {
    const auto rows = read_rows(dir, s);
    result.outcome.complete = rows.size() == point_count(s);
    // The other ranks are done: the extras (the regime map's fold lines) take every core here.
    if (result.outcome.complete) result.outcome.results = write_results(dir, s, rows, 0);
  }
  return result;
}

#endif

}  // namespace rubref::study
