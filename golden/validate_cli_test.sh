#!/usr/bin/env bash
# `rubref validate` as a user meets it: exit 0 on a pass, 1 on a failure (with the worst sample
# and its causes), 2 with one line on stderr for a single file it cannot compare, text on stdout
# and JSON with --json; directories list unmatched files (--strict fails on them) and carry on
# past a malformed file, whose case is an error, with the JSON always written.
set -u
rubref=$1
golden=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

case=identified_0.3mm_1600rpm.csv

# The golden file as its own candidate passes.
"$rubref" validate --case "$golden/$case" --candidate "$golden/$case" --json "$work/same.json" >"$work/out" 2>"$work/err"
[ $? -eq 0 ] || fail "a golden file does not pass against itself: $(cat "$work/out" "$work/err")"
grep -q "^result    PASS" "$work/out" || fail "no PASS line: $(cat "$work/out")"
grep -q '"pass": true' "$work/same.json" || fail "JSON lacks pass: true"
grep -q '"max_error_m": 0' "$work/same.json" || fail "JSON orbit error of a file against itself is not 0"

# x moved by 1 um everywhere: fails with exit 1, naming the worst sample.
awk -F, 'BEGIN { OFS = "," } /^#/ || /^t_s/ { print; next } { $2 = $2 + 1e-6; print }' "$golden/$case" >"$work/$case"
"$rubref" validate --case "$golden/$case" --candidate "$work/$case" --json "$work/moved.json" >"$work/out" 2>"$work/err"
[ $? -eq 1 ] || fail "a moved orbit did not exit 1"
grep -q "^result    FAIL" "$work/out" || fail "no FAIL line: $(cat "$work/out")"
grep -q "max error 1e-06 m" "$work/out" || fail "worst error not reported as 1e-06 m: $(grep orbit "$work/out")"
grep -q '"failed": 1' "$work/moved.json" || fail "JSON lacks failed: 1"
/usr/bin/python3 -c "import json,sys; c=json.load(open(sys.argv[1]))['cases'][0]['causes'][0]; sys.exit(not (c['code']=='static_offset' and c['confidence']=='confirmed' and abs(c['fitted']['offset_x_m']-1e-6)<1e-10))" "$work/moved.json" ||
  fail "a moved orbit's first cause is not a confirmed static_offset of 1e-6 m: $(grep -A3 '"causes"' "$work/moved.json")"

# Directories: every case with a candidate of the same name; the rest are skipped.
mkdir "$work/dir"
cp "$golden/$case" "$golden/restitution_0.3mm_1650rpm.csv" "$work/dir/"
"$rubref" validate --case "$golden" --candidate "$work/dir" >"$work/out" 2>"$work/err"
[ $? -eq 0 ] || fail "directory validation failed: $(tail -3 "$work/out") $(cat "$work/err")"
ncases=$(ls "$golden"/*.csv | wc -l)
grep -q "validated 2 case(s): 2 passed, 0 failed, $((ncases - 2)) without a candidate (skipped)" "$work/out" || fail "directory summary: $(tail -1 "$work/out")"

# A candidate named like no case is listed; --strict fails on it.
cp "$golden/$case" "$work/dir/identified_0.3mm_1600rpm_v2.csv"
"$rubref" validate --case "$golden" --candidate "$work/dir" >"$work/out" 2>"$work/err"
[ $? -eq 0 ] || fail "an unmatched file failed the batch without --strict"
grep -q "^unmatched 1 candidate file(s) named like no case: identified_0.3mm_1600rpm_v2.csv" "$work/out" || fail "unmatched file not listed: $(tail -2 "$work/out")"
"$rubref" validate --case "$golden" --candidate "$work/dir" --strict >"$work/out" 2>"$work/err"
[ $? -eq 1 ] || fail "--strict did not fail on an unmatched file"

# A malformed candidate is its case's error; the other cases are still compared, and the JSON written.
printf 't_s,x_m,y_m,speed_rpm\n0,0,zero,1600\n' >"$work/dir/restitution_0.3mm_1650rpm.csv"
"$rubref" validate --case "$golden" --candidate "$work/dir" --json "$work/batch.json" >"$work/out" 2>"$work/err"
rc=$?
[ "$rc" -eq 2 ] || fail "a batch with a malformed file exited $rc (want 2)"
grep -q "validated 2 case(s): 1 passed, 0 failed, 1 could not be compared" "$work/out" || fail "batch summary: $(grep validated "$work/out")"
/usr/bin/python3 -c "import json,sys; j=json.load(open(sys.argv[1])); e=[c for c in j['cases'] if 'error' in c]; sys.exit(not (len(e)==1 and \"column 'y_m'\" in e[0]['error'] and j['passed']==1 and j['unmatched']==['identified_0.3mm_1600rpm_v2.csv']))" "$work/batch.json" ||
  fail "batch JSON does not hold the malformed case's error: $(cat "$work/batch.json" | head -c 600)"

# Input it cannot compare: exit 2, one line on stderr, no JSON written.
expect_error() {
  local want=$1; shift
  "$rubref" validate "$@" --json "$work/bad.json" >"$work/out" 2>"$work/err"
  local rc=$?
  [ "$rc" -eq 2 ] || fail "exit $rc (want 2) for: $*"
  [ "$(wc -l <"$work/err")" -eq 1 ] || fail "stderr is not one line for: $*: $(cat "$work/err")"
  grep -qF -- "$want" "$work/err" || fail "stderr lacks '$want' for: $*: $(cat "$work/err")"
  [ ! -e "$work/bad.json" ] || fail "JSON written for: $*"
}
expect_error "no such candidate" --case "$golden/$case" --candidate "$work/none.csv"
"$rubref" simulate --rpm 1500 --revs 1 --settle-revs 1 --out "$work/other_speed.csv" >/dev/null
expect_error "the case runs at 1600 rpm" --case "$golden/$case" --candidate "$work/other_speed.csv"
expect_error "not a golden case" --case "$work/other_speed.csv" --candidate "$work/other_speed.csv"
printf 't_s,x_m,y_m,speed_rpm\n0,0,zero,1600\n' >"$work/broken.csv"
expect_error "broken.csv:2: column 'y_m'" --case "$golden/$case" --candidate "$work/broken.csv"
mkdir "$work/empty"
expect_error "holds no file named like a case" --case "$golden" --candidate "$work/empty"

[ "$failures" -eq 0 ] && echo "validate_cli_test: all passed"
exit "$failures"
