#!/usr/bin/python3
"""Draws the paper's Figs. 3, 5-12 from the data `rubref reproduce` wrote into FOLDER.

    plot_figures.py FOLDER

Reads FOLDER/data/figures.json (which files belong to which figure) and FOLDER/reproduce.json
(the run's numbers: jumps, folds, periods); writes FOLDER/figNN_*.png (300 dpi) and .svg.
Axes in the paper's units: mm, µm and rpm. Titles name the figure; what it shows is said in the
captions of report.md.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

MM = 1e3
UM = 1e6
DPI = 300
PAPER_BACKWARD_RPM = (1550, 1670)  # §6: backward whirl exceeds forward whirl, Fig. 11
HATCH = dict(facecolor="none", edgecolor="0.55", hatch="///", lw=0.0)
plt.rcParams.update({"font.size": 8, "axes.titlesize": 8, "legend.fontsize": 7, "axes.linewidth": 0.6,
                     "svg.fonttype": "none"})


def read_csv(path):
    """A rubref record or table: '# key: value' lines, then a CSV header and rows."""
    meta = {}
    body = []
    for line in Path(path).read_text().splitlines():
        if not body and line.startswith("#"):
            key, _, value = line[1:].partition(":")
            meta[key.strip()] = value.strip()
        else:
            body.append(line)
    data = np.genfromtxt(body, delimiter=",", names=True, dtype=None, encoding="utf-8")
    return meta, data


def save(fig, folder, name):
    for ext in ("png", "svg"):
        fig.savefig(folder / f"{name}.{ext}", dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    print(f"      {name}.png", flush=True)


def legend_below(fig, handles, labels, ncol):
    """A figure legend under the axes (savefig's tight bounding box keeps it in the image)."""
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=ncol, frameon=False)


def orbit_axes(ax, title, shared=False):
    # Shared axes keep one scale across panels; the limits then come from all of them (common_limits).
    ax.set_aspect("equal", adjustable="box" if shared else "datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title)
    ax.grid(True, lw=0.3)


def stator_line(ax, clearance_mm, label=None):
    ax.axhline(clearance_mm, color="tab:red", lw=0.8, ls="--", label=label or f"protrusion y = δ = {clearance_mm:g} mm")


def whirl_arrows(ax, x, y, color, count=3):
    """Arrows along the orbit in its direction of motion, spread over the first revolution."""
    n = len(x)
    for k in range(count):
        i = int(k * n / count) % max(n - 3, 1)
        ax.annotate("", xy=(x[i + 2], y[i + 2]), xytext=(x[i], y[i]),
                    arrowprops=dict(arrowstyle="-|>", color=color, lw=0.8, mutation_scale=9))


def keyphasor(ax, t, x, y, rpm, label=True):
    """The samples at shaft angle 0 (t a whole number of revolutions): one dot per revolution."""
    revs = t * rpm / 60.0
    on = np.abs(revs - np.round(revs)) < 1e-6
    ax.plot(x[on], y[on], "o", color="k", ms=2.5, label="shaft at angle 0 (once per rev)" if label else None, zorder=5)


def draw_orbit(ax, d, rpm, color="tab:blue", ls="-", label=None, revs=None, arrows=True, dots=True):
    x, y, t = d["x_m"] * MM, d["y_m"] * MM, d["t_s"]
    if revs is not None:
        keep = (t - t[0]) * rpm / 60.0 < revs - 1e-9
        x, y, t = x[keep], y[keep], t[keep]
    ax.plot(x, y, lw=0.8, color=color, ls=ls, label=label)
    if arrows:
        per_rev = int(round(len(x) / max(1.0, (t[-1] - t[0]) * rpm / 60.0)))
        whirl_arrows(ax, x[:per_rev + 3], y[:per_rev + 3], color)
    if dots:
        keyphasor(ax, t, x, y, rpm, label=label is not None)


def common_limits(axes, margin=0.05):
    """One square window holding every panel's data, for panels on shared axes."""
    lo = np.array([np.inf, np.inf])
    hi = -lo
    for ax in np.ravel(axes):
        for line in ax.get_lines():
            x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
            if len(x) > 2:
                lo = np.minimum(lo, [x.min(), y.min()])
                hi = np.maximum(hi, [x.max(), y.max()])
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2 * (1 + margin)
    for ax in np.ravel(axes):
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)


