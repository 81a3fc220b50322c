#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "ref/app/python_script.hpp"
#include "ref/app/study_mpi.hpp"
#include "ref/base/errors.hpp"
#include "ref/base/parallel.hpp"
#include "ref/cli/commands.hpp"
#include "ref/cli/options.hpp"
#include "ref/study/study_run.hpp"

namespace rubref::cli {

namespace {

namespace fs = std::filesystem;

struct study_state {
  std::string spec_file, out, shard = "1/1";
  bool no_figures = false, quiet = false;
};
struct merge_state {
  std::vector<std::string> dirs;
  std::string out;
  bool no_figures = false;
};

std::string read_spec_file(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw input_error("SPEC " + path + ": no such file");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  if (!in && !in.eof()) throw input_error("SPEC " + path + ": cannot be read");
  return ss.str();
}

// The kind's figures (scripts/plot_study.py); a grid study has none.
void draw(const fs::path& dir, const study::spec& s, bool no_figures) {
  if (no_figures || s.kind == study::study_kind::grid) return;
  run_python_script(default_python(), script_path("plot_study.py"), dir);
}

void report(const fs::path& dir, const study::study_results& r) {
  std::cout << "wrote";
  for (const auto& f : r.files) std::cout << " " << (dir / f).string();
  std::cout << "\n" << r.headline << "\n";
  if (r.problems > 0)
    std::cerr << "warning: " << r.problems << " point(s) have no steady result (status failed, invalid or unconverged in points.csv; "
              << "the first are listed in summary.json)\n";
}

}  // namespace

void add_study(CLI::App& app) {
  auto st = std::make_shared<study_state>();
  auto* sub = app.add_subcommand("study", "a parameter study from SPEC.json (grid or random sample; regime_map, basins, monte_carlo) "
                                          "on threads, MPI ranks (mpirun) or job-array shards -> DIR/points.csv, summary.json, figures");
  sub->add_option("spec", st->spec_file, "the study's SPEC (JSON, docs/studies.md)")->required();
  sub->add_option("--out", st->out, "the study's folder: created, or resumed if it holds this SPEC's study")->required();
  sub->add_option("--shard", st->shard, "compute shard i of N only (a job array's task; `rubref study-merge` assembles them)")
      ->capture_default_str();
  sub->add_flag("--no-figures", st->no_figures, "write the tables and summary only");
  sub->add_flag("--quiet", st->quiet, "no progress on stderr");
  add_threads_option(*sub);
  sub->callback([st] {
    study::spec s;
    study::shard part;
    try {
      s = study::parse_spec(read_spec_file(st->spec_file), st->spec_file);  // bad SPEC: nothing written
      part = study::parse_shard(st->shard);
    } catch (const input_error&) {
      if (study::launched_by_mpi() && study::secondary_mpi_rank()) std::exit(2);  // rank 0 says it
      throw;
    }
    const fs::path dir = st->out;
    std::ostream* progress = st->quiet ? nullptr : &std::cerr;
    if (study::launched_by_mpi()) {
      if (part.of != 1) throw input_error("--shard and mpirun are two ways to split a study: use one");
      const study::mpi_outcome m = study::run_study_mpi(dir, s, default_threads(), progress);
      if (!m.root) return;
      std::cerr << "study: " << m.outcome.computed << " point(s) computed on " << m.ranks << " MPI rank(s), " << m.outcome.already
                << " found in " << dir.string() << "\n";
      report(dir, m.outcome.results);
      draw(dir, s, st->no_figures);
      return;
    }
    study::run_settings settings;
    settings.part = part;
    settings.threads = default_threads();
    settings.progress = progress;
    const study::run_outcome o = study::run_study(dir, s, settings);
    if (!st->quiet && o.already > 0) std::cerr << "study: resumed: " << o.already << " point(s) of this part were already in " << dir.string() << "\n";
    if (part.of != 1) {
      std::cout << "wrote shard " << part.number << "/" << part.of << " (" << (o.computed + o.already) << " points) in " << dir.string()
                << (o.complete ? "; every point is in: run `rubref study-merge` on the folder(s)" : "") << "\n";
      return;
    }
    report(dir, o.results);
    draw(dir, s, st->no_figures);
  });

  auto mt = std::make_shared<merge_state>();
  auto* merge = app.add_subcommand("study-merge", "assemble the shards of a study (`rubref study --shard i/N`) from one or more folders "
                                                  "-> points.csv, summary.json and figures");
  merge->add_option("dirs", mt->dirs, "the shards' study folders (or one shared folder)")->required();
  merge->add_option("--out", mt->out, "where to write the results; default: the first folder");
  merge->add_flag("--no-figures", mt->no_figures, "write the tables and summary only");
  add_threads_option(*merge);
  merge->callback([mt] {
    std::vector<fs::path> dirs(mt->dirs.begin(), mt->dirs.end());
    const fs::path out = mt->out.empty() ? dirs.front() : fs::path(mt->out);
    const study::study_results r = study::merge_study(dirs, out, default_threads());
    report(out, r);
    draw(out, study::parse_spec(study::read_study_spec(out), (out / "spec.json").string()), mt->no_figures);
  });
}

}  // namespace rubref::cli
