#!/usr/bin/env python3
"""Figures of a `rubref study` folder (docs/studies.md): reads spec.json, points.csv and the
kind's extras, writes <kind>.png (300 dpi) and <kind>.svg:
  regime_map   clearance x speed coloured by the steady response, with the fold lines
  basins       the start plane coloured by the attractor reached
  monte_carlo  histograms of the run-up's rub onset speed, jump speed and peak contact force"""
import csv
import json
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

folder = Path(sys.argv[1])
spec = json.loads((folder / "spec.json").read_text())
kind = spec["study"]


def table(name):
    with open(folder / name, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def num(s):
    return float(s)


# Lengths in mm, speeds in rpm, as the paper's figures.
def scaled(name):
    return (1e3, name[:-2] + " [mm]") if name.endswith("_m") else (1.0, name.replace("_rpm", " [rpm]"))


def grid_axes(rows):
    """The two grid axes' values (ascending) and each row's cell."""
    names = [a["name"] for a in spec["grid"]]
    values = [sorted({num(r[n]) for r in rows}) for n in names]
    return names, values


def save(fig, stem):
    fig.savefig(folder / f"{stem}.png", dpi=300)
    fig.savefig(folder / f"{stem}.svg", metadata={"Date": None})  # the same bytes for the same data
    plt.close(fig)


def image(ax, rows, names, values, code, cmap, vmin, vmax):
    """A pcolormesh of one code per grid cell; the cells' edges halfway between the values."""
    def edges(v):
        if len(v) == 1:
            return [v[0] - 0.5, v[0] + 0.5]
        mids = [(a + b) / 2 for a, b in zip(v, v[1:])]
        return [2 * v[0] - mids[0]] + mids + [2 * v[-1] - mids[-1]]

    (sx, _), (sy, _) = scaled(names[1]), scaled(names[0])
    grid = [[math.nan] * len(values[1]) for _ in values[0]]
    pos = [{v: i for i, v in enumerate(vs)} for vs in values]
    for r in rows:
        grid[pos[0][num(r[names[0]])]][pos[1][num(r[names[1]])]] = code(r)
    ax.pcolormesh([e * sx for e in edges(values[1])], [e * sy for e in edges(values[0])], grid, cmap=cmap, vmin=vmin, vmax=vmax,
                  shading="flat")
    ax.set_xlabel(scaled(names[1])[1])
    ax.set_ylabel(scaled(names[0])[1])


def regime_map():
    rows = table("points.csv")
    names, values = grid_axes(rows)
    if names[0] == "speed_rpm":  # speed along x, clearance along y
        names, values = names[::-1], values[::-1]
    classes = [("no contact", "#d9d9d9"), ("partial rub, period 1", "#4c72b0"), ("partial rub, period ≥ 2", "#dd8452"),
               ("full annular rub", "#8172b3"), ("non-periodic", "#c44e52"), ("no steady result", "#222222")]

    def code(r):
        if r["status"] != "ok":
            return 5
        return {"no_contact": 0, "full_annular": 3, "non_periodic": 4}.get(r["response"], 1 if r["period_revs"] == "1" else 2)

    fig, ax = plt.subplots(figsize=(7.5, 4.8), constrained_layout=True)
    image(ax, rows, names, values, code, ListedColormap([c for _, c in classes]), -0.5, len(classes) - 0.5)
    present = {code(r) for r in rows}
    handles = [Patch(color=c, label=l) for i, (l, c) in enumerate(classes) if i in present]
    folds = table("folds.csv")
    by_clearance = {}
    for f in folds:
        by_clearance.setdefault(num(f["clearance_m"]), []).append(num(f["fold_rpm"]))
    if by_clearance:
        most = max(len(v) for v in by_clearance.values())
        for k in range(most):  # the k-th fold by speed at each clearance, joined where every clearance has it
            pts = sorted((c, sorted(v)[k]) for c, v in by_clearance.items() if len(v) == most)
            ax.plot([p[1] for p in pts], [p[0] * 1e3 for p in pts], "k-", marker="D", ms=3, lw=1.2)
        handles.append(plt.Line2D([], [], color="k", marker="D", ms=3, label="fold of the period-1 branch (continuation)"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.set_title(f"Regime map, {spec['variant']} law" + (f" — {spec['name']}" if spec["name"] else ""), fontsize=10)
    save(fig, "regime_map")


def basins():
    rows = table("points.csv")
    names, values = grid_axes(rows)
    attractors = table("attractors.csv")
    palette = ["#4c72b0", "#dd8452", "#55a868", "#8172b3", "#937860", "#da8bc3", "#8c8c8c", "#ccb974", "#64b5cd"]
    labels = [("start inside the stator (invalid)", "#ffffff"), ("no steady result", "#222222"), ("non-periodic", "#c44e52")]
    for a in attractors:
        labels.append((f"attractor {a['attractor']}: {a['response'].replace('_', ' ')}, period {a['period_revs']}, "
                       f"max radius {num(a['max_radius_m']) * 1e3:.3f} mm ({100 * num(a['share']):.0f} %)",
                       palette[(int(a["attractor"]) - 1) % len(palette)]))
    fig, ax = plt.subplots(figsize=(7.5, 4.8), constrained_layout=True)
    def code(r):  # -1: no attractor (invalid start, or no steady result), 0: non-periodic, k: attractor k
        return 0 if r["status"] == "invalid" else int(r["attractor"]) + 2

    image(ax, rows, names, values, code, ListedColormap([c for _, c in labels]), -0.5, len(labels) - 0.5)
    present = {code(r) for r in rows}
    ax.legend(handles=[Patch(facecolor=c, edgecolor="0.5", label=l) for i, (l, c) in enumerate(labels) if i in present], loc="upper center",
              bbox_to_anchor=(0.5, -0.13), fontsize=8, frameon=False)
    p = spec["parameters"]
    ax.set_title(f"Basins of attraction, {spec['variant']} law, {spec['speed_rpm']:g} rpm, δ = {p['clearance_m'] * 1e3:g} mm", fontsize=10)
    save(fig, "basins")


def monte_carlo():
    rows = [r for r in table("points.csv") if r["status"] == "ok"]
    panels = [("onset_rpm", "rub onset on the run-up [rpm]", 1.0), ("jump_rpm", "jump off the rubbing branch [rpm]", 1.0),
              ("peak_force_N", "peak normal contact force on the run-up [N]", 1.0)]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.6), constrained_layout=True)
    for ax, (col, label, scale) in zip(axes, panels):
        v = [num(r[col]) * scale for r in rows if not math.isnan(num(r[col]))]
        missing = len(rows) - len(v)
        if v:
            ax.hist(v, bins=max(5, min(50, int(len(v) ** 0.5))), color="#4c72b0", edgecolor="white", lw=0.5)
        ax.set_xlabel(label)
        ax.set_ylabel("samples")
        ax.set_title(f"{len(v)} samples" + (f" ({missing} without one)" if missing else ""), fontsize=9)
    vary = ", ".join(v["name"] for v in spec["sample"]["vary"])
    fig.suptitle(f"Monte Carlo over {vary}: {len(rows)} run-ups {spec['job']['from_rpm']:g}–{spec['job']['to_rpm']:g} rpm, "
                 f"{spec['variant']} law", fontsize=10)
    save(fig, "monte_carlo")


{"regime_map": regime_map, "basins": basins, "monte_carlo": monte_carlo}[kind]()
print(f"plot_study: {kind}.png, {kind}.svg in {folder}")
