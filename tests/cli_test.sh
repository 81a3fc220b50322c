#!/usr/bin/env bash
# The CLI as a user meets it: a bad input gives exit code 2, exactly one line on stderr naming
# the problem, and no output file (an existing one is left untouched).
source "$(dirname "${BASH_SOURCE[0]}")/shell_support.sh"

# expect_error <expected-substring> <args...>
expect_error() {
  local want=$1; shift
  "$rubref" "$@" >"$work/stdout" 2>"$work/stderr"
  local rc=$?
  local lines; lines=$(wc -l <"$work/stderr")
  [ "$rc" -eq 2 ] || fail "exit $rc (want 2) for: $*"
  [ "$lines" -eq 1 ] || fail "$lines stderr lines (want 1) for: $*: $(cat "$work/stderr")"
  grep -qF -- "$want" "$work/stderr" || fail "stderr lacks '$want' for: $*: $(cat "$work/stderr")"
  [ ! -e "$work/o.csv" ] || fail "output written for: $*"
  ls "$work" | grep -q '\.tmp-' && fail "temporary left behind for: $*"
}

out=(--out "$work/o.csv" --revs 1 --settle-revs 1)
expect_error "m_kg" simulate --m -1 "${out[@]}"
expect_error "k_y_N_m" simulate --k-y 0 "${out[@]}"
expect_error "clearance_m" simulate --clearance -3e-4 "${out[@]}"
expect_error "parameter r" simulate --r 1.2 "${out[@]}"
expect_error "mu" simulate --mu -0.1 "${out[@]}"
expect_error "e_m" simulate --e nan "${out[@]}"
expect_error "k1_N_m" simulate --k1 inf "${out[@]}"
expect_error "--rpm must be finite and in (0, 1e+06]" simulate --rpm 0 "${out[@]}"
expect_error "unknown variant 'hertz'" simulate --variant hertz "${out[@]}"
expect_error "unknown stepper 'euler'" simulate --stepper euler "${out[@]}"
expect_error "--bogus" simulate --bogus 1 "${out[@]}"
expect_error "--out" simulate --revs 1
expect_error "rpm" simulate --rpm fast "${out[@]}"
echo '{"k1_N_m": 1e6, "kone": 2}' >"$work/p.json"
expect_error "unknown parameter 'kone'" simulate --params "$work/p.json" "${out[@]}"
echo '{"k1_N_m": ' >"$work/broken.json"
expect_error "broken.json" simulate --params "$work/broken.json" "${out[@]}"
expect_error "does not exist" simulate --out "$work/no/such/dir/o.csv" --revs 1 --settle-revs 1
# Numerically dangerous: a 1e-30 kg rotor (rate c/m ~ 1.5e31 1/s) is refused before integrating.
expect_error "m_kg = 1e-30" simulate --m 1e-30 "${out[@]}"
expect_error "numerically dangerous parameters: sqrt(k1/m)" simulate --k1 1e30 "${out[@]}"
expect_error "numerically dangerous parameters: sqrt(k1/m)" rig --k1 1e30 --out "$work/o.csv"
printf '{\n  "m_kg": 1.52,\n  "mu": "0.2"\n}\n' >"$work/pm.json"
expect_error "pm.json:3: parameter 'mu' is not a number" simulate --params "$work/pm.json" "${out[@]}"
printf '{\n  "k1_N_m": 0\n}\n' >"$work/pk.json"
expect_error "pk.json:2: parameter k1_N_m must be finite and > 0" simulate --params "$work/pk.json" "${out[@]}"
# A fixed step beyond rk4's stability for the rotor's fastest mode is refused before integrating.
expect_error "dt = 1 s is beyond rk4's stability for this rotor: sqrt(k1/m) * dt" simulate --stepper rk4 --dt 1 "${out[@]}"
expect_error "sqrt(k_y/m) * dt" simulate --variant restitution --stepper rk4 --dt 0.02 "${out[@]}"
# Numbers in JSON are numbers.
"$rubref" sweep --from 1580 --to 1600 --step 20 --first-settle-revs 5 --settle-revs 5 --revs 6 --out "$work/json_sweep" >/dev/null \
  || fail "short sweep failed"
/usr/bin/python3 -c "import json,sys; s=json.load(open(sys.argv[1]))['settings']; sys.exit(0 if isinstance(s['rtol'], float) and isinstance(s['clearance_m'], float) else 1)" \
  "$work/json_sweep/summary.json" || fail "sweep summary.json settings hold numbers as text"
