"""stiffness.png in the manner of the paper's Fig. 8 (bars grouped by disk, a colour per tendon
state, a panel per orientation of the robot, each bar spanning the band eyelet friction sets) and
gravity.png in the manner of its Fig. 7 (the robot's shape under its own weight per state and
orientation), from the report of :func:`hwgen.model.stiffness.study`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .plots import pyplot, save

BAND_ALPHA = 0.35          # the part of a bar between the frictionless and the stuck stiffness


def _by(report: dict, friction: str, push: str | None = None) -> dict:
    """{orientation: [entries in state order]} of one friction."""
    out: dict = {}
    for e in report["states"]:
        if e["friction"] == friction and e.get("push") == push:
            out.setdefault(e["orientation"], []).append(e)
    return out


def plot_stiffness(report: dict, path: Path) -> None:
    """stiffness.png: :func:`stiffness_figure` written."""
    save(pyplot(), stiffness_figure(report), path)


def stiffness_figure(report: dict):
    """The Figure of stiffness.png: per orientation a panel, in it a bar per disk and state up to the
    frictionless stiffness (a colour per state, log scale), continued lighter up to the stuck one;
    the capstan stiffness at the tip as markers (▲ pushed toward +z, ▼ toward −z)."""
    plt = pyplot()
    from matplotlib.patches import Patch
    none, stuck = _by(report, "none"), _by(report, "stuck")
    caps = {k: _by(report, "capstan", k) for k in ("+z", "-z")}
    orientations = list(none)
    fig, axes = plt.subplots(len(orientations), 1, figsize=(10, 3.6 * len(orientations) + 0.6), squeeze=False)
    cmap = plt.get_cmap("viridis")
    r = report.get("endpoint_ratio", {})
    handles: dict = {}
    for ax, o in zip(axes[:, 0], orientations):
        states = none[o]
        n = len(states)
        disks = [d["disk"] for d in states[0]["disks"]]
        width = 0.8 / max(n, 1)
        x = np.arange(len(disks))
        colours = [cmap(j / max(n - 1, 1)) for j in range(n)]
        at = np.concatenate([x + (j - (n - 1) / 2) * width for j in range(n)])     # state by state, disk by disk
        lo = np.array([d["stiffness_n_per_mm"] for s in states for d in s["disks"]])
        hi = np.array([d["stiffness_n_per_mm"] for s in stuck[o] for d in s["disks"]])
        each = np.repeat(np.arange(n), len(disks))
        ax.bar(at, lo, width, color=[colours[j] for j in each])                  # one call: thousands of bars draw fast
        band = ax.bar(at, np.maximum(hi - lo, 0.0), width, bottom=lo, color=[colours[j] for j in each],
                      alpha=BAND_ALPHA)
        for patch in band:
            patch.set_gid("band")
        tips = at.reshape(n, len(disks))[:, -1]
        for key, marker in (("+z", "^"), ("-z", "v")):
            c = caps[key].get(o)
            if c:
                ax.plot(tips, [e["tip_stiffness_n_per_mm"] for e in c], marker, color="k", ms=4, ls="none",
                        label="_capstan")
        handles.setdefault("states", [Patch(color=colours[j], label=s["state"]) for j, s in enumerate(states)])
        ax.set_yscale("log")
        ax.set_xticks(x, [str(i + 1) for i in disks])        # the paper counts disks from 1 at the base
        ax.set_ylabel("stiffness along z (N/mm)")
        title = f"{o}: frictionless (solid) to every eyelet stuck (light)"
        if caps["+z"].get(o):
            title += "; ▲▼ capstan at the tip"
        row = [x for x in report.get("ratios", []) if x["orientation"] == o and x["friction"] in ("none", "stuck")]
        if r.get("states") and len(row) == 2:
            title += (f"\n{r['states'][0]}/{r['states'][1]} at the tip: {row[0]['tip']:.2f}× to {row[1]['tip']:.2f}× "
                      f"(paper: {r['paper']:g}×)")
        ax.set_title(title, fontsize=9)
        ax.grid(axis="y", which="both", alpha=0.3)
    axes[0, 0].legend(handles=handles["states"], ncol=min(len(handles["states"]), 9), fontsize=8, loc="upper right")
    axes[-1, 0].set_xlabel("tendon support disk (1 = base, clamped)")
    fig.subplots_adjust(left=0.08, right=0.98, top=1 - 0.5 / fig.get_figheight(), bottom=0.45 / fig.get_figheight(),
                        hspace=0.32)          # fixed margins: tight_layout measures every log tick label first
    return fig


def plot_gravity(report: dict, path: Path) -> None:
    """gravity.png: :func:`gravity_figure` written."""
    save(pyplot(), gravity_figure(report), path)


def gravity_figure(report: dict):
    """The Figure of gravity.png: per orientation a panel, in it the strip's shape per state."""
    plt = pyplot()
    none = _by(report, "none")
    orientations = list(none)
    fig, axes = plt.subplots(len(orientations), 1, figsize=(9, 3.4 * len(orientations) + 0.4), squeeze=False)
    cmap = plt.get_cmap("viridis")
    for ax, o in zip(axes[:, 0], orientations):
        states = none[o]
        n = len(states)
        for j, s in enumerate(states):
            c = s["curve"]
            ax.plot(c["y_mm"], c["z_mm"], color=cmap(j / max(n - 1, 1)),
                    label=f"{s['state']}: tip at z = {s['tip_z_mm']:+.1f} mm")
        ax.axhline(0.0, color="0.6", lw=0.8, ls="--")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_ylabel("z (mm)")
        g = report["orientations"].get(o)
        ax.set_title(f"{o}: " + ("the shape as tensioned, no weight" if g is None else
                                 f"shape under its own weight, gravity along {'−' if g[2] < 0 else '+'}z "
                                 "(cf. the paper's Fig. 7)"), fontsize=9)
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("y along the robot (mm)")
    fig.tight_layout()
    return fig
