#!/usr/bin/env bash
# rubref as an installed package (docs/architecture.md, "Using rubref from C++"): installs this
# build into a fresh prefix, builds tests/package (find_package(rubref), rubref::rubref,
# <rubref/rubref.hpp>) against it and runs it, then checks that the installed `rubref`, moved
# with its prefix, finds its plot scripts next to itself.
#   package_test.sh <rubref binary> <build dir> <source dir> [<python> <python install dir in the prefix>]
source "$(dirname "${BASH_SOURCE[0]}")/shell_support.sh"
build=$2
src=$3
python=${4:-}
python_dir=${5:-}

cmake --install "$build" --prefix "$work/prefix" >"$work/install.log" 2>&1 || fail "cmake --install: $(tail -3 "$work/install.log")"
for f in include/rubref/rubref.hpp include/rubref/ref/run/simulate.hpp include/rubref/variants/all_variants.hpp \
         lib/cmake/rubref/rubrefConfig.cmake lib/cmake/rubref/rubrefConfigVersion.cmake bin/rubref share/rubref/scripts/plot_figures.py; do
  [ -e "$work/prefix/$f" ] || fail "not installed: $f"
done
for private in cli app; do [ -e "$work/prefix/include/rubref/ref/$private" ] && fail "the private headers of ref/$private are installed"; done

# The consumer, configured and built as any other project would (its compiler, its flags).
cmake -S "$src/tests/package" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release \
  >"$work/configure.log" 2>&1 || fail "find_package(rubref) failed: $(grep -m3 -iE 'error|could not' "$work/configure.log")"
cmake --build "$work/consumer" >"$work/build.log" 2>&1 || fail "the consumer does not build: $(grep -m3 -E 'error' "$work/build.log")"
"$work/consumer/consumer" >"$work/consumer.out" 2>&1 || fail "the consumer failed: $(cat "$work/consumer.out")"

# A version request to find_package that the package cannot meet is refused.
mkdir -p "$work/too_new"
sed 's/find_package(rubref 0.1 REQUIRED)/find_package(rubref 99 REQUIRED)/' "$src/tests/package/CMakeLists.txt" >"$work/too_new/CMakeLists.txt"
cp "$src/tests/package/consumer.cpp" "$work/too_new/"
cmake -S "$work/too_new" -B "$work/too_new/build" -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null 2>&1 && fail "find_package(rubref 99) accepted"

# Relocated: the prefix moved, the installed binary still finds its scripts beside it.
mv "$work/prefix" "$work/moved"
"$work/moved/bin/rubref" --version >"$work/version.out" 2>&1 || fail "installed rubref --version failed"
grep -q "plot scripts: $work/moved/share/rubref/scripts" "$work/version.out" ||
  fail "the moved rubref does not find its scripts beside it: $(cat "$work/version.out")"
"$work/moved/bin/rubref" simulate --rpm 1600 --settle-revs 20 --revs 2 --out "$work/run.csv" >/dev/null 2>&1 ||
  fail "the installed rubref cannot simulate"

# The Python package, imported from the moved prefix as an installed one would be.
if [ -n "$python" ]; then
  PYTHONPATH="$work/moved/$python_dir" "$python" -c "
import rubref, sys
assert rubref.__file__.startswith('$work/moved/'), rubref.__file__
r = rubref.simulate(rpm=1600, clearance=0.3e-3, settle_revs=20, revs=2)
assert r['summary']['regime'] != 'no_contact', r['summary']['regime']
" >"$work/python.out" 2>&1 || fail "the installed Python package: $(tail -3 "$work/python.out")"
fi

finish "package: installed, found by find_package, consumer ran: $(head -1 "$work/consumer.out")"