rm -rf "$work/json_sweep"
# A coarse fixed step through contact runs, but warns with the time (stderr), exit 0.
"$rubref" simulate --stepper rk4 --dt 3e-4 --revs 2 --settle-revs 20 --out "$work/coarse.csv" >/dev/null 2>"$work/stderr" \
  || fail "coarse rk4 run failed"
grep -q "^warning: .* crossed a contact at rate \* dt up to .* first at t = " "$work/stderr" || fail "no coarse-contact warning: $(cat "$work/stderr")"
grep -q '"coarse_contact_steps"' "$work/coarse.summary.json" || fail "summary lacks coarse_contact_steps"
rm -f "$work/coarse.csv" "$work/coarse.summary.json"
# A sweep says at which speed its first under-resolved contact step was (the time is within that run).
"$rubref" sweep --stepper rk4 --dt 3e-4 --from 1580 --to 1620 --step 20 --first-settle-revs 20 --settle-revs 5 --direction up \
  --out "$work/coarse_sweep" >/dev/null 2>"$work/stderr" || fail "coarse rk4 sweep failed"
grep -q "^up branch, first at 1[56][0-9]0 rpm: warning: " "$work/stderr" || fail "sweep warning lacks the speed: $(cat "$work/stderr")"
grep -q '"first_coarse_contact_rpm"' "$work/coarse_sweep/summary.json" || fail "sweep summary lacks first_coarse_contact_rpm"
rm -rf "$work/coarse_sweep"
# A sweep started on the shot orbits says how many of its points were.
"$rubref" sweep --from 1580 --to 1620 --step 20 --start-from-orbit --out "$work/orbit_sweep" >/dev/null || fail "sweep --start-from-orbit failed"
grep -q '"orbit_starts": [1-9]' "$work/orbit_sweep/summary.json" || fail "sweep --start-from-orbit started no point on an orbit"
rm -rf "$work/orbit_sweep"

# A failed run never replaces an existing result.
echo keep >"$work/existing.csv"
"$rubref" simulate --m -1 --out "$work/existing.csv" 2>/dev/null
[ "$(cat "$work/existing.csv")" = keep ] || fail "existing output overwritten by a failed run"

# A good run writes the record and its summary; flags override the parameter file.
echo '{"k1_N_m": 5e6, "clearance_m": 2e-4}' >"$work/p.json"
"$rubref" simulate --variant piecewise-linear --params "$work/p.json" --clearance 2.5e-4 --revs 2 --settle-revs 20 \
  --samples-per-rev 16 --out "$work/good.csv" >/dev/null || fail "good run failed"
grep -qE '^# k1_N_m: (5e\+06|5000000)$' "$work/good.csv" || fail "parameter file not applied"
grep -q '^# clearance_m: 0.00025$' "$work/good.csv" || fail "flag did not override the file"
grep -q '^t_s,x_m,y_m,speed_rpm,vx_m_s,vy_m_s,fn_N$' "$work/good.csv" || fail "header"
[ "$(grep -vc '^#' "$work/good.csv")" -eq 33 ] || fail "expected header + 32 rows"
grep -q '"whirl"' "$work/good.summary.json" || fail "summary JSON"

"$rubref" --help >/dev/null || fail "--help"
# A command line that names a command builds only that command (ref/cli/main.cpp): every other
# route still knows them all.
for cmd in reproduce simulate orbit continuation sweep identify rig effects loop study study-merge validate params variants; do
  "$rubref" --help | grep -q "^  $cmd " || fail "--help does not list $cmd"
done
"$rubref" --version | grep -q "^rubref " || fail "--version"
"$rubref" effects >/dev/null || fail "effects (added with rig)"
"$rubref" study-merge --help >/dev/null || fail "study-merge --help (added with study)"
expect_error "did you mean 'simulate'" simluate --out "$work/o.csv"
# A mistyped command is named as such, whatever options and files follow it.
expect_error "unknown command 'simluate'; did you mean 'simulate'?" simluate --rpm 1600 --out "$work/o.csv"
expect_error "unknown command 'idnetify'; did you mean 'identify'?" idnetify "$work/x.csv" --out "$work/d"
# Help shows a flag as itself, not CLI11's default of a negated flag ("--no-figures{false}").
for cmd in loop reproduce identify; do
  "$rubref" $cmd --help >"$work/stdout" || fail "$cmd --help"
  grep -qE '\{(false|true)\}' "$work/stdout" && fail "$cmd --help shows a flag's default: $(grep -E '\{(false|true)\}' "$work/stdout")"
