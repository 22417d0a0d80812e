"""Length change against bending angle, in the manner of the paper's Fig. 6: every tendon on
top, the budgeted (stiffening) tendons zoomed below with their budgets drawn in."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import atomic_path


def plot_lengths(report: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    finally:
        plt.close(fig)
