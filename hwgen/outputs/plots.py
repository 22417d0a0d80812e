"""Length change against bending angle, in the manner of the paper's Fig. 6: every tendon on
top, the budgeted (stiffening) tendons zoomed below with their budgets drawn in."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display), imported when a plot is drawn."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save(plt, fig, path: Path) -> None:
    """Write the figure as a PNG whole or not at all, and free it."""
    # the figures lay themselves out once (tight_layout), which leaves a placeholder layout engine
    # behind; with one, savefig draws the whole figure an extra time first. Without it the pixels
    # are the same
    fig.set_layout_engine(None)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    finally:
        plt.close(fig)


def plot_lengths(report: dict, path: Path) -> None:
    """lengths.png: :func:`lengths_figure` written."""
    save(pyplot(), lengths_figure(report), path)


def lengths_figure(report: dict):
    """The matplotlib Figure of lengths.png: every tendon's ΔL over the sweep on top (one line
    each, labelled by name); the budgeted ones below with ±budget lines."""
    plt = pyplot()

    ang = np.asarray(report["sweep"]["angles_deg"])
    tendons = report["tendons"]
    stiff = [t for t in tendons if t["budget_mm"] is not None]
    fig, axes = plt.subplots(2 if stiff else 1, 1, figsize=(7, 7.5 if stiff else 4), squeeze=False)
    top = axes[0, 0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    col = {t["name"]: colors[i % len(colors)] for i, t in enumerate(tendons)}
    for t in tendons:
        top.plot(ang, t["delta_mm"], color=col[t["name"]], label=t["name"],
                 linestyle="-" if t["budget_mm"] is None else "--")
    top.set_title(f"{report['design']}: tendon length change (from the exported geometry)")
    top.set_ylabel("ΔL (mm)")
    top.legend(ncol=3, fontsize="small")
    if stiff:
        bot = axes[1, 0]
        for t in stiff:
            mark = "" if t["passed"] else " (over budget)"
            bot.plot(ang, t["delta_mm"], color=col[t["name"]], label=t["name"] + mark)
        for b in sorted({t["budget_mm"] for t in stiff}):
            bot.axhline(b, color="grey", linewidth=0.8, linestyle=":")
            bot.axhline(-b, color="grey", linewidth=0.8, linestyle=":")
            bot.text(ang[0], b, f" budget ±{b:g} mm", va="bottom", fontsize="small", color="grey")
        bot.set_title("zoom: stiffening tendons")
        bot.set_ylabel("ΔL (mm)")
        bot.legend(fontsize="small")
    for ax in axes[:, 0]:
        ax.axhline(0, color="black", linewidth=0.5)
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("constant-curvature bending angle (deg)")
    fig.tight_layout()
    return fig


def plot_sag(report: dict, design_report: dict, path: Path) -> bool:
    """sag.png (:func:`sag_figure`); False (and nothing written) when the report has no gravity state."""
    fig = sag_figure(report, design_report)
    if fig is None:
        return False
    save(pyplot(), fig, path)
    return True


def sag_figure(report: dict, design_report: dict):
    """The Figure of sag.png: the robot's own-weight state N seen from the side, like the first
    photograph of Sect. III-B: the deformed strip, every disk to scale square to it, the tip
    assembly's centre of mass, the clamp, the straight line it would keep without weight, and the
    numbers. None when the report has no gravity state."""
    g = report.get("gravity") or {}
    if not g.get("curve"):
        return None
    plt = pyplot()
    from matplotlib.patches import Polygon, Rectangle

    c = g["curve"]
    s, y, z, psi = (np.asarray(c[k], float) for k in ("s_mm", "y_mm", "z_mm", "psi_deg"))
    psi = np.radians(psi)
    disks = {d["index"]: d for d in design_report["disks"]}
    st = design_report["stations_mm"]
    fig, ax = plt.subplots(figsize=(10, 6.2), dpi=110)
    clamp = 30.0
    ax.add_patch(Rectangle((-clamp, -12), clamp, 24, facecolor="0.8", edgecolor="0.3", hatch="///", lw=0.8, zorder=1))
    ax.plot([-clamp, g["length_mm"] + max(g["tip_assembly"]["a_mm"], 0)], [0, 0], "--", color="0.5", lw=1,
            label="without its weight")
    corners_all = [np.column_stack([y, z])]
    for i, d in disks.items():
        si = float(st[i])
        p = float(np.interp(si, s, psi))
        ctr = np.array([np.interp(si, s, y), np.interp(si, s, z)])
        tn, nn = np.array([np.cos(p), np.sin(p)]), np.array([-np.sin(p), np.cos(p)])
        r, th = d["outer_diameter_mm"] / 2, d["thickness_mm"]
        pts = [ctr + u * th / 2 * tn + v * r * nn for u, v in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        ax.add_patch(Polygon(pts, closed=True, facecolor="#e8d9a0", edgecolor="#6b5d1c", lw=0.7, zorder=4))
        corners_all.append(np.array(pts))
    ax.plot(y, z, color="k", lw=2.5, zorder=5, label="strip (elastica)")
    tip = g["tip_assembly"]
    if tip["mass_g"] > 0:
        com = np.asarray(c["tip_com_mm"])
        ax.plot([y[-1], com[0]], [z[-1], com[1]], color="#1f4e79", lw=1, zorder=6)
        ax.plot(*com, marker="o", ms=10, color="#1f4e79", zorder=7)
        ax.annotate(f"tip assembly {tip['mass_g']:.0f} g (centre of mass)", com, xytext=(-10, -18),
                    textcoords="offset points", fontsize=8, color="#1f4e79", ha="right")
        corners_all.append(com[None, :])
    ax.annotate("", xy=(y[-1], z[-1]), xytext=(y[-1], 0.0), arrowprops=dict(arrowstyle="<->", color="tab:red"))
    case = g["cases"][g["gravity"]]
    ax.text(y[-1] + 4, z[-1] / 2, f"sag {case['tip_sag_mm']:.1f} mm", color="tab:red", fontsize=9)
    pts = np.vstack(corners_all)
    lo, hi = pts.min(axis=0) - 12, pts.max(axis=0) + 12
    lo[0] = min(lo[0], -clamp - 40)
    ax.annotate("", xy=(lo[0] + 15, -25), xytext=(lo[0] + 15, 15), arrowprops=dict(arrowstyle="-|>", lw=1.8))
    ax.text(lo[0] + 19, -5, "g", fontsize=12, style="italic")
    ok = case["max_stress_mpa"] <= g["allowable_stress_mpa"]
    ax.text(0.99, 0.98, f"tip sag {case['tip_sag_mm']:.1f} mm, tip {case['tip_angle_deg']:.1f}° below horizontal\n"
                        f"strip stress {case['max_stress_mpa']:.0f} MPa at s = {case['s_max_stress_mm']:.1f} mm "
                        f"(allowable {g['allowable_stress_mpa']:g}: {'OK' if ok else 'OVER'})\n"
                        f"base moment {case['base_moment_nmm']:.0f} N·mm, carried {case['carried_weight_n']:.2f} N\n"
                        f"EI = {g['EI_nmm2']:.3g} N·mm² (E = {g['E_mpa'] / 1000:g} GPa); "
                        f"bare strip: {g['uniform_strip']['tip_sag_mm']:.0f} mm",
            transform=ax.transAxes, ha="right", va="top", fontsize=8.5,
            bbox=dict(boxstyle="round", facecolor="white", edgecolor="0.6"))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(min(lo[1], -50), max(hi[1], 60) + 45)        # room for the numbers above the robot
    ax.set_aspect("equal")
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.set_xlabel("horizontal (mm)")
    ax.set_ylabel("vertical (mm)")
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(f"{report['design']}: own weight, no tendon tensioned (state N), flexible direction along gravity")
    fig.tight_layout()
    return fig


def plot_tolerance(report: dict, path: Path) -> bool:
    """tolerance.png (:func:`tolerance_figure`); False (and nothing written) without a budgeted tendon."""
    fig = tolerance_figure(report)
    if fig is None:
        return False
    save(pyplot(), fig, path)
    return True


def tolerance_figure(report: dict):
    """The Figure of tolerance.png, like the lower panel of Fig. 6 for each budgeted tendon (a
    column each): ΔL against the bending angle through the hole centres (eq. (2)), along the taut
    path of the nominal print, and the as-built spread (p5-p95 band, p50, min-max envelope)
    against ±budget; below, the histogram of each sample's largest |ΔL| with the budget and the
    verdict's statistic. None without a budgeted tendon."""
    tb = (report.get("as_built") or {}).get("taut")
    if not tb:
        return None
    rows = [(k, r) for k, r in enumerate(tb["tendons"]) if r["budget_mm"] is not None]
    if not rows:
        return None
    plt = pyplot()

    ang = np.asarray(tb["angles_deg"], float)
    band, env = np.asarray(tb["band_mm"], float), np.asarray(tb["envelope_mm"], float)
    centre = {t["name"]: np.asarray(t["delta_mm"], float) for t in report["tendons"]}
    n = tb["samples"]
    fig, axes = plt.subplots(2 if n else 1, len(rows), figsize=(4.4 * len(rows), 6.8 if n else 4.2), squeeze=False,
                             gridspec_kw=dict(height_ratios=[2.2, 1] if n else [1]))
    for col, (k, r) in enumerate(rows):
        ax, b = axes[0, col], r["budget_mm"]
        if n:
            ax.fill_between(ang, env[0, k], env[1, k], color="tab:blue", alpha=0.12, lw=0, label="as built, min–max")
            ax.fill_between(ang, band[0, k], band[-1, k], color="tab:blue", alpha=0.35, lw=0, label="as built, p5–p95")
            ax.plot(ang, band[1, k], color="tab:blue", lw=0.8, label="as built, p50")
        ax.plot(ang, r["taut_delta_mm"], color="k", lw=1.6, label="taut path, nominal print")
        ax.plot(ang, centre[r["name"]], color="tab:green", lw=1.3, ls="--", label="eq. (2), hole centres")
        for s in (1, -1):
            ax.axhline(s * b, color="tab:red", ls=":", lw=1.2, label="budget" if s == 1 else None)
        ax.axhline(0, color="0.6", lw=0.5)
        ax.set_xlim(ang[0], ang[-1])
        ax.set_xlabel("bending angle θ = κL (deg)")
        ax.set_title(f"{r['name']}: {r['robust_mm']:.3f} mm at {tb['robust'] if n else 'nominal'} — "
                     f"{'passes' if r['passed'] else 'fails'}", fontsize=10)
        ax.grid(alpha=0.3)
        if col == 0:
            ax.set_ylabel("L(θ) − L(0) (mm)")
            ax.legend(fontsize=7)
        if n:
            hx, hist = axes[1, col], r["histogram"]
            edges = np.asarray(hist["edges_mm"], float)
            hx.stairs(hist["counts"], edges, fill=True, color="tab:blue", alpha=0.7)
            hx.axvline(b, color="tab:red", ls=":", lw=1.4, label=f"budget {b:g} mm")
            hx.axvline(r["centreline_max_abs_delta_mm"], color="tab:green", ls="--", lw=1.2, label="eq. (2)")
            hx.axvline(r["taut_max_abs_delta_mm"], color="k", lw=1.4, label="taut, nominal")
            hx.axvline(r["robust_mm"], color="tab:blue", ls="-.", lw=1.2, label=tb["robust"])
            hx.set_xlim(0, edges[-1])
            hx.set_xlabel("largest |ΔL| over the sweep (mm)")
            hx.grid(alpha=0.3)
            if col == 0:
                hx.set_ylabel(f"samples (of {n})")
                hx.legend(fontsize=7)
    p = tb["process"]
    fig.suptitle(f"{report['design']}: budgeted tendons as built, taut path through the measured holes; {n} samples "
                 f"(σ_pos {p['position_sigma_mm']:g}, σ_dia {p['diameter_sigma_mm']:g}, "
                 f"station ±{p['station_tolerance_mm']:g} mm, "
                 f"tilt and play as measured)", fontsize=9)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return fig


