#!/usr/bin/env bash
# `rubref study` end to end (docs/studies.md): the same files, byte for byte, from 1 thread, 2
# threads, job-array shards merged (separate folders, or one shared folder), and MPI ranks (when
# built with MPI: $2 is mpiexec); a study killed midway and resumed; bad input refused with one
# line, exit 2 and nothing written.
#   study_cli_test.sh <rubref> [mpiexec]
source "$(dirname "$0")/shell_support.sh"
mpiexec=${2:-}

cat > "$work/map.json" <<'SPEC'
{"study": "regime_map", "name": "test map",
 "grid": [{"name": "clearance_m", "values": [2e-4, 3e-4, 4e-4]}, {"name": "speed_rpm", "from": 1300, "to": 2900, "step": 50}]}
SPEC
cat > "$work/mc.json" <<'SPEC'
{"study": "monte_carlo", "sample": {"count": 12, "seed": 5, "vary": [{"name": "e_m", "normal": [7.06e-5, 4e-6]},
 {"name": "clearance_m", "uniform": [2.5e-4, 3.5e-4]}]}, "job": {"from_rpm": 1200, "to_rpm": 3200}}
SPEC

same() {  # same <what> <reference dir> <dir>: the result files are byte-identical
  for f in points.csv summary.json "${@:4}"; do
    cmp -s "$2/$f" "$3/$f" || fail "$1: $f differs from the single-thread run"
  done
}

for spec in map mc; do
  extra=(); [ $spec = map ] && extra=(folds.csv)
  "$rubref" study "$work/$spec.json" --out "$work/$spec-t1" --threads 1 --no-figures --quiet > /dev/null || fail "$spec: 1 thread"
  "$rubref" study "$work/$spec.json" --out "$work/$spec-t2" --threads 2 --no-figures --quiet > /dev/null || fail "$spec: 2 threads"
  same "$spec, 2 threads" "$work/$spec-t1" "$work/$spec-t2" "${extra[@]}"
  for i in 1 2 3; do
    "$rubref" study "$work/$spec.json" --out "$work/$spec-s$i" --shard $i/3 --quiet > /dev/null || fail "$spec: shard $i/3"
    "$rubref" study "$work/$spec.json" --out "$work/$spec-shared" --shard $i/3 --quiet > /dev/null || fail "$spec: shared shard $i/3"
  done
  [ -e "$work/$spec-s1/points.csv" ] && fail "$spec: a shard wrote the study's results"
  "$rubref" study-merge "$work/$spec-s1" "$work/$spec-s2" "$work/$spec-s3" --out "$work/$spec-merged" --no-figures > /dev/null || fail "$spec: merge"
  same "$spec, shards merged" "$work/$spec-t1" "$work/$spec-merged" "${extra[@]}"
  "$rubref" study-merge "$work/$spec-shared" --no-figures > /dev/null || fail "$spec: merge of a shared folder"
  same "$spec, shards in one folder" "$work/$spec-t1" "$work/$spec-shared" "${extra[@]}"
  if [ -n "$mpiexec" ]; then
    as_root=(); [ "$(id -u)" -eq 0 ] && as_root=(--allow-run-as-root)
    "$mpiexec" "${as_root[@]}" --oversubscribe --mca btl_vader_single_copy_mechanism none -np 2 \
      "$rubref" study "$work/$spec.json" --out "$work/$spec-mpi" --no-figures --quiet > "$work/mpi.log" 2>&1 || { cat "$work/mpi.log"; fail "$spec: mpirun -np 2"; }
    same "$spec, 2 MPI ranks" "$work/$spec-t1" "$work/$spec-mpi" "${extra[@]}"
  fi
done
if [ -n "$mpiexec" ]; then  # bad input under mpirun: rank 0's one line, nothing written
  echo '{"study": "grid", "grid": [{"name": "muu", "values": [0.1]}]}' > "$work/bad-mpi.json"
  "$mpiexec" "${as_root[@]}" --oversubscribe --mca btl_vader_single_copy_mechanism none -np 2 \
    "$rubref" study "$work/bad-mpi.json" --out "$work/nothing" > /dev/null 2> "$work/mpi.err" && fail "mpirun: a bad SPEC exited 0"
  [ "$(grep -c '^rubref: error: ' "$work/mpi.err")" -eq 1 ] || fail "mpirun: not one rubref line for a bad SPEC: $(cat "$work/mpi.err")"
  [ -e "$work/nothing" ] && fail "mpirun: a bad SPEC wrote $work/nothing"
fi

# A loop campaign (rig + loop per point, the noise's seed from the point's stream): the same rows
# from one process and from two shards on one thread each.
cat > "$work/loop.json" <<'SPEC'
{"study": "grid", "grid": [{"name": "effect.preload.F_y", "values": [0, -4]}],
 "job": {"type": "loop", "speeds_rpm": [1200, 1300, 1400, 1550, 1650, 1750], "record_revs": 8}}