done
"$rubref" loop --help | grep -qE -- '^  --no-figures +write the report without drawing figures$' || fail "loop --help lacks --no-figures and its text"
"$rubref" reproduce --help | grep -qE -- '^  --no-figures +write data and report only' || fail "reproduce --help lacks --no-figures and its text"
"$rubref" simulate --help | grep -q -- "--k1" || fail "simulate --help lists parameters"

# sweep: tables, waterfalls, summary; a folder rubref made is replaced, any other is refused.
sw=(sweep --from 1590 --to 1610 --step 10 --first-settle-revs 20 --settle-revs 10)
"$rubref" "${sw[@]}" --orbits --out "$work/sw" >/dev/null || fail "sweep failed"
for f in sweep.csv waterfall_up.csv waterfall_down.csv summary.json orbits/up_1600rpm.csv .rubref-output; do
  [ -s "$work/sw/$f" ] || fail "sweep did not write $f"
done
[ "$(grep -vc '^#' "$work/sw/sweep.csv")" -eq 7 ] || fail "sweep.csv: expected header + 6 rows"
grep -q '"hysteresis_bands_rpm"' "$work/sw/summary.json" || fail "sweep summary lacks the jump report"
"$rubref" "${sw[@]}" --direction up --out "$work/sw" >/dev/null || fail "sweep could not replace its own output"
[ ! -e "$work/sw/waterfall_down.csv" ] || fail "replaced sweep output kept a stale file"
mkdir "$work/mine" && echo precious >"$work/mine/notes.txt"
expect_error "was not made by rubref" "${sw[@]}" --out "$work/mine"
[ "$(cat "$work/mine/notes.txt")" = precious ] || fail "sweep touched a folder it did not make"
rm -rf "$work/mine"
# An empty folder made for the output is filled; the current folder is never replaced (the shell
# would be left in a deleted one).
mkdir "$work/empty"
"$rubref" "${sw[@]}" --direction up --out "$work/empty" >/dev/null || fail "sweep refused an empty folder"
[ -s "$work/empty/sweep.csv" ] && [ -e "$work/empty/.rubref-output" ] || fail "sweep did not fill the empty folder"
mkdir "$work/here"
(cd "$work/here" && "$rubref" "${sw[@]}" --out . >/dev/null 2>"$work/stderr") && fail "sweep replaced the current folder"
grep -q "holds the current folder" "$work/stderr" || fail "--out . not refused as the current folder: $(cat "$work/stderr")"
[ -d "$work/here" ] || fail "--out . removed the current folder"
rm -rf "$work/empty" "$work/here"
expect_error "multiple of 6" "${sw[@]}" --revs 10 --out "$work/sw2"

# An interrupted run (killed mid-sweep, no chance to clean up) leaves the earlier result whole.
cp -r "$work/sw" "$work/sw_before"
long_sweep=(sweep --from 1400 --to 1800 --step 1 --settle-revs 300)  # ~15 s: killed after 1 s
"$rubref" "${long_sweep[@]}" --out "$work/sw" >/dev/null 2>&1 &
sleep 1
kill -KILL $! 2>/dev/null
wait $! 2>/dev/null
diff -r "$work/sw_before" "$work/sw" >/dev/null || fail "a killed sweep changed the existing output"
"$rubref" "${long_sweep[@]}" --out "$work/sw_new" >/dev/null 2>&1 &
sleep 1
kill -KILL $! 2>/dev/null
wait $! 2>/dev/null
[ ! -e "$work/sw_new" ] || fail "a killed sweep left a partial output folder"
rm -rf "$work"/sw.tmp-* "$work"/sw_new.tmp-* "$work"/sw_before  # a killed run cannot clean up its staging
expect_error "--direction" "${sw[@]}" --direction sideways --out "$work/sw2"

# identify: on a sweep's multi-dwell record, with the linear part given.
"$rubref" sweep --from 1550 --to 1650 --step 50 --samples-per-rev 512 --direction up --orbits --out "$work/id_sw" >/dev/null \
  || fail "sweep for identify failed"
