#include "ref/study/study_folder.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <nlohmann/json.hpp>

#include "ref/base/errors.hpp"
#include "ref/base/number_text.hpp"
#include "ref/base/parallel.hpp"
#include "ref/base/version.hpp"
#include "ref/format/atomic_output.hpp"
#include "ref/orbits/continuation.hpp"

namespace rubref::study {

namespace fs = std::filesystem;

namespace {

constexpr const char* kSpecFile = "spec.json";
constexpr const char* kJournalPrefix = "rows-";

std::string generator_line() { return "# generator: rubref " + std::string(version()) + " study\n"; }

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw input_error("cannot read " + p.string());
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> split(const std::string& line, char sep = ',') {
  std::vector<std::string> cells;
  std::size_t start = 0;
  for (;;) {
    const std::size_t end = line.find(sep, start);
    cells.push_back(line.substr(start, end - start));
    if (end == std::string::npos) return cells;
    start = end + 1;
  }
}

bool is_journal(const fs::path& p) {
  const std::string name = p.filename().string();
  return name.rfind(kJournalPrefix, 0) == 0 && p.extension() == ".csv";
}

std::vector<fs::path> journals(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && is_journal(entry.path())) out.push_back(entry.path());
  std::sort(out.begin(), out.end());
  return out;
}

double cell_number(const std::string& c) {
  if (c == "nan") return std::numeric_limits<double>::quiet_NaN();
  return std::stod(c);
}

// Quantile by the nearest rank of sorted finite values (deterministic, no interpolation).
double quantile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size() - 1, k == 0 ? 0 : k - 1)];
}

nlohmann::ordered_json statistics(std::vector<double> v, std::size_t rows) {
  std::vector<double> finite;
  for (double x : v)
    if (std::isfinite(x)) finite.push_back(x);
  std::sort(finite.begin(), finite.end());
  nlohmann::ordered_json j;
  j["count"] = finite.size();
  j["without_value"] = rows - finite.size();
  if (finite.empty()) return j;
  double mean = 0.0;
  for (double x : finite) mean += x;  // in sorted order: the same sum wherever the rows came from
  mean /= static_cast<double>(finite.size());
  double var = 0.0;
  for (double x : finite) var += (x - mean) * (x - mean);
  j["mean"] = mean;
  j["sd"] = finite.size() > 1 ? std::sqrt(var / static_cast<double>(finite.size() - 1)) : 0.0;
  j["min"] = finite.front();
  j["p05"] = quantile(finite, 0.05);
  j["median"] = quantile(finite, 0.5);
  j["p95"] = quantile(finite, 0.95);
  j["max"] = finite.back();
  return j;
}

// A study's table as parsed rows (cells) in index order, with the column positions.
struct parsed_rows {
  std::vector<std::string> columns;
  std::vector<std::vector<std::string>> cells;
  std::size_t col(const std::string& name) const {
    return static_cast<std::size_t>(std::find(columns.begin(), columns.end(), name) - columns.begin());
  }
};