def period_text(p):
    return "non-periodic" if p == 0 else f"period {p}"


def fig03(folder, man, numbers):
    items = man["fig03"]
    fig, axes = plt.subplots(1, len(items), figsize=(2.6 * len(items), 2.9), layout="constrained")
    for ax, item, info in zip(axes, items, numbers["fig03"]):
        _, d = read_csv(folder / item["file"])
        draw_orbit(ax, d, item["rpm"], label="orbit" if ax is axes[0] else None)
        stator_line(ax, man["clearance_mm"], label="where a 0.3 mm protrusion would be" if ax is axes[0] else "")
        orbit_axes(ax, f"{info['role']}, {item['rpm']:.0f} rpm")
    legend_below(fig, *axes[0].get_legend_handles_labels(), ncol=3)
    fig.suptitle("Fig. 3 — orbits without rub")
    save(fig, folder, "fig03_orbits_no_rub")


def fig05(folder, man):
    _, d = read_csv(folder / man["fig05"]["file"])
    fig, ax = plt.subplots(figsize=(5.5, 3.2), layout="constrained")
    ax.errorbar(d["speed_rpm"], d["mu_mean"], yerr=d["mu_std"], fmt="o", ms=3, capsize=2, label="identified: mean ± std over contact samples")
    ax.axhline(man["fig05"]["mu_input"], color="tab:red", ls="--", lw=0.8,
               label=f"input of the record: μ = {man['fig05']['mu_input']:g} (also the paper's average)")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("friction coefficient μ = f_x / f_N")
    ax.set_ylim(0, 0.5)
    ax.grid(True, lw=0.3)
    ax.legend()
    ax.set_title("Fig. 5 — friction coefficient (consistency check on rubref's own record)")
    save(fig, folder, "fig05_friction")


def orbit_row(folder, items, clearance_mm, title, name):
    fig, axes = plt.subplots(1, len(items), figsize=(2.5 * len(items), 2.9), layout="constrained", sharex=True, sharey=True)
    for ax, item in zip(axes, items):
        _, d = read_csv(folder / item["file"])
        p = item["period_revs"]
        draw_orbit(ax, d, item["rpm"], revs=None if p != 1 else 1, label="orbit" if ax is axes[0] else None)
        stator_line(ax, clearance_mm, label=None if ax is axes[0] else "")
        orbit_axes(ax, f"{item['rpm']:.0f} rpm, {period_text(p)}", shared=True)
    common_limits(axes)
    axes[0].legend(loc="lower left")
    fig.suptitle(title)
    save(fig, folder, name)


def fig06(folder, man):
    orbit_row(folder, man["fig06"], man["clearance_mm"], "Fig. 6 — coefficient of restitution r = 0.86, 0.3 mm", "fig06_restitution_orbits")