"$rubref" params >"$work/paper.json"
"$rubref" identify "$work/id_sw/record_up.csv" --linear "$work/paper.json" --out "$work/id" >/dev/null || fail "identify failed"
grep -q '"term": "z1"' "$work/id/identification.json" || fail "identify did not keep z"
grep -q "Table 1" "$work/id/identification.md" || fail "identification.md lacks Table 1"
printf 't_s,x_m,y_m,speed_rpm\n0,0,0,1500\n1,0,0,1500\n' >"$work/short.csv"
expect_error "short.csv" identify "$work/short.csv" --clearance 3e-4 --out "$work/id2"
printf 't_s,x_m,y_m,speed_rpm\n0,0,zero,1500\n' >"$work/bad.csv"
expect_error "bad.csv:2: column 'y_m'" identify "$work/bad.csv" --out "$work/id2"
printf 'time,x,y,rpm\n0,0,0,1500\n' >"$work/header.csv"
expect_error "header.csv:1: header 'time,x,y,rpm' must start with t_s,x_m,y_m,speed_rpm" identify "$work/header.csv" --out "$work/id2"
printf 't_s,x_m,y_m,speed_rmp\n0,0,0,1500\n' >"$work/header.csv"
expect_error "column 4 is 'speed_rmp'; did you mean 'speed_rpm'?" loop "$work/header.csv" --out "$work/id2"
# Millimetres under metre columns (an orbit of tens of centimetres): identify and the loop refuse
# the record with the conversion before any work, leave no output, and an empty folder as it was.
"$rubref" rig --speeds 1500,1600 --revs 6 --settle-revs 30 --out "$work/rig_m.csv" >/dev/null || fail "rig (for a record in mm) failed"
awk -F, -v OFS=, '/^#/ || /^t_s/ { print; next } { $2 *= 1000; $3 *= 1000; print }' "$work/rig_m.csv" >"$work/rig_mm.csv"
expect_error "if the file holds millimetres, divide x_m and y_m by 1000" identify "$work/rig_mm.csv" --out "$work/id_mm"
grep -qE "rig_mm.csv:[0-9]+: [xy]_m reaches -?[0-9.]+ m, and no rotor kit's shaft moves 10 mm or more" "$work/stderr" \
  || fail "identify on a record in mm: $(cat "$work/stderr")"
[ ! -e "$work/id_mm" ] || fail "identify on a record in mm left an output folder"
mkdir "$work/loop_mm"
expect_error "if the file holds millimetres, divide x_m and y_m by 1000" loop "$work/rig_mm.csv" --no-figures --out "$work/loop_mm"
[ -d "$work/loop_mm" ] && [ -z "$(ls -A "$work/loop_mm")" ] || fail "a failed loop did not leave the empty folder as it was"
rm -rf "$work/loop_mm" "$work"/rig_m*.csv "$work/rig_m.truth.json" "$work/header.csv"
# The re-identification's parameters are checked before any work, by their one name.
expect_error "re-identification: unknown parameter 'delta' (k1, k3, c2, mu, e, clearance)" identify "$work/id_sw/record_up.csv" --reidentify --reid-fit k1,delta --out "$work/id2"
expect_error "unknown parameter 'clearnce'; did you mean 'clearance'?" identify "$work/id_sw/record_up.csv" --reidentify --reid-fit clearnce --out "$work/id2"
expect_error "library term 'w2'" identify "$work/id_sw/record_up.csv" --linear "$work/paper.json" --library z1,w2 --out "$work/id2"
grep -v '^# clearance_m' "$work/id_sw/record_up.csv" >"$work/no_clearance.csv"
expect_error "no clearance_m" identify "$work/no_clearance.csv" --linear "$work/paper.json" --out "$work/id2"