// Basins: the attractor each start reached. Two periodic results are one attractor when they
// have the same period and response and their shift-invariant measures (max radius, max y, the
// forward and backward 1X amplitudes) agree to 1e-6 of the clearance: a shot orbit is exact to
// 1e-12 m, and a period-n orbit entered one revolution later gives the same measures.
std::vector<std::string> label_attractors(const parsed_rows& t, const spec& s, nlohmann::ordered_json& summary, std::string& csv) {
  const double tol = 1e-6 * s.base.clearance;
  struct attractor {
    std::string response, period;
    std::vector<double> measures;
    std::size_t points = 0, first = 0;
  };
  std::vector<attractor> found;
  std::vector<std::string> labels;
  std::size_t non_periodic = 0, unresolved = 0;
  const std::vector<std::string> measure_names{"max_radius_m", "max_y_m", "forward_1x_m", "backward_1x_m"};
  for (const auto& row : t.cells) {
    const std::string& status = row[t.col("status")];
    const std::string& response = row[t.col("response")];
    if (status != "ok") {
      labels.push_back("-1");
      ++unresolved;
      continue;
    }
    if (response == "non_periodic") {
      labels.push_back("0");
      ++non_periodic;
      continue;
    }
    std::vector<double> m;
    for (const auto& n : measure_names) m.push_back(cell_number(row[t.col(n)]));
    const std::string& period = row[t.col("period_revs")];
    std::size_t id = 0;
    for (std::size_t a = 0; a < found.size() && id == 0; ++a) {
      bool same = found[a].response == response && found[a].period == period;
      for (std::size_t k = 0; same && k < m.size(); ++k) same = std::abs(found[a].measures[k] - m[k]) <= tol;
      if (same) id = a + 1;
    }
    if (id == 0) {
      found.push_back({response, period, m, 0, static_cast<std::size_t>(std::stoull(row[0]))});
      id = found.size();
    }
    ++found[id - 1].points;
    labels.push_back(std::to_string(id));
  }
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  csv = generator_line() + "attractor,response,period_revs,points,share,first_index,max_radius_m,max_y_m,forward_1x_m,backward_1x_m\n";
  const double n = static_cast<double>(t.cells.size());
  for (std::size_t a = 0; a < found.size(); ++a) {
    const auto& f = found[a];
    list.push_back({{"attractor", a + 1}, {"response", f.response}, {"period_revs", std::stoi(f.period)}, {"points", f.points},
                    {"share", static_cast<double>(f.points) / n}, {"first_index", f.first}, {"max_radius_m", f.measures[0]},
                    {"max_y_m", f.measures[1]}, {"forward_1x_m", f.measures[2]}, {"backward_1x_m", f.measures[3]}});
    csv += std::to_string(a + 1) + "," + f.response + "," + f.period + "," + std::to_string(f.points) + "," +
           format_number(static_cast<double>(f.points) / n) + "," + std::to_string(f.first);
    for (double v : f.measures) csv += "," + format_number(v);
    csv += "\n";
  }
  summary["attractors"] = list;
  summary["non_periodic_points"] = non_periodic;
  summary["unresolved_points"] = unresolved;
  return labels;
}

// Regime map: the folds of the period-1 branch at each clearance of the grid, by continuation
// over the grid's speed range: the lines between which two steady responses coexist.
std::string fold_lines(const spec& s, nlohmann::ordered_json& summary, unsigned threads) {
  const axis& clearances = s.grid[0].name == "clearance_m" ? s.grid[0] : s.grid[1];
  const axis& speeds = s.grid[0].name == kSpeed ? s.grid[0] : s.grid[1];
  const double lo = *std::min_element(speeds.values.begin(), speeds.values.end());
  const double hi = *std::max_element(speeds.values.begin(), speeds.values.end());
  struct folds_at {
    std::vector<special_point> folds;
    std::string problem;
  };
  std::vector<folds_at> out(clearances.values.size());
  if (lo < hi)
    parallel_for(out.size(), threads, [&](std::size_t i) {
      continuation_request req;
      req.variant = s.variant;
      req.params = s.base;
      req.params.clearance = clearances.values[i];
      req.from = lo;
      req.to = hi;
      req.samples_per_rev = s.job.samples_per_rev;
      try {
        validate(req);
        const continuation_result r = continue_branch(req);
        for (const auto& p : r.special)
          if (p.kind == special_kind::fold) out[i].folds.push_back(p);
        if (!r.reached_end) out[i].problem = r.stopped;
      } catch (const std::exception& e) {  // a fold line that cannot be traced is said, not drawn
        out[i].problem = one_line(e.what());
      }
    });
  std::string csv = generator_line() + "clearance_m,fold_rpm,located\n";
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < out.size(); ++i) {
    nlohmann::ordered_json at{{"clearance_m", clearances.values[i]}, {"fold_rpm", nlohmann::ordered_json::array()}};
    for (const auto& f : out[i].folds) {
      at["fold_rpm"].push_back(f.rpm);
      csv += format_number(clearances.values[i]) + "," + format_number(f.rpm) + "," + (f.located ? "1" : "0") + "\n";
    }
    if (!out[i].problem.empty()) at["branch_problem"] = out[i].problem;
    list.push_back(at);
  }
  summary["folds"] = list;
  return csv;
}

}  // namespace

shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  const auto bad = [&] { return input_error(setting("shard") + " must be i/N with 1 <= i <= N (got '" + text + "')"); };
  if (slash == std::string::npos) throw bad();
  const std::string a = text.substr(0, slash), b = text.substr(slash + 1);
  const auto digits = [](const std::string& s) { return !s.empty() && s.size() <= 9 && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }); };
  if (!digits(a) || !digits(b)) throw bad();
  shard s{std::stoul(a), std::stoul(b)};
  if (s.number < 1 || s.number > s.of) throw bad();
  return s;
}

std::pair<std::size_t, std::size_t> shard_block(std::size_t points, shard s) {
  // floor(points * k / of) without overflow: (q of + r) k / of = q k + r k / of, r < of
  const std::size_t q = points / s.of, r = points % s.of;
  const auto edge = [&](std::size_t k) { return q * k + r * k / s.of; };
  return {edge(s.number - 1), edge(s.number)};
}

void check_study_folder(const fs::path& dir, const std::string& canonical) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
    if (!fs::is_directory(parent, ec)) throw input_error(setting("out") + " " + dir.string() + ": its folder " + parent.string() + " does not exist");
    return;
  }
  if (!fs::is_directory(dir, ec)) throw input_error(setting("out") + " " + dir.string() + " exists and is not a folder");
  if (fs::exists(dir / kSpecFile, ec)) {
    if (read_text(dir / kSpecFile) != canonical)
      throw input_error(setting("out") + " " + dir.string() + " holds another study (its spec.json differs from this SPEC): use another folder");
    return;
  }
  if (!fs::is_empty(dir, ec)) throw input_error(setting("out") + " " + dir.string() + " is not empty and holds no study (no spec.json): use a new or empty folder");
}

void open_study_folder(const fs::path& dir, const std::string& canonical) {
  check_study_folder(dir, canonical);
  std::error_code ec;
  fs::create_directory(dir, ec);
  if (!fs::is_directory(dir)) throw input_error("cannot create " + dir.string() + (ec ? ": " + ec.message() : ""));
  if (!fs::exists(dir / kSpecFile)) {
    atomic_output out;  // shards racing on one shared folder write the same bytes
    out.stage(dir / kSpecFile, canonical);
    out.commit();
  }
}

std::string read_study_spec(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw input_error(dir.string() + " is not a folder");
  if (!fs::exists(dir / kSpecFile, ec)) throw input_error(dir.string() + " is not a study folder (no spec.json)");
  return read_text(dir / kSpecFile);
}

std::string row_line(const std::vector<std::string>& cells) {
  std::string line;
  for (std::size_t i = 0; i < cells.size(); ++i) line += (i ? "," : "") + cells[i];
  return line;
}

