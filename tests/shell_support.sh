# Sourced by the shell tests (cli, reproduce, determinism) with the binary under test as $1:
# `rubref`, a scratch folder `work` removed on exit, `fail` to record a failure and go on, and
# `finish` to report and exit non-zero if anything failed.
set -u
rubref=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
# finish <summary printed when all passed>; exits 1 on any failure (not the count: exit codes wrap at 256)
finish() {
  [ "$failures" -eq 0 ] || { echo "$failures failed"; exit 1; }
  echo "$1"
  exit 0
}
