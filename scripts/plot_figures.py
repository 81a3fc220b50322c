#!/usr/bin/python3
"""Draws the paper's Figs. 3, 6-12 from the data `rubref reproduce` wrote into FOLDER.

    plot_figures.py FOLDER

Reads FOLDER/data/figures.json (which files belong to which figure) and FOLDER/reproduce.json
(hysteresis bands); writes FOLDER/figNN_*.png and .svg. Axes in the paper's units: mm and rpm.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d import Axes3D  # noqa: E402,F401  (registers the 3d projection)

MM = 1e3
PAPER_BACKWARD_RPM = (1550, 1670)  # §6: backward whirl exceeds forward whirl, Fig. 11


def read_csv(path):
    """A rubref record or table: '# key: value' lines, then a CSV header and rows."""
    meta = {}
    with open(path) as f:
        lines = f.read().splitlines()
    body = []
    for line in lines:
        if not body and line.startswith("#"):
            key, _, value = line[1:].partition(":")
            meta[key.strip()] = value.strip()
        else:
            body.append(line)
    data = np.genfromtxt(body, delimiter=",", names=True, dtype=None, encoding="utf-8")
    return meta, data


def save(fig, folder, name):
    for ext in ("png", "svg"):
        fig.savefig(folder / f"{name}.{ext}", dpi=120, bbox_inches="tight")
    plt.close(fig)
    print(f"      {name}.png", flush=True)


def orbit_axes(ax, title):
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title, fontsize=9)
    ax.grid(True, lw=0.3)


def stator_line(ax, clearance_mm):
    ax.axhline(clearance_mm, color="tab:red", lw=0.8, ls="--", label=f"protrusion y = {clearance_mm:g} mm")


def fig03(folder, man):
    items = man["fig03"]
    fig, axes = plt.subplots(1, len(items), figsize=(3.2 * len(items), 3.4), layout="constrained")
    for ax, item in zip(axes, items):
        _, d = read_csv(folder / item["file"])
        ax.plot(d["x_m"] * MM, d["y_m"] * MM, lw=1.0)
        orbit_axes(ax, f"{item['rpm']:.0f} rpm")
    fig.suptitle("Fig. 3 — Whirling orbits without rubbing (contact-free model): "
                 "horizontal ellipse → vertical ellipse → circle")
    save(fig, folder, "fig03_orbits_no_rub")


def fig05(folder, man):
    _, d = read_csv(folder / man["fig05"]["file"])
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.errorbar(d["speed_rpm"], d["mu_mean"], yerr=d["mu_std"], fmt="o", capsize=3, label="rubref: mean ± std over contact samples")
    ax.axhline(man["fig05"]["mu_paper"], color="tab:red", ls="--", lw=1, label="paper: average 0.24")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("friction coefficient μ = f_x / f_N")
    ax.set_ylim(0, 0.5)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Fig. 5 — Variation of the friction coefficient with speed (identified from rubref's own records)", fontsize=10)
    save(fig, folder, "fig05_friction")


def orbit_row(folder, items, clearance_mm, title, name, overlay=None):
    fig, axes = plt.subplots(1, len(items), figsize=(3.2 * len(items), 3.6), layout="constrained")
    for i, (ax, item) in enumerate(zip(axes, items)):
        _, d = read_csv(folder / item["file"])
        ax.plot(d["x_m"] * MM, d["y_m"] * MM, lw=1.0, label=item["variant"])
        if overlay:
            _, e = read_csv(folder / overlay[i]["file"])
            ax.plot(e["x_m"] * MM, e["y_m"] * MM, lw=1.2, ls=":", label=overlay[i]["variant"])
        stator_line(ax, clearance_mm)
        orbit_axes(ax, f"{item['rpm']:.0f} rpm")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(title)
    save(fig, folder, name)


def fig06(folder, man):
    orbit_row(folder, man["fig06"], man["clearance_mm"],
              f"Fig. 6 — Orbits with the coefficient of restitution r = 0.86, clearance {man['clearance_mm']:g} mm (run-up)",
              "fig06_restitution_orbits")


def fig07(folder, man):
    _, d = read_csv(folder / man["fig07"]["file"])
    z = d["z_m"] * MM
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
    a.plot(z, d["fn_piecewise_linear_N"], label="(a) piecewise-linear  $k_1 z$")
    a.plot(z, d["fn_piecewise_nonlinear_N"], ls="--", label="(b) piecewise-nonlinear  $k_1 z + k_3 z^3$")
    b.plot(z, d["fn_piecewise_nonlinear_N"] - d["fn_piecewise_linear_N"], color="tab:orange")
    for ax in (a, b):
        ax.axvline(man["fig07"]["z_reached_mm"], color="gray", lw=0.8, ls=":",
                   label=f"deepest penetration in the 0.3 mm sweeps ({man['fig07']['z_reached_mm'] * 1e3:.1f} µm)")
        ax.set_xlabel("penetration z = y − δ [mm]")
        ax.grid(True, lw=0.3)
    a.set_ylabel("normal force $f_N$ [N]")
    b.set_ylabel("$k_3 z^3$: nonlinear minus linear [N]")
    a.legend(fontsize=8)
    b.legend(fontsize=8)
    fig.suptitle("Fig. 7 — Contact stiffness of (a) piecewise-linear and (b) piecewise-nonlinear laws (Table 2)")
    save(fig, folder, "fig07_normal_force")


def fig08(folder, man):
    items = man["fig08"]
    lin = [i for i in items if i["variant"] == "piecewise-linear"]
    non = [i for i in items if i["variant"] == "piecewise-nonlinear"]
    orbit_row(folder, lin, man["clearance_mm"],
              f"Fig. 8 — Orbits of the piecewise-linear (solid) and piecewise-nonlinear (dotted) laws, "
              f"{man['clearance_mm']:g} mm (run-up)", "fig08_piecewise_orbits", overlay=non)


def fig09(folder, man):
    _, d = read_csv(folder / man["waterfall"]["up"])
    speeds = np.unique(d["speed_rpm"])
    shown = speeds[::4]  # every 20 rpm keeps the lines apart
    fig = plt.figure(figsize=(10, 7))
    ax = fig.add_subplot(projection="3d")
    ax.set_box_aspect(None, zoom=0.85)  # keeps the z label inside the figure
    for rpm in shown:
        row = d[d["speed_rpm"] == rpm]
        ax.plot(row["order"], np.full(len(row), rpm), row["amplitude_m"] * MM, lw=0.8, color="tab:blue")
    ax.set_xlabel("order (negative: backward whirl)")
    ax.set_ylabel("speed [rpm]")
    ax.set_zlabel("amplitude [mm]")
    ax.view_init(elev=28, azim=-60)
    ax.set_title(f"Fig. 9 — Waterfall: full spectrum of x + jy vs speed, identified law, "
                 f"{man['clearance_mm']:g} mm, run-up", fontsize=10)
    save(fig, folder, "fig09_waterfall")


def sweep_data(folder, man, variant, clearance_mm):
    for s in man["sweeps"]:
        if s["variant"] == variant and abs(s["clearance_mm"] - clearance_mm) < 1e-9:
            return read_csv(folder / s["file"])[1]
    raise KeyError(variant)


def fig10(folder, man, numbers):
    clearances = [c["clearance_mm"] for c in numbers["clearances"]]
    fig, axes = plt.subplots(1, len(clearances), figsize=(5 * len(clearances), 4), sharey=True)
    for ax, c in zip(axes, numbers["clearances"]):
        d = sweep_data(folder, man, "identified", c["clearance_mm"])
        for direction, style in (("up", "-"), ("down", "--")):
            rows = d[d["direction"] == direction]
            order = np.argsort(rows["speed_rpm"])
            ax.plot(rows["speed_rpm"][order], rows["max_radius_m"][order] * MM, style, marker=".", ms=3,
                    label="run-up" if direction == "up" else "run-down")
        for lo, hi in c["hysteresis_bands_rpm"]:
            ax.axvspan(lo, hi, color="tab:orange", alpha=0.2, label="two coexisting responses")
        ax.set_title(f"clearance {c['clearance_mm']:g} mm", fontsize=9)
        ax.set_xlabel("speed [rpm]")
        ax.grid(True, lw=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("orbit amplitude, max |x + jy| [mm]")
    fig.suptitle("Fig. 10 — Jump phenomenon: identified law, run-up vs run-down")
    save(fig, folder, "fig10_jump")


def fig11(folder, man):
    d = sweep_data(folder, man, "identified", man["clearance_mm"])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for direction, style in (("up", "-"), ("down", "--")):
        rows = d[d["direction"] == direction]
        order = np.argsort(rows["speed_rpm"])
        name = "run-up" if direction == "up" else "run-down"
        ax.plot(rows["speed_rpm"][order], rows["amp_f1x_m"][order] * MM, style, color="tab:blue", label=f"forward 1X, {name}")
        ax.plot(rows["speed_rpm"][order], rows["amp_b1x_m"][order] * MM, style, color="tab:red", label=f"backward 1X, {name}")
    ax.axvspan(*PAPER_BACKWARD_RPM, color="gray", alpha=0.15, label="paper: backward > forward (1550–1670 rpm)")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("1X amplitude [mm]")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Fig. 11 — Directional spectrum: forward and backward 1X, identified law, {man['clearance_mm']:g} mm")
    save(fig, folder, "fig11_directional_spectrum")


def fig12(folder, man):
    items = man["fig12"]
    clearances = sorted({i["clearance_mm"] for i in items})
    speeds = sorted({i["rpm"] for i in items})
    fig, axes = plt.subplots(len(clearances), len(speeds), figsize=(3 * len(speeds), 3 * len(clearances)), layout="constrained")
    for item in items:
        ax = axes[clearances.index(item["clearance_mm"])][speeds.index(item["rpm"])]
        _, d = read_csv(folder / item["file"])
        ax.plot(d["x_m"] * MM, d["y_m"] * MM, lw=0.9)
        stator_line(ax, item["clearance_mm"])
        orbit_axes(ax, f"{item['clearance_mm']:g} mm, {item['rpm']:.0f} rpm")
    fig.suptitle("Fig. 12 — Orbits of the identified law at clearances 0.2, 0.3 and 0.4 mm (run-up, μ = 0.24)")
    save(fig, folder, "fig12_clearances")


def main():
    folder = Path(sys.argv[1])
    man = json.loads((folder / "data" / "figures.json").read_text())
    numbers = json.loads((folder / "reproduce.json").read_text())
    fig03(folder, man)
    fig05(folder, man)
    fig06(folder, man)
    fig07(folder, man)
    fig08(folder, man)
    fig09(folder, man)
    fig10(folder, man, numbers)
    fig11(folder, man)
    fig12(folder, man)


if __name__ == "__main__":
    main()
