#!/usr/bin/env bash
# The main job end to end, as the README's first command runs it: every figure (PNG and SVG),
# the report, its numbers and the data behind them.
source "$(dirname "${BASH_SOURCE[0]}")/shell_support.sh"

"$rubref" reproduce --out "$work/rep" >"$work/log" 2>&1 || { cat "$work/log"; fail "reproduce failed"; }
grep -q "report.md" "$work/log" || fail "reproduce did not say where the report is"
for fig in fig03_orbits_no_rub fig05_friction fig06_restitution_orbits fig07_normal_force fig08_piecewise_orbits \
           fig09_spectrum_map fig10_jump fig11_directional_spectrum fig12_clearances; do
  for ext in png svg; do [ -s "$work/rep/$fig.$ext" ] || fail "missing $fig.$ext"; done
  grep -q "($fig.png)" "$work/rep/report.md" || fail "report does not show $fig"
done
head -c 8 "$work/rep/fig10_jump.png" | od -An -c | grep -q "P   N   G" || fail "fig10_jump.png is not a PNG"
for f in report.md reproduce.json data/figures.json data/sweep_identified_0.3mm.csv data/waterfall_identified_0.3mm_up.csv \
         data/branch_identified_0.3mm.csv data/branch_identified_0.3mm.json data/contact_free_response.csv \
         data/identification.json data/fig05_friction.csv; do
  [ -s "$work/rep/$f" ] || fail "missing $f"
done
grep -qiE '\bnan\b|\binf\b' "$work/rep/report.md" && fail "report contains nan/inf"
grep -q "Paper vs rubref" "$work/rep/report.md" || fail "report lacks the comparison table"
grep -q "Table 1" "$work/rep/report.md" || fail "report lacks Table 1"
grep -q "Table 2" "$work/rep/report.md" || fail "report lacks Table 2"
for fig in fig03_orbits_no_rub fig10_jump fig12_clearances; do
  grep -q "<svg" "$work/rep/$fig.svg" || fail "$fig.svg is not an SVG"
done

# The physics the report rests on, checked on the run's own numbers (reproduce.json) and images.
/usr/bin/python3 - "$work/rep" <<'PY' || fail "reproduce.json or the figures break a documented property (above)"
import json, struct, sys
from pathlib import Path

rep = Path(sys.argv[1])
n = json.loads((rep / "reproduce.json").read_text())
bad = []
step = n["range"]["step_rpm"]
for c in n["clearances"]:
    tag = f"{c['clearance_mm']:g} mm"
    # The range is chosen to bracket both rub boundaries of every sweep.
    if not c["range_brackets_rub"]:
        bad.append(f"{tag}: a sweep rubs at an end of the range")
    # Two independent methods put the jumps at the same speeds: a sweep (integration, each speed
    # from its neighbour) leaves a branch where continuation (shooting + arclength) finds its fold,
    # so each jump lies between the two grid speeds around a fold: the run-up's at the rubbing
    # branch's top fold, the run-down's at the contact-free branch's grazing fold.
    folds = c["branch"]["folds_rpm"]
    if len(folds) < 2:
        bad.append(f"{tag}: continuation found {len(folds)} folds, not the two that bound the coexistence")
        continue
    top, low = max(folds), min(folds)
    for j in c["jumps"]:
        lo, hi = sorted((j["from_rpm"], j["to_rpm"]))
        fold = top if j["sweep"] == "up" else low
        if not (lo <= fold <= hi):
            bad.append(f"{tag}: {j['sweep']} jump {lo}-{hi} rpm does not bracket the fold at {fold:.2f} rpm")
    if sorted(j["sweep"] for j in c["jumps"]) != ["down", "up"]:
        bad.append(f"{tag}: expected one jump per sweep, got {c['jumps']}")
    # The sweeps disagree exactly between the folds (grid speeds inside [low, top]).
    inside = [b for b in c["hysteresis_bands_rpm"] if b[0] >= low and b[1] <= top and b[0] - low < step and top - b[1] < step]
    if not inside:
        bad.append(f"{tag}: no hysteresis band spans the folds {low:.2f}-{top:.2f} rpm: {c['hysteresis_bands_rpm']}")
# Fig. 3 shows a horizontal and a vertical ellipse (major axis within 10 degrees) and a circle.
roles = {f["role"]: f for f in n["fig03"]}
if abs(roles["horizontal ellipse"]["tilt_deg"] % 180.0 - 0.0) > 10.0 and abs(roles["horizontal ellipse"]["tilt_deg"] - 180.0) > 10.0:
    bad.append(f"Fig. 3 horizontal ellipse tilted {roles['horizontal ellipse']['tilt_deg']:.1f} deg")
if abs(roles["vertical ellipse"]["tilt_deg"] - 90.0) > 10.0:
    bad.append(f"Fig. 3 vertical ellipse tilted {roles['vertical ellipse']['tilt_deg']:.1f} deg")
if roles["circle"]["axis_ratio"] < 0.95:
    bad.append(f"Fig. 3 circle has minor/major {roles['circle']['axis_ratio']:.3f}")
# Every PNG says 300 dpi in its pHYs chunk (11811 pixels per metre).
for png in sorted(rep.glob("fig*.png")):
    data = png.read_bytes()
    at = data.find(b"pHYs")
    if at < 0:
        bad.append(f"{png.name}: no pHYs chunk")
        continue
    x, y, unit = struct.unpack(">IIB", data[at + 4:at + 13])
    if unit != 1 or round(x * 0.0254) != 300 or round(y * 0.0254) != 300:
        bad.append(f"{png.name}: {x * 0.0254:.0f} x {y * 0.0254:.0f} dpi, not 300")
for b in bad:
    print("  " + b)
sys.exit(1 if bad else 0)
PY

# A second run replaces the first one's folder.
"$rubref" reproduce --no-figures --out "$work/rep" >/dev/null 2>&1 || fail "second reproduce failed"
[ ! -e "$work/rep/fig10_jump.png" ] || fail "second run kept the first run's figures"

finish "reproduce_test: all passed"