def fig07(folder, man, numbers):
    _, d = read_csv(folder / man["fig07"]["file"])
    f7 = numbers["fig07"]
    paper, whole = f7["paper_speeds"], f7["whole_run_up"]
    z = d["z_m"] * UM
    fig, ax = plt.subplots(figsize=(6.0, 4.0), layout="constrained")
    ax.axvspan(z[0], whole["max_penetration_um"], color="tab:orange", alpha=0.12,
               label=f"reached over the whole run-up, to {whole['max_penetration_um']:.0f} µm")
    ax.axvspan(z[0], paper["max_penetration_um"], color="tab:orange", alpha=0.25,
               label=f"reached at {paper['from_rpm']:.0f}–{paper['to_rpm']:.0f} rpm, to {paper['max_penetration_um']:.1f} µm")
    ax.loglog(z, d["k1_z_N"], label="$k_1 z$ (piecewise-linear)")
    ax.loglog(z, d["k3_z3_N"], ls="--", label="$k_3 z^3$ (added by the piecewise-nonlinear law)")
    for r, ls in ((paper, ":"), (whole, "-.")):
        ax.axhline(r["c2_zdot2_at_max_rate_N"], color="tab:green", ls=ls, lw=0.9,
                   label=f"$c_2 \\dot z^2$ at {r['max_penetration_rate_m_s']:.3g} m/s, the fastest rate "
                         + ("at the paper's speeds" if r is paper else "over the run-up"))
    ax.axvline(f7["z_cubic_one_percent_um"], color="gray", ls=":", lw=0.9,
               label=f"$k_3 z^3$ = 1 % of $k_1 z$ ({f7['z_cubic_one_percent_um']:.0f} µm)")
    ax.set_xlabel("penetration z = y − δ [µm]")
    ax.set_ylabel("force [N]")
    ax.set_xlim(1e-2, z[-1])
    ax.set_ylim(1e-6, 1e5)
    ax.grid(True, which="major", lw=0.3)
    legend_below(fig, *ax.get_legend_handles_labels(), ncol=2)
    ax.set_title("Fig. 7 — contact force terms, 0.3 mm (Table 2)")
    save(fig, folder, "fig07_normal_force")


def fig08(folder, man):
    items = man["fig08"]
    lin = [i for i in items if i["variant"] == "piecewise-linear"]
    non = [i for i in items if i["variant"] == "piecewise-nonlinear"]
    fig, axes = plt.subplots(2, len(lin), figsize=(2.5 * len(lin), 5.0), layout="constrained",
                             gridspec_kw={"height_ratios": [3, 2]})
    for k, (a, b) in enumerate(zip(lin, non)):
        _, da = read_csv(folder / a["file"])
        _, db = read_csv(folder / b["file"])
        ax = axes[0][k]
        draw_orbit(ax, da, a["rpm"], revs=1, label="piecewise-linear" if k == 0 else None)
        draw_orbit(ax, db, b["rpm"], revs=1, color="tab:orange", ls=":", label="piecewise-nonlinear" if k == 0 else None,
                   arrows=False, dots=False)
        stator_line(ax, man["clearance_mm"], label=None if k == 0 else "")
        orbit_axes(ax, f"{a['rpm']:.0f} rpm", shared=True)
        per_rev = int(round(len(da) / ((da["t_s"][-1] - da["t_s"][0]) * a["rpm"] / 60.0)))
        dist = np.hypot(da["x_m"] - db["x_m"], da["y_m"] - db["y_m"])[:per_rev] * 1e9
        angle = np.arange(per_rev) * 360.0 / per_rev
        axes[1][k].semilogy(angle, np.maximum(dist, 1e-6), color="tab:purple", lw=0.8)
        axes[1][k].set_xlabel("shaft angle [°]")
        axes[1][k].set_xticks([0, 90, 180, 270, 360])
        axes[1][k].grid(True, lw=0.3)
    common_limits(axes[0])
    lo = min(ax.get_ylim()[0] for ax in axes[1])
    hi = max(ax.get_ylim()[1] for ax in axes[1])
    for ax in axes[1]:
        ax.set_ylim(lo, hi)
    axes[1][0].set_ylabel("distance between the orbits [nm]")
    legend_below(fig, *axes[0][0].get_legend_handles_labels(), ncol=4)
    fig.suptitle("Fig. 8 — piecewise-linear vs piecewise-nonlinear law, 0.3 mm")
    save(fig, folder, "fig08_piecewise_orbits")


def clearance_numbers(numbers, clearance_mm):
    for c in numbers["clearances"]:
        if abs(c["clearance_mm"] - clearance_mm) < 1e-9:
            return c
    raise KeyError(clearance_mm)


def hatch_ranges(ax, ranges, half_step, label=None):
    """Bands of grid speeds, each widened by half a grid step on both sides."""
    for k, (lo, hi) in enumerate(ranges):
        ax.axvspan(lo - half_step, hi + half_step, label=label if k == 0 else None, **HATCH)