std::map<std::size_t, std::string> read_rows(const fs::path& dir, const spec& s) {
  const std::vector<std::string> cols = columns(s);
  const std::string header = row_line(cols);
  const std::size_t n = point_count(s);
  const std::size_t varied = varied_names(s).size();
  std::map<std::size_t, std::string> rows;
  std::map<std::size_t, fs::path> source;
  for (const fs::path& file : journals(dir)) {
    const std::string content = read_text(file);
    std::size_t pos = 0, line_no = 0;
    while (pos < content.size()) {
      const std::size_t nl = content.find('\n', pos);
      if (nl == std::string::npos) break;  // an unfinished last line: its point runs again
      const std::string line = content.substr(pos, nl - pos);
      pos = nl + 1;
      ++line_no;
      const std::string where = file.string() + ":" + std::to_string(line_no);
      if (line_no == 1) {
        if (line.rfind("# generator: rubref", 0) != 0) throw input_error(where + ": not a study journal rubref wrote");
        continue;
      }
      if (line_no == 2) {
        if (line != header) throw input_error(where + ": its columns are not this study's");
        continue;
      }
      const auto cells = split(line);
      if (cells.size() != cols.size()) throw input_error(where + ": " + std::to_string(cells.size()) + " cells for " + std::to_string(cols.size()) + " columns");
      const std::string& idx = cells[0];
      if (idx.empty() || idx.size() > 15 || !std::all_of(idx.begin(), idx.end(), [](char c) { return c >= '0' && c <= '9'; }))
        throw input_error(where + ": index '" + idx + "' is not a whole number");
      const std::size_t i = std::stoull(idx);
      if (i >= n) throw input_error(where + ": index " + idx + " is beyond the study's " + std::to_string(n) + " points");
      const point p = point_at(s, i);
      for (std::size_t k = 0; k < varied; ++k)
        if (cells[1 + k] != format_number(p.values[k])) throw input_error(where + ": point " + idx + "'s " + cols[1 + k] + " is not this study's");
      if (const auto it = rows.find(i); it != rows.end()) {
        if (it->second != line)
          throw input_error(where + ": point " + idx + " differs from its row in " + source[i].string() + " (two builds or settings wrote this folder?)");
        continue;
      }
      rows.emplace(i, line);
      source.emplace(i, file);
    }
  }
  return rows;
}

journal::journal(const fs::path& dir, const spec& s, shard part) {
  path_ = dir / (std::string(kJournalPrefix) + std::to_string(part.number) + "-of-" + std::to_string(part.of) + ".csv");
  std::error_code ec;
  if (fs::exists(path_, ec)) {
    // Drop an unfinished last line (a killed writer) so that appended rows start on a line.
    const std::string content = read_text(path_);
    const std::size_t keep = content.rfind('\n') == std::string::npos ? 0 : content.rfind('\n') + 1;
    if (keep != content.size()) fs::resize_file(path_, keep);
    // Without both header lines (cut while they were written) it starts afresh.
    if (std::count(content.begin(), content.begin() + static_cast<std::ptrdiff_t>(keep), '\n') < 2) fs::remove(path_);
  }
  const bool fresh = !fs::exists(path_, ec);
  file_ = std::fopen(path_.c_str(), "ab");
  if (file_ == nullptr) throw input_error("cannot write " + path_.string() + ": " + std::strerror(errno));
  if (fresh) {
    const std::string head = generator_line() + row_line(columns(s)) + "\n";
    std::fwrite(head.data(), 1, head.size(), file_);
    std::fflush(file_);
  }
}

journal::~journal() {
  if (file_ != nullptr) std::fclose(file_);
}

void journal::append(const std::vector<std::vector<std::string>>& rows) {
  std::string text;
  for (const auto& r : rows) text += row_line(r) + "\n";
  if (std::fwrite(text.data(), 1, text.size(), file_) != text.size() || std::fflush(file_) != 0)
    throw input_error("cannot write " + path_.string() + ": " + std::strerror(errno));
}