# orbit: shooting writes one period and its Floquet multipliers; bad periods are refused.
"$rubref" orbit --rpm 1600 --samples-per-rev 64 --out "$work/orb.csv" >"$work/stdout" || fail "orbit failed"
grep -q '"method": "shooting"' "$work/orb.summary.json" || fail "orbit did not shoot: $(cat "$work/orb.summary.json")"
grep -q '"floquet_multipliers"' "$work/orb.summary.json" || fail "orbit summary lacks the multipliers"
grep -q '"stable": true' "$work/orb.summary.json" || fail "the paper's 1600 rpm orbit is not stable"
[ "$(grep -vc '^#' "$work/orb.csv")" -eq 65 ] || fail "orbit.csv: expected header + 64 rows"
expect_error "periods must be a whole number in [1, 64]" orbit --periods 0 --out "$work/o.csv"
expect_error "--tolerance must be finite and > 0 m (got -1)" orbit --tolerance -1 --out "$work/o.csv"
# continuation: a branch with its special points; bad ranges and parameters refused.
"$rubref" continuation --from 1380 --to 1460 --clearance 3e-4 --out "$work/branch" >"$work/stdout" || fail "continuation failed"
for f in branch.csv summary.json; do [ -s "$work/branch/$f" ] || fail "continuation did not write $f"; done
grep -q '"reached_end": true' "$work/branch/summary.json" || fail "continuation stopped early: $(cat "$work/branch/summary.json")"
python3 -c 'import json, sys; j = json.load(open(sys.argv[1])); assert len(j["grazings"]) == 1 and j["grazings"][0]["located"]' \
  "$work/branch/summary.json" || fail "continuation did not locate the grazing at 0.3 mm"
