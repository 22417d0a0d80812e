"""stiffness.png in the manner of the paper's Fig. 8 (bars grouped by disk, a colour per tendon
state) and gravity.png in the manner of its Fig. 7 (the robot's shape under its own weight per
state), from the report of :func:`hwgen.model.stiffness.study`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import _pyplot, _save


def plot_stiffness(report: dict, path: Path) -> None:
    """stiffness.png: :func:`stiffness_figure` written."""
    _save(_pyplot(), stiffness_figure(report), path)


def stiffness_figure(report: dict):
    """The Figure of stiffness.png: a bar per disk and state (a colour per state, log scale)."""
    plt = _pyplot()
    states = report["states"]
    disks = [d["disk"] for d in states[0]["disks"]]
    n = len(states)
    width = 0.8 / max(n, 1)
    fig, ax = plt.subplots(figsize=(10, 4.8))
    cmap = plt.get_cmap("viridis")
    x = np.arange(len(disks))
    for j, s in enumerate(states):
        k = [d["stiffness_n_per_mm"] for d in s["disks"]]
        ax.bar(x + (j - (n - 1) / 2) * width, k, width, label=s["state"], color=cmap(j / max(n - 1, 1)))
    ax.set_yscale("log")
    ax.set_xticks(x, [str(i + 1) for i in disks])        # the paper counts disks from 1 at the base
    ax.set_xlabel("tendon support disk (1 = base, clamped)")
    ax.set_ylabel("transverse stiffness, flexible direction (N/mm)")
    r = report.get("endpoint_ratio", {})
    title = "predicted stiffness per tendon state (robot horizontal under its own weight)"
    if r.get("ratio"):
        title += f"\n{r['states'][0]}/{r['states'][1]} at the tip: {r['ratio']:.2f}× (paper: {r['paper']:g}×)"
    ax.set_title(title, fontsize=10)
    ax.grid(axis="y", which="both", alpha=0.3)
    ax.legend(ncol=min(n, 9), fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig


def plot_gravity(report: dict, path: Path) -> None:
    """gravity.png: :func:`gravity_figure` written."""
    _save(_pyplot(), gravity_figure(report), path)


def gravity_figure(report: dict):
    """The Figure of gravity.png: the strip's shape per state, one line each."""
    plt = _pyplot()
    states = report["states"]
    fig, ax = plt.subplots(figsize=(9, 4.5))
    cmap = plt.get_cmap("viridis")
    n = len(states)
    for j, s in enumerate(states):
        c = s["curve"]
        ax.plot(c["y_mm"], c["z_mm"], color=cmap(j / max(n - 1, 1)),
                label=f"{s['state']}: tip {s['tip_sag_mm']:.1f} mm down")
    ax.axhline(0.0, color="0.6", lw=0.8, ls="--")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("y along the robot (mm)")
    ax.set_ylabel("z, up (mm)")
    ax.set_title("shape under its own weight, flexible direction along gravity (cf. the paper's Fig. 7)", fontsize=10)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