def fig09(folder, man, numbers):
    c = clearance_numbers(numbers, man["clearance_mm"])
    half_step = man["sweep_grid_rpm"][2] / 2
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.0), layout="constrained", sharey=True)
    mesh = None
    for ax, direction in zip(axes, ("up", "down")):
        _, d = read_csv(folder / man["waterfall"][direction])
        speeds = np.unique(d["speed_rpm"])
        orders = np.unique(d["order"])
        grid = np.full((len(orders), len(speeds)), np.nan)
        si = np.searchsorted(speeds, d["speed_rpm"])
        oi = np.searchsorted(orders, d["order"])
        grid[oi, si] = d["amplitude_m"]
        db = 20.0 * np.log10(np.maximum(grid, 1e-12) / 1e-6)  # dB re 1 µm
        mesh = ax.pcolormesh(speeds, orders, db, shading="nearest", cmap="magma", vmin=-30, vmax=max(10.0, np.nanmax(db)),
                             rasterized=True)
        for o in (0.5, 1, 2, 3):
            for sign in (1, -1):
                ax.axhline(sign * o, color="w", lw=0.4, ls="--", alpha=0.6)
        ax.set_yticks([-4, -3, -2, -1, -0.5, 0, 0.5, 1, 2, 3, 4])
        ax.set_yticklabels(["−4X", "−3X", "−2X", "−1X", "−½X", "0", "½X", "1X", "2X", "3X", "4X"])
        ax.set_ylim(-4.2, 4.2)
        rub = c[f"rub_{direction}_rpm"]
        if rub:
            ax.axvline(rub[0][0], color="c", ls=":", lw=1.0, label=f"rub, {rub[0][0]:.0f}–{rub[-1][1]:.0f} rpm")
            ax.axvline(rub[-1][1], color="c", ls=":", lw=1.0)
        for k, (lo, hi) in enumerate(c[f"periods_{direction}"]["non_periodic_rpm"]):
            ax.axvspan(lo - half_step, hi + half_step, ymin=0.975, ymax=1.0, color="w", label="non-periodic" if k == 0 else None)
        ax.text(0.01, 0.955, "forward whirl", transform=ax.transAxes, va="top", color="w")
        ax.text(0.01, 0.03, "backward whirl", transform=ax.transAxes, va="bottom", color="w")
        ax.set_xlabel("speed [rpm]")
        ax.set_title("run-up" if direction == "up" else "run-down")
        ax.legend(loc="upper right", framealpha=0.6)
    axes[0].set_ylabel("shaft order (negative: backward)")
    fig.colorbar(mesh, ax=axes, label="full-spectrum amplitude [dB re 1 µm]", shrink=0.9)
    fig.suptitle(f"Fig. 9 — full spectrum vs speed, identified law, {man['clearance_mm']:g} mm")
    save(fig, folder, "fig09_spectrum_map")


def sweep_data(folder, man, variant, clearance_mm):
    for s in man["sweeps"]:
        if s["variant"] == variant and abs(s["clearance_mm"] - clearance_mm) < 1e-9:
            return read_csv(folder / s["file"])[1]
    raise KeyError(variant)


def branch_data(folder, man, clearance_mm):
    for b in man["branches"]:
        if abs(b["clearance_mm"] - clearance_mm) < 1e-9:
            return read_csv(folder / b["file"])[1], json.loads((folder / b["summary"]).read_text())
    raise KeyError(clearance_mm)


def plot_branch(ax, rpm, value, stable, color, label):
    """The branch in traced order, solid where stable and dashed where not."""
    start = 0
    first_stable = first_unstable = True
    for i in range(1, len(rpm) + 1):
        if i == len(rpm) or stable[i] != stable[start]:
            s = bool(stable[start])
            tag = None
            if s and first_stable:
                tag, first_stable = f"{label}, stable", False
            elif not s and first_unstable:
                tag, first_unstable = f"{label}, unstable", False
            ax.plot(rpm[start:i + 1], value[start:i + 1], color=color, lw=1.0, ls="-" if s else "--", label=tag)
            start = i


