#pragma once
// A study over MPI ranks (docs/studies.md, "MPI"): `mpirun -np K rubref study SPEC --out DIR`.
// Rank 0 owns the folder; the points not yet written are dealt out in rounds, each rank taking a
// contiguous block of the round; the rows are gathered to rank 0, which journals them. The files
// are the same, byte for byte, as from one process: a row depends on its index alone.

#include <filesystem>
#include <iosfwd>

#include "ref/study/study_run.hpp"

namespace rubref::study {

// Whether this process was started by mpirun/srun (OpenMPI's, PMI's or PMIx's environment).
bool launched_by_mpi();
// Whether this process is an MPI rank other than 0 (from the launcher's environment): it leaves
// saying bad input to rank 0, so that a bad SPEC is one line, not one per rank.
bool secondary_mpi_rank();
// Whether this executable is the MPI engine, `rubref-mpi` (built with -DRUBREF_MPI=ON).
bool built_with_mpi();

// `rubref` itself never links MPI, so every command starts without loading it (OpenMPI and its
// dependencies cost more than the rest of a start). Under mpirun it hands its whole command line
// to `rubref-mpi` beside it, which is the same command line interface built with MPI; it returns
// when there is nothing to hand over (not under mpirun, already the engine, or no engine built).
// Throws input_error if the engine is there but cannot be started. Call it before any thread
// starts: the engine inherits the signal mask.
void hand_over_to_mpi_engine(char** argv);

struct mpi_outcome {
  bool root = false;    // rank 0: the only one that reports
  int ranks = 1;
  run_outcome outcome;  // rank 0's
};

// Every rank calls it; it initialises and finalises MPI. Bad input (found by rank 0) is an
// input_error on rank 0 and a quiet exit with status 2 on the others. `threads` per rank.
mpi_outcome run_study_mpi(const std::filesystem::path& dir, const spec& s, unsigned threads, std::ostream* progress);

}  // namespace rubref::study
