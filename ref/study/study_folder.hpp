#pragma once
// A study's folder (docs/studies.md, "Files"): spec.json (the canonical SPEC), journals of rows
// (rows-<i>-of-<N>.csv, appended as points finish, so a killed study resumes where it stopped),
// and, once every point is in, the results: points.csv (rows in index order), summary.json and
// the kind's extras (folds.csv, attractors.csv). The results depend on the rows alone, never on
// which process, shard or thread wrote them.

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "ref/study/study.hpp"

namespace rubref::study {

struct shard {
  std::size_t number = 1, of = 1;  // 1-based: shard `number` of `of`
};
// "i/N" -> shard; input_error unless 1 <= i <= N.
shard parse_shard(const std::string& text);
// The block of indices [first, last) shard s owns of `points` (contiguous, sizes differ by <= 1).
std::pair<std::size_t, std::size_t> shard_block(std::size_t points, shard s);

// Before any work: `dir` can hold this study: it does not exist (its parent does), is empty, or
// is a study folder of the same canonical SPEC. input_error naming the problem otherwise.
void check_study_folder(const std::filesystem::path& dir, const std::string& canonical);
// Creates the folder (and its spec.json and marker) if needed.
void open_study_folder(const std::filesystem::path& dir, const std::string& canonical);
// The canonical SPEC a study folder holds; input_error if it is not one.
std::string read_study_spec(const std::filesystem::path& dir);

// Every complete row in the folder's journals, by index: lines as written (no newline). A
// journal's unfinished last line (a killed writer) is ignored; a row that is malformed, out of
// range, or that disagrees with another row of the same index is an input_error.
std::map<std::size_t, std::string> read_rows(const std::filesystem::path& dir, const spec& s);

// Appends rows to one journal. Opening truncates an unfinished last line left by a killed run.
class journal {
 public:
  journal(const std::filesystem::path& dir, const spec& s, shard part);
  journal(const journal&) = delete;
  journal& operator=(const journal&) = delete;
  ~journal();
  void append(const std::vector<std::vector<std::string>>& rows);  // whole lines, flushed
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
};

std::string row_line(const std::vector<std::string>& cells);

// What a finished study wrote, for the command's last line.
struct study_results {
  std::vector<std::string> files;  // relative to the folder
  std::string headline;            // e.g. "412 no_contact, 380 partial_rub, 8 non_periodic"
  std::size_t problems = 0;        // rows with status failed, invalid or unconverged
};

// Writes points.csv, summary.json and the kind's extras atomically from the complete set of rows
// (input_error naming the first missing index otherwise). `threads` only for the extras' own
// work (the regime map's fold lines), which does not change a bit with it.
study_results write_results(const std::filesystem::path& dir, const spec& s, const std::map<std::size_t, std::string>& rows,
                            unsigned threads);

}  // namespace rubref::study
