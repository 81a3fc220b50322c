#include "ref/study/study_run.hpp"

#include <algorithm>
#include <ostream>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/base/parallel.hpp"

namespace rubref::study {

namespace fs = std::filesystem;

void compute_points(const spec& s, const std::vector<std::size_t>& indices, unsigned threads, std::size_t chunk, const rows_sink& sink) {
  const unsigned workers = thread_count(threads, std::max<std::size_t>(1, indices.size()));
  if (chunk == 0) chunk = 64 * static_cast<std::size_t>(workers);
  for (std::size_t first = 0; first < indices.size(); first += chunk) {
    const std::size_t count = std::min(chunk, indices.size() - first);
    std::vector<std::vector<std::string>> rows(count);
    parallel_for(count, workers, [&](std::size_t k) { rows[k] = evaluate(s, indices[first + k]); });  // each its own slot
    sink(std::move(rows));
  }
}

progress_meter::progress_meter(std::ostream* out, std::size_t total, std::size_t already_done)
    : out_(out), total_(total), done_(already_done), start_done_(already_done), start_(std::chrono::steady_clock::now()), last_(start_) {}

void progress_meter::add(std::size_t n) {
  done_ += n;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ >= std::chrono::seconds(2)) {
    last_ = now;
    print();
  }
}

void progress_meter::finish() {
  if (printed_ != done_) print();
}

void progress_meter::print() {
  if (out_ == nullptr) return;
  printed_ = done_;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = seconds > 0.0 ? static_cast<double>(done_ - start_done_) / seconds : 0.0;
  *out_ << "study: " << done_ << "/" << total_ << " points ("
        << format_fixed(total_ ? 100.0 * static_cast<double>(done_) / static_cast<double>(total_) : 100.0, 1) << " %), "
        << format_digits(rate, 3) << " points/s";
  if (done_ < total_ && rate > 0.0) *out_ << ", ETA " << format_digits(static_cast<double>(total_ - done_) / rate, 3) << " s";
  *out_ << std::endl;
}

run_outcome run_study(const fs::path& dir, const spec& s, const run_settings& settings) {
  const std::string canonical = canonical_text(s);
  open_study_folder(dir, canonical);
  const auto [first, last] = shard_block(point_count(s), settings.part);
  const auto written = read_rows(dir, s);
  std::vector<std::size_t> todo;
  for (std::size_t i = first; i < last; ++i)
    if (written.find(i) == written.end()) todo.push_back(i);
  run_outcome outcome;
  outcome.already = (last - first) - todo.size();
  {
    journal j(dir, s, settings.part);
    progress_meter meter(settings.progress, last - first, outcome.already);
    compute_points(s, todo, settings.threads, 0, [&](std::vector<std::vector<std::string>>&& rows) {
      j.append(rows);
      meter.add(rows.size());
    });
    if (!todo.empty()) meter.finish();
  }
  outcome.computed = todo.size();
  const auto rows = read_rows(dir, s);
  outcome.complete = rows.size() == point_count(s);
  if (outcome.complete && settings.part.of == 1) outcome.results = write_results(dir, s, rows, settings.threads);
  return outcome;
}

study_results merge_study(const std::vector<fs::path>& dirs, const fs::path& out, unsigned threads) {
  require(!dirs.empty(), "study-merge needs at least one study folder");
  const std::string canonical = read_study_spec(dirs.front());
  for (const auto& d : dirs)
    if (read_study_spec(d) != canonical)
      throw input_error(d.string() + " holds another study than " + dirs.front().string() + " (their spec.json differ)");
  const spec s = parse_spec(canonical, (dirs.front() / "spec.json").string());
  std::map<std::size_t, std::string> rows;
  for (const auto& d : dirs)
    for (auto& [i, line] : read_rows(d, s)) {
      const auto [it, inserted] = rows.emplace(i, line);
      if (!inserted && it->second != line)
        throw input_error(d.string() + ": point " + std::to_string(i) + " differs from its row in another folder (two builds or settings?)");
    }
  check_study_folder(out, canonical);
  const std::size_t n = point_count(s);
  if (rows.size() != n) {
    std::size_t missing = 0, first_missing = n;
    for (std::size_t i = 0; i < n; ++i)
      if (rows.find(i) == rows.end()) first_missing = std::min(first_missing, i), ++missing;
    throw input_error("study-merge: " + std::to_string(missing) + " of " + std::to_string(n) + " points have no row (the first: " +
                      std::to_string(first_missing) + "); run the shards that hold them");
  }
  open_study_folder(out, canonical);
  return write_results(out, s, rows, threads);
}

}  // namespace rubref::study
