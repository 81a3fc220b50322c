#!/usr/bin/env bash
# The main job end to end, as the README's first command runs it: every figure (PNG and SVG),
# the report, its numbers and the data behind them.
source "$(dirname "${BASH_SOURCE[0]}")/shell_support.sh"

"$rubref" reproduce --out "$work/rep" >"$work/log" 2>&1 || { cat "$work/log"; fail "reproduce failed"; }
grep -q "report.md" "$work/log" || fail "reproduce did not say where the report is"
for fig in fig03_orbits_no_rub fig05_friction fig06_restitution_orbits fig07_normal_force fig08_piecewise_orbits \
           fig09_waterfall fig10_jump fig11_directional_spectrum fig12_clearances; do
  for ext in png svg; do [ -s "$work/rep/$fig.$ext" ] || fail "missing $fig.$ext"; done
  grep -q "($fig.png)" "$work/rep/report.md" || fail "report does not show $fig"
done
head -c 8 "$work/rep/fig10_jump.png" | od -An -c | grep -q "P   N   G" || fail "fig10_jump.png is not a PNG"
for f in report.md reproduce.json data/figures.json data/sweep_identified_0.3mm.csv data/waterfall_identified_0.3mm_up.csv \
         data/identification.json data/fig05_friction.csv; do
  [ -s "$work/rep/$f" ] || fail "missing $f"
done
grep -qiE '\bnan\b|\binf\b' "$work/rep/report.md" && fail "report contains nan/inf"
grep -q "Paper vs rubref" "$work/rep/report.md" || fail "report lacks the comparison table"
grep -q "Table 1" "$work/rep/report.md" || fail "report lacks Table 1"
grep -q "Table 2" "$work/rep/report.md" || fail "report lacks Table 2"
# A second run replaces the first one's folder.
"$rubref" reproduce --no-figures --out "$work/rep" >/dev/null 2>&1 || fail "second reproduce failed"
[ ! -e "$work/rep/fig10_jump.png" ] || fail "second run kept the first run's figures"

finish "reproduce_test: all passed"