def folds(ax, summary, rpm_rows, value, color, label):
    first = True
    for f in summary["folds"]:
        k = f["after_point"]
        y = 0.5 * (value[k] + value[min(k + 1, len(value) - 1)])
        ax.plot(f["speed_rpm"], y, "D", color=color, ms=4, mfc="w", label=label if first else None, zorder=6)
        first = False


def sweep_rows(d, direction):
    rows = d[d["direction"] == direction]
    return rows[np.argsort(rows["speed_rpm"])]


def jump_arrows(ax, c, d, column, scale):
    for j in c["jumps"]:
        rows = sweep_rows(d, j["sweep"])
        a = rows[rows["speed_rpm"] == j["from_rpm"]][column][0] * scale
        b = rows[rows["speed_rpm"] == j["to_rpm"]][column][0] * scale
        ax.annotate("", xy=(j["to_rpm"], b), xytext=(j["from_rpm"], a),
                    arrowprops=dict(arrowstyle="-|>", color="k", lw=0.9, mutation_scale=10), zorder=7)


def fig10(folder, man, numbers):
    _, cf = read_csv(folder / man["contact_free"])
    clearances = [c["clearance_mm"] for c in numbers["clearances"]]
    fig, axes = plt.subplots(2, len(clearances), figsize=(4.0 * len(clearances), 5.6), layout="constrained", sharex=True, sharey="row")
    for k, c in enumerate(numbers["clearances"]):
        delta = c["clearance_mm"]
        d = sweep_data(folder, man, "identified", delta)
        br, summary = branch_data(folder, man, delta)
        top = axes[0][k]
        side = axes[1][k]
        first = k == 0
        # The orbit's top against the clearance, and the horizontal amplitude.
        top.plot(cf["speed_rpm"], cf["y_amplitude_m"] * MM, color="0.6", lw=0.8, label="contact-free (closed form)" if first else None)
        side.plot(cf["speed_rpm"], cf["x_amplitude_m"] * MM, color="0.6", lw=0.8)
        br_top = (br["max_z_m"] * MM + delta)
        br_side = br["peak_to_peak_x_m"] * MM / 2
        plot_branch(top, br["speed_rpm"], br_top, br["stable"], "tab:blue", "period-1 branch" if first else "_")
        plot_branch(side, br["speed_rpm"], br_side, br["stable"], "tab:blue", "_")
        folds(top, summary, br["speed_rpm"], br_top, "tab:blue", "fold" if first else None)
        folds(side, summary, br["speed_rpm"], br_side, "tab:blue", None)
        for direction, marker, color in (("up", "^", "tab:green"), ("down", "v", "tab:red")):
            rows = sweep_rows(d, direction)
            name = ("run-up" if direction == "up" else "run-down") if first else None
            top.plot(rows["speed_rpm"], rows["max_y_m"] * MM, marker, color=color, ms=1.6, ls="none", label=name)
            side.plot(rows["speed_rpm"], rows["peak_to_peak_x_m"] * MM / 2, marker, color=color, ms=1.6, ls="none")
        jump_arrows(top, c, d, "max_y_m", MM)
        jump_arrows(side, c, d, "peak_to_peak_x_m", MM / 2)
        top.axhline(delta, color="tab:red", lw=0.8, ls=":", label="clearance δ" if first else None)
        for ax in (top, side):
            hatch_ranges(ax, c["periods_up"]["non_periodic_rpm"] + c["periods_down"]["non_periodic_rpm"], man["sweep_grid_rpm"][2] / 2,
                         label="non-periodic (a sweep)" if first and ax is top else None)
            ax.grid(True, lw=0.3)
        top.set_title(f"clearance δ = {delta:g} mm")
        side.set_xlabel("speed [rpm]")
        top.set_ylim(0, 1.6 * max(d["max_y_m"].max() * MM, delta))  # the contact-free peak is clipped: it is not reached
        side.set_ylim(0, None)
        side.set_xlim(man["sweep_grid_rpm"][0], man["sweep_grid_rpm"][1])
    axes[0][0].set_ylabel("top of the orbit, max y [mm]")
    axes[1][0].set_ylabel("horizontal amplitude, ½ pk-pk x [mm]")
    axes[0][0].legend(loc="upper right")
    fig.suptitle("Fig. 10 — jump phenomenon, identified law")
    save(fig, folder, "fig10_jump")


