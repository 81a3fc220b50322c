#pragma once
// Running a study's points: on one machine's threads (default), one shard of a job array, or as
// the computing part of an MPI rank (ref/app/study_mpi.cpp). Points are handed out in chunks;
// each finished chunk's rows go to the journal at once, so a killed study loses at most the
// chunks in flight, and progress (points done, rate, ETA) is reported on the way.

#include <chrono>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <vector>

#include "ref/study/study.hpp"
#include "ref/study/study_folder.hpp"

namespace rubref::study {

using rows_sink = std::function<void(std::vector<std::vector<std::string>>&& rows)>;

// Evaluates the points `indices` (ascending) on `threads` threads, `chunk` at a time (0: 64 per
// thread), handing each chunk's rows to `sink` in index order.
void compute_points(const spec& s, const std::vector<std::size_t>& indices, unsigned threads, std::size_t chunk, const rows_sink& sink);

// "study: 1200/10000 points (12.0 %), 310 points/s, ETA 28 s" on `out`, at most every 2 s and at
// the end; silent with a null stream.
class progress_meter {
 public:
  progress_meter(std::ostream* out, std::size_t total, std::size_t already_done);
  void add(std::size_t n);
  void finish();

 private:
  void print();
  std::ostream* out_;
  std::size_t total_, done_, start_done_, printed_ = static_cast<std::size_t>(-1);
  std::chrono::steady_clock::time_point start_, last_;
};

struct run_settings {
  shard part;             // 1/1: the whole study, results written at the end
  unsigned threads = 0;   // 0: every hardware thread (or --threads, RUBREF_THREADS)
  std::ostream* progress = nullptr;
};

struct run_outcome {
  std::size_t computed = 0, already = 0;  // points computed now, found in the folder's journals
  bool complete = false;                  // every point of the study has its row (results written)
  study_results results;
};

// Opens (or resumes) the study folder, computes the points of `settings.part` not yet written,
// and, when that completes the study, writes its results. Shards of one study may write one
// shared folder at once (each its own journal) or folders merged later (merge_study).
run_outcome run_study(const std::filesystem::path& dir, const spec& s, const run_settings& settings);

// `rubref study-merge`: the spec of every folder must be the same; rows from all of them are
// assembled into `out` (a folder of the same study, or a new one) and the results written.
study_results merge_study(const std::vector<std::filesystem::path>& dirs, const std::filesystem::path& out, unsigned threads);

}  // namespace rubref::study