study_results write_results(const fs::path& dir, const spec& s, const std::map<std::size_t, std::string>& rows, unsigned threads) {
  const std::size_t n = point_count(s);
  for (std::size_t i = 0; i < n; ++i)
    if (rows.find(i) == rows.end())
      throw input_error(dir.string() + ": point " + std::to_string(i) + " of " + std::to_string(n) + " has no row yet (run its shard, or the study again)");

  parsed_rows t;
  t.columns = columns(s);
  t.cells.reserve(n);
  for (const auto& [i, line] : rows) t.cells.push_back(split(line));

  nlohmann::ordered_json summary;
  summary["generator"] = "rubref " + std::string(version()) + " study";
  summary["study"] = to_string(s.kind);
  summary["name"] = s.name;
  summary["variant"] = s.variant;
  summary["job"] = to_string(s.job.kind);
  summary["points"] = n;
  summary["varied"] = varied_names(s);

  study_results res;
  std::map<std::string, std::size_t> status;
  nlohmann::ordered_json problems = nlohmann::ordered_json::array();
  for (const auto& row : t.cells) {
    const std::string& st = row[t.col("status")];
    ++status[st];
    if (st != "ok") {
      ++res.problems;
      if (problems.size() < 20) problems.push_back({{"index", std::stoull(row[0])}, {"status", st}, {"note", row.back()}});
    }
  }
  summary["status"] = status;
  summary["problems"] = problems;

  atomic_output out;
  if (s.job.kind == job_kind::run_up) {
    for (const char* c : {"onset_rpm", "jump_rpm", "peak_force_N", "max_y_m", "unstable_width_rpm"}) {
      std::vector<double> v;
      for (const auto& row : t.cells)
        if (row[t.col("status")] == "ok") v.push_back(cell_number(row[t.col(c)]));
      summary["statistics"][c] = statistics(v, v.size());
    }
    res.headline = std::to_string(status["ok"]) + " run-ups";
  } else if (s.job.kind == job_kind::loop) {
    // The campaign's score: the loop named exactly the truth's effects (none for none).
    std::map<std::string, std::pair<std::size_t, std::size_t>> by_truth;  // points, matched
    std::size_t matched = 0, ok = 0;
    for (const auto& row : t.cells) {
      if (row[t.col("status")] != "ok") continue;
      ++ok;
      const bool m = row[t.col("match")] == "1";
      matched += m;
      auto& b = by_truth[row[t.col("truth")]];
      ++b.first;
      b.second += m;
    }
    nlohmann::ordered_json campaign{{"points_run", ok}, {"named_exactly", matched}};
    for (const auto& [truth, b] : by_truth) campaign["by_truth"][truth] = {{"points", b.first}, {"named_exactly", b.second}};
    summary["campaign"] = campaign;
    res.headline = std::to_string(matched) + " of " + std::to_string(ok) + " loop runs named exactly the effects of their truth";
  } else {
    std::map<std::string, std::size_t> responses, periods;
    for (const auto& row : t.cells) {
      if (row[t.col("status")] != "ok") continue;
      ++responses[row[t.col("response")]];
      ++periods[row[t.col("period_revs")]];
    }
    summary["responses"] = responses;
    summary["periods_revs"] = periods;
    for (const auto& [r, k] : responses) res.headline += (res.headline.empty() ? "" : ", ") + std::to_string(k) + " " + r;
  }
  std::vector<std::string> extra_column;
  if (s.kind == study_kind::basins) {
    std::string csv;
    extra_column = label_attractors(t, s, summary, csv);
    out.stage(dir / "attractors.csv", csv);
    res.files.push_back("attractors.csv");
    res.headline += "; " + std::to_string(summary["attractors"].size()) + " periodic attractor(s)";
  }
  if (s.kind == study_kind::regime_map) {
    out.stage(dir / "folds.csv", fold_lines(s, summary, threads));
    res.files.push_back("folds.csv");
  }

  std::string points = generator_line();
  points += "# study: " + std::string(to_string(s.kind)) + "\n# job: " + std::string(to_string(s.job.kind)) + "\n";
  points += "# variant: " + s.variant + "\n# points: " + std::to_string(n) + "\n";
  points += row_line(t.columns) + (extra_column.empty() ? "" : ",attractor") + "\n";
  std::size_t k = 0;
  for (const auto& [i, line] : rows) points += line + (extra_column.empty() ? "" : "," + extra_column[k++]) + "\n";
  out.stage(dir / "points.csv", points);
  out.stage(dir / "summary.json", summary.dump(2) + "\n");
  out.commit();
  res.files.insert(res.files.begin(), {"points.csv", "summary.json"});
  return res;
}

}  // namespace rubref::study
