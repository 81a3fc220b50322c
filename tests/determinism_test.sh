#!/usr/bin/env bash
# Same inputs, same bits, whatever the thread count (docs/robustness.md): every command that runs
# tasks on threads is run on 1 and on 2 threads (--threads, or RUBREF_THREADS for the commands
# without the option) and a second time on 1, and every file it writes is compared byte for byte.
source "$(dirname "${BASH_SOURCE[0]}")/shell_support.sh"

# same <what> <dir-a> <dir-b>: the two outputs are identical, file by file.
same() {
  diff -r "$2" "$3" >"$work/diff" || fail "$1 differs between runs: $(head -c 400 "$work/diff")"
}

# A sweep across the jump (both directions, orbits kept) on 1 and 2 threads, and again on 1.
sw=(sweep --from 1560 --to 1640 --step 20 --first-settle-revs 40 --settle-revs 20 --orbits)
"$rubref" "${sw[@]}" --threads 1 --out "$work/sweep_1" >/dev/null || fail "sweep on 1 thread"
"$rubref" "${sw[@]}" --threads 2 --out "$work/sweep_2" >/dev/null || fail "sweep on 2 threads"
"$rubref" "${sw[@]}" --threads 1 --out "$work/sweep_1b" >/dev/null || fail "sweep again"
same "sweep (1 vs 2 threads)" "$work/sweep_1" "$work/sweep_2"
same "sweep (run vs rerun)" "$work/sweep_1" "$work/sweep_1b"

# The virtual rig (its dwells run in parallel), then identify and loop on its record (their
# output-error fits evaluate the dwells in parallel).
rig=(rig --speeds 1300,1400,1600,1650 --settle-revs 60 --revs 8)
for n in 1 2; do
  mkdir -p "$work/rig_$n"
  RUBREF_THREADS=$n "$rubref" "${rig[@]}" --out "$work/rig_$n/rig.csv" >/dev/null || fail "rig on $n threads"
done
same "rig (1 vs 2 threads)" "$work/rig_1" "$work/rig_2"
for n in 1 2; do
  RUBREF_THREADS=$n "$rubref" loop "$work/rig_1/rig.csv" --no-figures --out "$work/loop_$n" >/dev/null 2>&1 || fail "loop on $n threads"
done
same "loop (1 vs 2 threads)" "$work/loop_1" "$work/loop_2"
idf=(identify "$work/rig_1/rig.csv" --averaging on --library z1,z3,zd2 --reidentify)
for n in 1 2; do
  RUBREF_THREADS=$n "$rubref" "${idf[@]}" --out "$work/identify_$n" >/dev/null 2>&1 || fail "identify on $n threads"
done
same "identify with output-error refinement (1 vs 2 threads)" "$work/identify_1" "$work/identify_2"

# The main job: continuation, sweeps and identification on 1 and 2 threads (figures aside:
# matplotlib's files carry no rubref numbers beyond the data compared here).
for n in 1 2; do
  "$rubref" reproduce --no-figures --threads $n --out "$work/reproduce_$n" >/dev/null 2>&1 || fail "reproduce on $n threads"
done
same "reproduce (1 vs 2 threads)" "$work/reproduce_1" "$work/reproduce_2"

finish "determinism: all outputs identical"