SPEC
"$rubref" study "$work/loop.json" --out "$work/loop-t2" --threads 2 --quiet > /dev/null || fail "loop: 2 threads"
for i in 1 2; do "$rubref" study "$work/loop.json" --out "$work/loop-s$i" --shard $i/2 --threads 1 --quiet > /dev/null || fail "loop: shard $i/2"; done
"$rubref" study-merge "$work/loop-s1" "$work/loop-s2" --out "$work/loop-merged" > /dev/null || fail "loop: merge"
same "loop campaign, shards merged" "$work/loop-t2" "$work/loop-merged"
grep -q '"named_exactly": 2' "$work/loop-t2/summary.json" || fail "loop: the campaign did not name none and preload: $(grep -A3 campaign "$work/loop-t2/summary.json")"

# Figures of the kinds (matplotlib): PNG and SVG.
"$rubref" study "$work/map.json" --out "$work/map-t1" --quiet > /dev/null || fail "map: figures"
for f in regime_map.png regime_map.svg; do [ -s "$work/map-t1/$f" ] || fail "map: no $f"; done

# Resume: a journal cut in the middle of a row (a killed run) is completed, to the same bytes.
mkdir "$work/cut"
cp "$work/map-t1/spec.json" "$work/cut/"
head -c 3000 "$work/map-t1/rows-1-of-1.csv" > "$work/cut/rows-1-of-1.csv"
"$rubref" study "$work/map.json" --out "$work/cut" --no-figures > /dev/null 2> "$work/resume.err" || fail "resume after a cut journal"
grep -q "resumed" "$work/resume.err" || fail "resume: no 'resumed' on stderr: $(cat "$work/resume.err")"
same "resumed after a cut" "$work/map-t1" "$work/cut" folds.csv

# Resume after a real kill (SIGTERM midway: a background job ignores SIGINT; one thread, rows
# journalled 64 at a time).
cat > "$work/big.json" <<'SPEC'
{"study": "grid", "grid": [{"name": "clearance_m", "values": [2e-4, 3e-4]}, {"name": "speed_rpm", "from": 1300, "to": 2900, "step": 4}],
 "job": {"start": "rest", "settle_revs": 150}}
SPEC
"$rubref" study "$work/big.json" --out "$work/big-ref" --threads 2 --quiet > /dev/null || fail "big: reference"
"$rubref" study "$work/big.json" --out "$work/big" --threads 1 --quiet > /dev/null 2>&1 &
pid=$!
for _ in $(seq 1 200); do
  [ "$(wc -l < "$work/big/rows-1-of-1.csv" 2> /dev/null || echo 0)" -ge 100 ] && break
  sleep 0.05
done
kill -TERM $pid 2> /dev/null
wait $pid
status=$?
rows=$(($(wc -l < "$work/big/rows-1-of-1.csv") - 2))
if [ $status -eq 143 ]; then
  [ -e "$work/big/points.csv" ] && fail "kill: results written by an interrupted study"
  [ $rows -ge 64 ] && [ $rows -lt 802 ] || fail "kill: $rows rows journalled before the interrupt"
else
  echo "note: the study finished before the interrupt (status $status); the resume is then a no-op"
fi
"$rubref" study "$work/big.json" --out "$work/big" --threads 2 --quiet > /dev/null || fail "kill: resume"
same "resumed after SIGTERM" "$work/big-ref" "$work/big"

# Bad input: one line naming the problem, exit 2, nothing written.
bad() {  # bad <expected text> <args...>
  local expected=$1
  shift
  "$rubref" "$@" > "$work/out.txt" 2> "$work/err.txt"
  local rc=$?
  [ $rc -eq 2 ] || fail "$*: exit $rc, expected 2"
  [ "$(wc -l < "$work/err.txt")" -eq 1 ] || fail "$*: stderr is not one line: $(cat "$work/err.txt")"
  grep -qF -- "$expected" "$work/err.txt" || fail "$*: expected '$expected' in: $(cat "$work/err.txt")"
  [ -e "$work/nothing" ] && fail "$*: wrote $work/nothing"
}
echo '{"study": "regime_map", "grid": [{"name": "clearance_m", "values": [3e-4]}, {"name": "speed_rpm", "fro": 1, "to": 2, "count": 2}]}' > "$work/typo.json"
bad "key 'grid[1].fro': unknown key; did you mean 'from'" study "$work/typo.json" --out "$work/nothing"
echo '{"study": "grid", "grid": [{"name": "mu", "values": [0.1, "x"]}]}' > "$work/type.json"
bad "key 'grid[0].values[1]': must be a number" study "$work/type.json" --out "$work/nothing"
echo '{"study": ' > "$work/trunc.json"
bad "not JSON" study "$work/trunc.json" --out "$work/nothing"
bad "no such file" study "$work/missing.json" --out "$work/nothing"
bad "--shard must be i/N" study "$work/map.json" --out "$work/nothing" --shard 4/3
bad "holds another study" study "$work/mc.json" --out "$work/map-t1"
bad "points have no row" study-merge "$work/map-s1" "$work/map-s2" --out "$work/nothing"
bad "holds another study" study-merge "$work/map-s1" "$work/mc-s2" --out "$work/nothing"

finish "study: 1 thread = 2 threads = shards merged = shared folder${mpiexec:+ = 2 MPI ranks}; a loop campaign sharded; resumed after a cut and a kill; bad input refused"
