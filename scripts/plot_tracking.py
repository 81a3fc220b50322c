#!/usr/bin/env python3
"""Figures of `rubref loop` on an order-tracked table (docs/real-data.md): reads plot_data.json,
writes bode.png (1X amplitude and phase against speed: the table, the base fit, the fit with the
effects found, and where that fit is swept, the steady fit of the same effects), polar.png (the 1X vector in the complex plane) and residual.png (|residual| / noise
against speed, before and after), one set per probe; with 2X columns also bode_2x.png (the 2X
table, its runout-only fit and the fit the loop kept)."""
import cmath
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

folder = Path(sys.argv[1])
d = json.loads((folder / "plot_data.json").read_text())
um = 1e6
rpm = d["rpm"]
after_label = "with " + ", ".join(d["effects"]) if d["effects"] else None


def vectors(p, key):
    return [complex(a, b) * um for a, b in zip(p[key + "_re"], p[key + "_im"])]


for p in d["probes"]:
    suffix = f"_{p['name']}" if p["name"] and len(d["probes"]) > 1 else ""
    title = Path(d["source"]).name + (f", probe {p['name']}" if p["name"] else "")
    data, before, after = vectors(p, "data"), vectors(p, "before"), vectors(p, "after")
    steady = vectors(p, "steady") if "steady_re" in p else None  # the after fit's effects, steady (the sweep's bias)
    steady_label = "the same effects, steady"

    fig, axs = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    axs[0].plot(rpm, [abs(v) for v in data], ".", ms=2, color="0.55", label="table")
    axs[0].plot(rpm, [abs(v) for v in before], "-", lw=1.2, color="tab:red", label="base fit (one critical speed, unbalance, runout)")
    if steady:
        axs[0].plot(rpm, [abs(v) for v in steady], "--", lw=1.0, color="tab:orange", label=steady_label)
    if after_label:
        axs[0].plot(rpm, [abs(v) for v in after], "-", lw=1.0, color="tab:blue", label=after_label)
    axs[0].set_ylabel("1X amplitude, 0-peak [µm]")
    axs[0].legend(fontsize=8)
    axs[0].set_title(title)
    axs[1].plot(rpm, [math.degrees(cmath.phase(v)) for v in data], ".", ms=2, color="0.55")
    axs[1].plot(rpm, [math.degrees(cmath.phase(v)) for v in before], "-", lw=1.2, color="tab:red")
    if steady:
        axs[1].plot(rpm, [math.degrees(cmath.phase(v)) for v in steady], "--", lw=1.0, color="tab:orange")
    if after_label:
        axs[1].plot(rpm, [math.degrees(cmath.phase(v)) for v in after], "-", lw=1.0, color="tab:blue")
    axs[1].set_ylabel("1X phase (lead) [deg]")
    axs[1].set_xlabel("speed [rpm]")
    axs[1].set_ylim(-180, 180)
    fig.tight_layout()
    fig.savefig(folder / f"bode{suffix}.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 5.5))
    ax.plot([v.real for v in data], [v.imag for v in data], ".", ms=2, color="0.55", label="table")
    ax.plot([v.real for v in before], [v.imag for v in before], "-", lw=1.2, color="tab:red", label="base fit")
    if after_label:
        ax.plot([v.real for v in after], [v.imag for v in after], "-", lw=1.0, color="tab:blue", label=after_label)
    ax.set_xlabel("Re 1X [µm]")
    ax.set_ylabel("Im 1X [µm]")
    ax.set_aspect("equal", "datalim")
    ax.legend(fontsize=8)
    ax.set_title(title + ": polar")
    fig.tight_layout()
    fig.savefig(folder / f"polar{suffix}.png", dpi=120)
    plt.close(fig)

    noise = p["noise_m"] * um
    fig, ax = plt.subplots(figsize=(7.5, 3.5))
    ax.plot(rpm, [abs(a - b) / noise for a, b in zip(data, before)], ".", ms=2, color="tab:red", label="base fit")
    if steady:
        ax.plot(rpm, [abs(a - b) / noise for a, b in zip(data, steady)], ".", ms=2, color="tab:orange", label=steady_label)
    if after_label:
        ax.plot(rpm, [abs(a - b) / noise for a, b in zip(data, after)], ".", ms=2, color="tab:blue", label=after_label)
    ax.axhline(math.sqrt(2), color="k", lw=0.8, ls="--", label="noise (RMS of |residual|)")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("|residual| / noise")
    ax.set_title(title + ": residual")
    ax.legend(fontsize=8, markerscale=4)
    fig.tight_layout()
    fig.savefig(folder / f"residual{suffix}.png", dpi=120)
    plt.close(fig)

    if "two_x" in p:
        t = p["two_x"]
        data2, before2, after2 = vectors(t, "data"), vectors(t, "before"), vectors(t, "after")
        fig, axs = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
        for ax, f in ((axs[0], abs), (axs[1], lambda v: math.degrees(cmath.phase(v)))):
            ax.plot(rpm, [f(v) for v in data2], ".", ms=2, color="0.55", label="table")
            ax.plot(rpm, [f(v) for v in before2], "-", lw=1.2, color="tab:red", label="2X runout alone")
            ax.plot(rpm, [f(v) for v in after2], "-", lw=1.0, color="tab:blue", label="kept by the loop")
        axs[0].set_ylabel("2X amplitude, 0-peak [µm]")
        axs[0].legend(fontsize=8)
        axs[0].set_title(title + ": 2X")
        axs[1].set_ylabel("2X phase (lead) [deg]")
        axs[1].set_xlabel("speed [rpm]")
        axs[1].set_ylim(-180, 180)
        fig.tight_layout()
        fig.savefig(folder / f"bode_2x{suffix}.png", dpi=120)
        plt.close(fig)
