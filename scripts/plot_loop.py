#!/usr/bin/env python3
"""Figures of a `rubref loop` report folder (docs/loop.md): reads plot_data.json, writes
orbit.png (measured orbit with the model before and after the trace), residual.png (residual
against shaft angle, before and after) and residual_spectrum.png (full spectrum of the residual
by shaft order, RMS over the dwells with contact)."""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

folder = Path(sys.argv[1])
d = json.loads((folder / "plot_data.json").read_text())
um = 1e6

order = sorted(range(len(d["phase_deg"])), key=lambda i: d["phase_deg"][i])
ph = [d["phase_deg"][i] for i in order]


def by_phase(key):
    return [d[key][i] * um for i in order]


fig, ax = plt.subplots(figsize=(5.5, 5.5))
ax.plot([v * um for v in d["x_m"]], [v * um for v in d["y_m"]], ".", ms=1, color="0.6", label="measured")
ax.plot(by_phase("x_before_m"), by_phase("y_before_m"), "-", lw=1, color="tab:red", label="paper's model (before)")
ax.plot(by_phase("x_after_m"), by_phase("y_after_m"), "-", lw=1, color="tab:blue", label="with the effects found (after)")
ax.axhline(d["clearance_m"] * um, color="k", lw=0.8, ls="--", label="clearance")
ax.set_xlabel("x [µm]")
ax.set_ylabel("y [µm]")
ax.set_title(d["title"])
ax.set_aspect("equal", "datalim")
ax.legend(fontsize=8, loc="lower left")
fig.tight_layout()
fig.savefig(folder / "orbit.png", dpi=120)
plt.close(fig)

fig, axs = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
for ax, c in zip(axs, ("x", "y")):
    meas = by_phase(f"{c}_m")
    ax.plot(ph, [b - m for b, m in zip(by_phase(f"{c}_before_m"), meas)], ".", ms=1, color="tab:red", label="before")
    ax.plot(ph, [a - m for a, m in zip(by_phase(f"{c}_after_m"), meas)], ".", ms=1, color="tab:blue", label="after")
    ax.set_ylabel(f"residual {c} [µm]")
axs[0].legend(fontsize=8, markerscale=8)
axs[1].set_xlabel("shaft angle from the keyphasor [deg]")
axs[0].set_title(d["title"] + ": model − measured")
fig.tight_layout()
fig.savefig(folder / "residual.png", dpi=120)
plt.close(fig)

fig, ax = plt.subplots(figsize=(7, 3.5))
k = d["orders"]
ax.bar([o - 0.2 for o in k], [v * um for v in d["spectrum_before_m"]], width=0.4, color="tab:red", label="before")
ax.bar([o + 0.2 for o in k], [v * um for v in d["spectrum_after_m"]], width=0.4, color="tab:blue", label="after")
ax.set_yscale("log")
ax.set_xlabel("shaft order (negative: backward)")
ax.set_ylabel("residual amplitude [µm]")
ax.set_title("full spectrum of the residual, RMS over dwells with contact")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(folder / "residual_spectrum.png", dpi=120)
plt.close(fig)