head -c 3 "$work/branch/branch.csv" | grep -q '^# ' || fail "branch.csv lacks its provenance header"
# A branch row restarts its orbit: rpm and state of the last (rubbing) point.
read -r rpm x0 y0 vx0 vy0 < <(python3 -c 'import csv, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#"))]
r = rows[-1]; print(r["speed_rpm"], r["x0_m"], r["y0_m"], r["vx0_m_s"], r["vy0_m_s"])' "$work/branch/branch.csv")
"$rubref" orbit --rpm "$rpm" --initial "$x0" "$y0" "$vx0" "$vy0" --clearance 3e-4 --out "$work/row.csv" >/dev/null \
  || fail "orbit from a branch row failed"
grep -q '"start": "given state"' "$work/row.summary.json" || fail "orbit did not start from --initial"
grep -q '"newton_iterations": 1,' "$work/row.summary.json" || fail "a branch point is not already an orbit: $(cat "$work/row.summary.json")"
expect_error "from < to" continuation --from 1500 --to 1500 --out "$work/o.csv"
expect_error "from < to" continuation --from 2200 --to 1300 --out "$work/o.csv"
expect_error "--direction" continuation --direction sideways --out "$work/o.csv"
expect_error "--parameter mu needs --from and --to" continuation --parameter mu --out "$work/o.csv"
expect_error "unknown continuation parameter 'rpm'" continuation --parameter rpm --out "$work/o.csv"
expect_error "clearance_m" continuation --parameter clearance --from -1e-4 --to 3e-4 --out "$work/o.csv"

# rig and loop: bad effects and records named; a record without rub is not a loop's input.
expect_error "unknown effect 'gravity'" rig --effect gravity --out "$work/o.csv"
expect_error "k_h = -1" rig --effect hertz_contact:k_h=-1 --out "$work/o.csv"
expect_error "--time-base must be acquisition or shaft" rig --time-base ticks --out "$work/o.csv"
expect_error "needs shaft-synchronous time" rig --no-keyphasor --time-base acquisition --out "$work/o.csv"
"$rubref" rig --clearance 1 --speeds 1200,1300 --revs 4 --settle-revs 20 --out "$work/free.csv" >/dev/null || fail "rig failed"
grep -q '^# clearance_m: 1$' "$work/free.csv" || fail "rig record lacks its clearance"
grep -q 'effects' "$work/free.csv" && fail "rig record names its effects"
expect_error "no dwell reaches its clearance" loop "$work/free.csv" --out "$work/loop"
expect_error "short.csv" loop "$work/short.csv" --clearance 3e-4 --out "$work/loop"
# The loop's and identification's settings are checked by their registry rows (issue 62), the
# message naming the flag, before any work.
expect_error "--max-effects must be a whole number in [0, 11]" loop "$work/free.csv" --max-effects 12 --out "$work/loop"
expect_error "--bootstrap must be a whole number in [0, 1e+05]" identify "$work/free.csv" --bootstrap -1 --out "$work/loop"
expect_error "--rho must be finite and in [0, 1)" identify "$work/free.csv" --rho 1 --out "$work/loop"
[ ! -e "$work/loop" ] || fail "loop left a report behind"
# A drive that does not hold its speed: every dwell is left out with its reason, and the loop says
# it had nothing to score (no NaN error) and that the residual is unexplained.
"$rubref" rig --speed-fluctuation 0.01 --fluctuation-hz 3 --speeds 1550,1650 --revs 6 --settle-revs 30 --out "$work/drift.csv" >/dev/null || fail "rig (drift) failed"
"$rubref" loop "$work/drift.csv" --out "$work/drift" >"$work/stdout" 2>"$work/stderr" || fail "loop (drift) failed: $(cat "$work/stderr")"
grep -q "no dwell with contact was usable" "$work/stdout" || fail "loop (drift) does not say nothing was usable: $(cat "$work/stdout")"
grep -qiw "nan" "$work/stdout" "$work/drift/report.md" && fail "loop (drift) printed a NaN"
grep -q "residual unexplained" "$work/stdout" || fail "loop (drift) did not call the residual unexplained"
grep -q "left out: not periodic" "$work/stderr" || fail "loop (drift) did not say why the dwells were left out"
rm -rf "$work/drift" "$work/drift.csv"
# Order-tracked tables (docs/real-data.md): an undeclared convention is one line naming what to
# declare, nothing is written; conventions of a table are refused for a time record.
printf 'rpm,amp_1x,phase_1x_deg\n1000,0.1,10\n' >"$work/table.csv"
expect_error "the amplitude convention is not declared: give it (--amplitude" loop "$work/table.csv" --out "$work/loop"
expect_error "the phase convention is not declared" loop "$work/table.csv" --amplitude pk-pk --out "$work/loop"
expect_error "column 'amp_1x' has no unit: declare it (--amplitude-unit" loop "$work/table.csv" --amplitude pk-pk --phase lag --out "$work/loop"
expect_error "--probe-angle 'north': expected DEG or NAME=DEG" loop "$work/table.csv" --probe-angle north --out "$work/loop"
expect_error "an order-tracked table is fitted alone" loop "$work/table.csv" "$work/free.csv" --out "$work/loop"
expect_error "describe an order-tracked table" loop "$work/free.csv" --amplitude rms --out "$work/loop"
expect_error "is an order-tracked table" loop "$work/table.csv" --mass 2 --out "$work/loop"
printf 'rpm,amp_1x_um,phase_1x_deg\n' >"$work/flat.csv"
for i in $(seq 1 20); do echo "1500,1.$i,1$i" >>"$work/flat.csv"; done
expect_error "needs rows at more than one speed" loop "$work/flat.csv" --amplitude rms --phase lag --out "$work/loop"
[ ! -e "$work/loop" ] || fail "loop on a bad table left a report behind"
# A table of the closed form's 1X (an isotropic rotor: 160 rad/s, damping ratio 0.03, e 5 um, runout
# 1 um, in mils pk-pk and lagging phase): fitted, nothing added, the critical speed in report.json.
/usr/bin/python3 "$(dirname "${BASH_SOURCE[0]}")/closed_form_table.py" "$work/table.csv" mil-pkpk-lag
"$rubref" loop "$work/table.csv" --amplitude pk-pk --phase lag --amplitude-unit mil --no-figures --out "$work/tracked" >"$work/stdout" 2>"$work/stderr" \
  || fail "loop on a table failed: $(cat "$work/stderr")"
grep -q "effects: none; residual is noise" "$work/stdout" || fail "loop on a noise-free isotropic table: $(cat "$work/stdout")"
# 1e-6: a noise-free table, fitted to its own rounding; the fit's stopping rule is far finer.
/usr/bin/python3 -c "import json,sys,math; m=json.load(open(sys.argv[1]))['modes']; sys.exit(0 if len(m)==1 and abs(m[0]['critical_speed_rpm']-160*30/math.pi)<1e-6*160*30/math.pi else 1)" \
  "$work/tracked/report.json" || fail "loop on a table: critical speed not the closed form's"
rm -rf "$work/tracked" "$work/table.csv"

# Outputs are checked before any work: a file rubref did not write is not replaced (unless
# --force), an input is never an output, a missing folder is named, and the loop refuses its
# folder before it starts working (no progress lines, just the error).
printf 'my own notes\n' >"$work/notes.csv"
expect_error "notes.csv: exists and was not written by rubref" simulate --revs 1 --settle-revs 1 --out "$work/notes.csv"
grep -q "my own notes" "$work/notes.csv" || fail "a file rubref did not write was replaced"
"$rubref" simulate --revs 1 --settle-revs 1 --force --out "$work/notes.csv" >/dev/null || fail "--force did not replace the file"
"$rubref" simulate --revs 1 --settle-revs 1 --out "$work/notes.csv" >/dev/null || fail "rubref's own output was not replaced"
rm -f "$work/notes.csv" "$work/notes.summary.json"
"$rubref" params >"$work/p.json"
expect_error "is also an input of this run" simulate --params "$work/p.json" --revs 1 --settle-revs 1 --out "$work/p.json"
expect_error "directory $work/none does not exist" orbit --out "$work/none/o.csv"
expect_error "parent directory $work/none does not exist" loop "$work/free.csv" --out "$work/none/loop"

# Friendlier intake: a mistyped name gets the nearest one; a bad RUBREF_THREADS is refused before
# any work; bare `rubref` shows what it can do; a clearance typed in millimetres is warned about.
expect_error "unknown variant 'identifed'; did you mean 'identified'?" simulate --variant identifed "${out[@]}"
expect_error "did you mean 'simulate'?" simulat
expect_error "did you mean '--rpm'?" simulate --rmp 1600 "${out[@]}"
expect_error "unknown effect 'hertz_contactt'; did you mean 'hertz_contact'?" rig --effect hertz_contactt --out "$work/o.csv"
RUBREF_THREADS=abc expect_error "RUBREF_THREADS must be a whole number from 1 to 4096 (got 'abc')" rig --out "$work/o.csv"
"$rubref" >"$work/stdout" 2>&1 || fail "bare rubref failed"
grep -q "reproduce" "$work/stdout" || fail "bare rubref does not list the commands: $(head -3 "$work/stdout")"
"$rubref" simulate --clearance 0.3 --revs 1 --settle-revs 1 --out "$work/mm.csv" >/dev/null 2>"$work/stderr" || fail "a large clearance was refused"
grep -q "warning: clearance_m = 0.3 m is larger than any rotor kit's; if millimetres were meant, 0.3 mm is 0.0003 m" "$work/stderr" \
  || fail "no warning for a clearance of 0.3 m: $(cat "$work/stderr")"
rm -f "$work/mm.csv" "$work/mm.summary.json"

# An interrupted run removes its unfinished output and dies of the signal (128 + signal): SIGTERM,
# and SIGINT (Ctrl-C) with job control on, as in a terminal (a background job of a script ignores it).
# The signal is sent once the run's staging folder exists (its handler is in place by then): on a
# loaded machine that can take many seconds, so the wait is by the clock (up to 120 s), and a run
# that never makes one is a failure of its own, not a signal sent too early.
staging_of() {  # staging_of <pid>: waits for interrupted.tmp-*; false if it never comes or the run ended
  local deadline=$((SECONDS + 120))
  while [ "$SECONDS" -lt "$deadline" ]; do
    ls -d "$work"/interrupted.tmp-* >/dev/null 2>&1 && return 0
    kill -0 "$1" 2>/dev/null || return 1
    sleep 0.05
  done
  return 1
}
for sig in TERM INT; do
  set -m
  "$rubref" reproduce --no-figures --out "$work/interrupted" 2>"$work/stderr" >/dev/null &
  pid=$!
  set +m
  staging_of "$pid" || fail "SIG$sig: reproduce made no staging folder within 120 s: $(cat "$work/stderr")"
  kill -"$sig" "$pid"
  wait "$pid"
  rc=$?
  want=$((128 + $(kill -l "$sig")))
  [ "$rc" -eq "$want" ] || fail "SIG$sig: exit $rc (want $want): $(cat "$work/stderr")"
  ls -d "$work"/interrupted* >/dev/null 2>&1 && fail "SIG$sig left $(ls -d "$work"/interrupted*)"
  grep -q "interrupted" "$work/stderr" || fail "SIG$sig: no message: $(cat "$work/stderr")"
done
# Interrupted, a run into an empty folder leaves the folder, empty.
mkdir "$work/interrupted"
"$rubref" reproduce --no-figures --out "$work/interrupted" 2>"$work/stderr" >/dev/null &
pid=$!
staging_of "$pid" || fail "SIGTERM into an empty folder: reproduce made no staging folder within 120 s: $(cat "$work/stderr")"
kill -TERM "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 143 ] || fail "SIGTERM into an empty folder: exit $rc (want 143): $(cat "$work/stderr")"
[ -d "$work/interrupted" ] && [ -z "$(ls -A "$work/interrupted")" ] || fail "SIGTERM: the empty folder was not left as it was"
ls -d "$work"/interrupted.* >/dev/null 2>&1 && fail "SIGTERM into an empty folder left $(ls -d "$work"/interrupted.*)"

finish "cli_test: all passed"
