"""sim.png: MuJoCo against the statics, from sim.json: the strip's centre line in each compared state
and bent (side view), with the independent Cosserat rod's in state N and bent, and the tip
stiffness of each state, both models side by side."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs.plots import pyplot, save


def sim_figure(result: dict):
    """The Figure of sim.png."""
    plt = pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [1.6, 1]})
    cmap = plt.get_cmap("viridis")
    cases = [(s["state"], s["mujoco_curve"], s["statics_curve"]) for s in result["states"]]
    b = result.get("bent") or {}
    if b:
        cases.append((f"{b['tendon']} at {b['tension_n']:.1f} N", b["mujoco_curve"], b["statics_curve"]))
    for j, (label, mj, st) in enumerate(cases):
        c = cmap(j / max(len(cases) - 1, 1))
        ax.plot(st["y_mm"], st["z_mm"], color=c, lw=3, alpha=0.35)
        ax.plot(mj["y_mm"], mj["z_mm"], color=c, lw=1.2, ls="--", label=label)
    ref = result.get("reference") or {}
    rods = [r["curve"] for r in ref.values() if isinstance(r, dict) and "curve" in r]
    for curve in rods:
        ax.plot(curve["y_mm"], curve["z_mm"], color="tab:red", lw=0.8, ls=":")
    ax.plot([], [], color="k", lw=3, alpha=0.35, label="statics (hwgen stiffness)")
    ax.plot([], [], color="k", lw=1.2, ls="--", label="MuJoCo (robot.xml)")
    if rods:
        ax.plot([], [], color="tab:red", lw=0.8, ls=":", label="Cosserat rod (independent)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("y along the robot (mm)")
    ax.set_ylabel("z, gravity along -z (mm)")
    ax.set_title("centre line at rest under its own weight", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    names = [s["state"] for s in result["states"]]
    x = np.arange(len(names))
    mj = [s["mujoco_tip_n_per_mm"] for s in result["states"]]
    st = [s["statics_tip_n_per_mm"] for s in result["states"]]
    bx.bar(x - 0.2, st, 0.4, label="statics", color="0.6")
    bx.bar(x + 0.2, mj, 0.4, label="MuJoCo", color="tab:blue")
    for xi, a, s in zip(x, mj, st):
        bx.text(xi + 0.2, a, f"{a / s:.3f}×", ha="center", va="bottom", fontsize=8)
    bx.set_xticks(x, names)
    bx.set_ylabel("tip stiffness, flexible direction (N/mm)")
    bx.set_title(f"{result['design']}: MuJoCo against the statics (limit ±{result['agreement_limit']:.0%})",
                 fontsize=10)
    bx.legend(fontsize=8)
    bx.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def plot_sim(result: dict, path: Path) -> None:
    """sim.png: :func:`sim_figure` written."""
    save(pyplot(), sim_figure(result), path)