def fig11(folder, man, numbers):
    delta = man["clearance_mm"]
    c = clearance_numbers(numbers, delta)
    d = sweep_data(folder, man, "identified", delta)
    br, _ = branch_data(folder, man, delta)
    fig, ax = plt.subplots(figsize=(6.5, 3.8), layout="constrained")
    ax.axvspan(*PAPER_BACKWARD_RPM, color="0.85", label="paper: backward > forward (1550–1670 rpm)")
    hatch_ranges(ax, c["periods_up"]["non_periodic_rpm"] + c["periods_down"]["non_periodic_rpm"], man["sweep_grid_rpm"][2] / 2,
                 label="non-periodic (a sweep)")
    plot_branch(ax, br["speed_rpm"], br["forward_1x_m"] * MM, br["stable"], "tab:blue", "forward 1X, period-1 branch")
    plot_branch(ax, br["speed_rpm"], br["backward_1x_m"] * MM, br["stable"], "tab:red", "backward 1X, period-1 branch")
    for direction, marker in (("up", "^"), ("down", "v")):
        rows = sweep_rows(d, direction)
        name = "run-up" if direction == "up" else "run-down"
        ax.plot(rows["speed_rpm"], rows["amp_f1x_m"] * MM, marker, color="tab:blue", ms=1.6, ls="none", label=f"forward 1X, {name}")
        ax.plot(rows["speed_rpm"], rows["amp_b1x_m"] * MM, marker, color="tab:red", ms=1.6, ls="none", label=f"backward 1X, {name}")
    ax.set_xlabel("speed [rpm]")
    ax.set_ylabel("1X amplitude [mm]")
    ax.set_xlim(man["sweep_grid_rpm"][0], man["sweep_grid_rpm"][1])
    ax.set_ylim(0, None)
    ax.grid(True, lw=0.3)
    ax.legend(ncol=2)
    ax.set_title(f"Fig. 11 — directional spectrum, identified law, {delta:g} mm")
    save(fig, folder, "fig11_directional_spectrum")


def fig12(folder, man):
    items = man["fig12"]
    clearances = sorted({i["clearance_mm"] for i in items})
    speeds = sorted({i["rpm"] for i in items})
    fig, axes = plt.subplots(len(clearances), len(speeds), figsize=(2.3 * len(speeds), 2.4 * len(clearances)),
                             layout="constrained", sharex=True, sharey=True)
    for item in items:
        row, col = clearances.index(item["clearance_mm"]), speeds.index(item["rpm"])
        ax = axes[row][col]
        _, d = read_csv(folder / item["file"])
        p = item["period_revs"]
        draw_orbit(ax, d, item["rpm"], revs=None if p != 1 else 1)
        stator_line(ax, item["clearance_mm"])
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.3)
        ax.set_title(f"δ = {item['clearance_mm']:g} mm, {item['rpm']:.0f} rpm" + ("" if p == 1 else f", {period_text(p)}"))
        if row == len(clearances) - 1:
            ax.set_xlabel("x [mm]")
        if col == 0:
            ax.set_ylabel("y [mm]")
    common_limits(axes)
    fig.suptitle("Fig. 12 — orbits of the identified law at three clearances (common axes)")
    save(fig, folder, "fig12_clearances")


def main():
    folder = Path(sys.argv[1])
    man = json.loads((folder / "data" / "figures.json").read_text())
    numbers = json.loads((folder / "reproduce.json").read_text())
    fig03(folder, man, numbers)
    fig05(folder, man)
    fig06(folder, man)
    fig07(folder, man, numbers)
    fig08(folder, man)
    fig09(folder, man, numbers)
    fig10(folder, man, numbers)
    fig11(folder, man, numbers)
    fig12(folder, man)


if __name__ == "__main__":
    main()
