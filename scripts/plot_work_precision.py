#!/usr/bin/env python3
"""Work-precision figure (docs/performance.md): reads the CSV of bench/work_precision
(method,events,setting,steps,error_m,time_s) and draws error against wall time, log-log, one line
per stepper with located events (solid) and without (dashed, Eq. 2 as written in the RHS).

    plot_work_precision.py TABLE.csv OUT.png
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

table, out = sys.argv[1], sys.argv[2]
rows = list(csv.DictReader(open(table)))
colors = {"rk4": "tab:red", "dopri5": "tab:blue", "rkf78": "tab:green", "bulirsch-stoer": "tab:purple"}
fig, ax = plt.subplots(figsize=(7, 5))
for method, color in colors.items():
    for events, style, label in (("located", "-o", "events located"), ("none", "--x", "no events")):
        pts = [(float(r["time_s"]), max(float(r["error_m"]), 1e-16)) for r in rows if r["method"] == method and r["events"] == events]
        if pts:
            pts.sort()
            ax.plot([p[0] * 1e3 for p in pts], [p[1] for p in pts], style, color=color, ms=4, label=f"{method}, {label}")
ax.set_xscale("log")
ax.set_yscale("log")
ax.set_xlabel("wall time of one steady-state run (200 + 8 rev) [ms]")
ax.set_ylabel("largest orbit error against the golden orbit [m]")
ax.set_title("identified law, 0.3 mm, 1600 rpm")
ax.grid(True, which="both", lw=0.3)
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(out, dpi=120)
