"""A sweep's summary: the best variants as a table (summary.md) and two plots (matplotlib).

- ``tradeoff.png``: the coupling figure against the least wall (clearance), coloured by mass. The
  coupling figure is the level's strongest: the actuating tension's rise (coupling level and
  above), else the worst budgeted tendon's length change as built (robust), else by eq. (2)
  through the hole centres (lengths).
- ``region.png``: the decoupled region over two axes (the sweep file's ``summary.axes``, else the
  first two numeric axes): a point per pair of their values, the best over any other axes, circled
  where every budgeted tendon keeps its budget, with the worst length change as its colour (log
  scale). One numeric axis: that change
  against the axis with the budget drawn in.

"Best": passing variants first, then the smallest coupling figure, then the lightest.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pyarrow as pa

from ..atomic import write_text
from ..outputs.plots import pyplot, save
from .spec import Loaded

ORDER = {"pass": 0, "fail": 1, "error": 2, "bad input": 3}


def figure_column(t: pa.Table) -> tuple[str, str]:
    """(column, label) of the coupling figure this table has."""
    for col, label in (("coupling", "actuating tension rise (share)"),
                       ("robust_mm", "worst budgeted ΔL as built (mm)"),
                       ("centre_mm", "worst budgeted ΔL by eq. (2) (mm)")):
        if col in t.column_names and t.column(col).null_count < len(t):
            return col, label
    return "centre_mm", "worst budgeted ΔL by eq. (2) (mm)"


def best(loaded: Loaded, t: pa.Table, n: int) -> list[dict]:
    col, _ = figure_column(t)
    rows = t.to_pylist()

    def key(r):
        f = r.get(col)
        return (ORDER.get(r["verdict"], 9), math.inf if f is None else f, r.get("mass_g") or math.inf, r["variant"])
    return sorted(rows, key=key)[:n]


def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v).replace("|", "\\|")


def markdown(loaded: Loaded, t: pa.Table, n: int) -> str:
    col, label = figure_column(t)
    verdicts = {}
    for v in t.column("verdict").to_pylist():
        verdicts[v] = verdicts.get(v, 0) + 1
    head = ["variant", *loaded.names, "verdict", col, "taut_mm", "clearance_mm", "mass_g", "hash"]
    lines = [f"# Sweep {loaded.spec.sweep} ({loaded.spec.level})", "",
             f"Base design: `{loaded.base_path.name}`; {len(t)} variants: "
             + ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items())) + ".", "",
             f"Best {n} (passing first, then by {label}, then by mass):", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in best(loaded, t, n):
        cells = [r["variant"], *(r[name] for name in loaded.names), r["verdict"], r.get(col), r.get("taut_mm"),
                 r.get("clearance_mm"), r.get("mass_g"), r["hash"][:12]]
        lines.append("| " + " | ".join(_fmt(c) for c in cells) + " |")
    return "\n".join(lines) + "\n"


def write(loaded: Loaded, t: pa.Table, folder: Path) -> list[Path]:
    """summary.md, tradeoff.png and region.png in ``folder``; returns the files written."""
    n = loaded.spec.summary.best
    write_text(folder / "summary.md", markdown(loaded, t, n))
    out = [folder / "summary.md"]
    _tradeoff(loaded, t, folder / "tradeoff.png")
    out.append(folder / "tradeoff.png")
    if _region(loaded, t, folder / "region.png"):
        out.append(folder / "region.png")
    return out


def _values(t: pa.Table, col: str) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in t.column(col).to_pylist()])


def _tradeoff(loaded: Loaded, t: pa.Table, path: Path) -> None:
    plt = pyplot()
    col, label = figure_column(t)
    y, x, m = _values(t, col), _values(t, "clearance_mm"), _values(t, "mass_g")
    ok = np.isfinite(x) & np.isfinite(y)
    fig, ax = plt.subplots(figsize=(7, 5))
    if ok.any():
        sc = ax.scatter(x[ok], y[ok], c=m[ok], cmap="viridis", s=14)
        fig.colorbar(sc, ax=ax, label="mass of disks and strip (g)")
        if col != "coupling" and np.nanmin(y[ok]) > 0:
            ax.set_yscale("log")
    ax.set_xlabel("least wall around an eyelet hole (mm)")
    ax.set_ylabel(label)
    ax.set_title(f"sweep {loaded.spec.sweep}: coupling against clearance against mass ({int(ok.sum())} variants)")
    ax.grid(True, alpha=0.3)
    save(plt, fig, path)


def _region(loaded: Loaded, t: pa.Table, path: Path) -> bool:
    numeric = [n for n in loaded.names if loaded.columns[n] != "json"]
    axes = list(loaded.spec.summary.axes or numeric[:2])
    if not axes:
        return False
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 5))
    dec = np.array([bool(v) for v in t.column("decoupled").to_pylist()])
    known = np.array([v is not None for v in t.column("decoupled").to_pylist()])
    worst = _values(t, "centre_mm")
    if len(axes) == 1:
        x = _values(t, axes[0])
        order = np.argsort(x)
        ax.plot(x[order], worst[order], "-o", color="tab:blue", markersize=4)
        ax.scatter(x[dec & known], worst[dec & known], color="tab:green", zorder=3, label="decoupled")
        budgets = {b for r in t.column("per_tendon").to_pylist() if r for b in _budgets(r)}
        for b in sorted(budgets):
            ax.axhline(b, color="grey", linestyle=":", linewidth=0.8)
        if np.nanmin(worst) > 0:
            ax.set_yscale("log")
        ax.set_xlabel(axes[0])
        ax.set_ylabel("worst budgeted ΔL by eq. (2) (mm)")
        ax.legend(fontsize="small")
    else:
        x, y, dec, known, worst = _cells(_values(t, axes[0]), _values(t, axes[1]), dec, known, worst)
        pos = worst[np.isfinite(worst) & (worst > 0)]
        norm = None
        if pos.size:
            from matplotlib.colors import LogNorm
            norm = LogNorm(vmin=pos.min(), vmax=max(pos.max(), pos.min() * 1.0001))
        sel = known & np.isfinite(worst)
        sc = ax.scatter(x[sel & ~dec], y[sel & ~dec], c=worst[sel & ~dec], norm=norm, cmap="magma_r", marker="x", s=18,
                        label="coupled")
        ax.scatter(x[sel & dec], y[sel & dec], c=worst[sel & dec], norm=norm, cmap="magma_r", marker="o", s=30,
                   edgecolors="tab:green", label="decoupled")
        ax.scatter(x[~known], y[~known], color="lightgrey", marker=".", s=8, label="bad input only")
        fig.colorbar(sc, ax=ax, label="worst budgeted ΔL by eq. (2) (mm)")
        ax.set_xlabel(axes[0])
        ax.set_ylabel(axes[1])
        ax.legend(fontsize="small")
    ax.set_title(f"sweep {loaded.spec.sweep}: the decoupled region")
    ax.grid(True, alpha=0.3)
    save(plt, fig, path)
    return True


def _cells(x, y, dec, known, worst):
    """One point per (x, y): the best over every other axis (the smallest worst change; decoupled
    if any variant there is; bad input only if every one is)."""
    cells: dict[tuple, list[int]] = {}
    for i, key in enumerate(zip(x, y)):
        cells.setdefault(key, []).append(i)
    out = []
    for (cx, cy), idx in cells.items():
        idx = np.asarray(idx)
        w = worst[idx][known[idx]]
        w = w[np.isfinite(w)]
        out.append((cx, cy, bool((dec[idx] & known[idx]).any()), bool(known[idx].any()),
                    float(w.min()) if w.size else np.nan))
    cx, cy, cd, ck, cw = (np.array(c) for c in zip(*out))
    return cx.astype(float), cy.astype(float), cd.astype(bool), ck.astype(bool), cw.astype(float)


def _budgets(tendons_json: str) -> list[float]:
    import json
    return [t["budget_mm"] for t in json.loads(tendons_json) if t.get("budget_mm") is not None]


