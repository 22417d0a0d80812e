"""Where each tendon passes each disk: tables, eq. (3) functions and mirrors (numpy only)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..params import Design, RoutingFunction
from .settings import Termination, termination

DEFAULT_BUDGET_MM = 0.2  # the paper's claim for the stiffening tendons (Sect. IV-A)


def sample_function(f: RoutingFunction, stations, length: float) -> np.ndarray:
    """Sample an eq. (3) path at arc lengths s = stations; returns (N, 2) columns x, z."""
    s = np.asarray(stations, dtype=float)
    th = f.k * np.pi * s / length + np.radians(f.phase_deg)
    x = np.full_like(s, f.x0)
    z = np.full_like(s, f.z0)
    if f.kind == "cosine":
        if f.axis == "z":
            z = z + f.a * np.cos(th)
        else:
            x = x + f.a * np.cos(th)
    elif f.kind == "helix":
        z = z + f.a * np.cos(th)
        x = x + f.a * np.sin(th)
    # float noise such as cos(pi/2) = 6e-17 would make "on the backbone plane" tests flaky
    return np.column_stack([x, z]).round(12)


@dataclass(frozen=True)
class TendonPath:
    """One tendon: its eyelet positions (x, z) at every station, in mm."""

    name: str
    channel: str
    points: np.ndarray              # (N, 2): the geometry's eyelet centres
    function_points: np.ndarray | None  # (N, 2): the named eq. (3) function, where given with a table
    budget_mm: float | None         # allowed length change; None = no budget (actuating)
    source: str                     # "table" or "function"
    pretension_n: float | None      # what it is pulled to at its turn in the protocol, N (None: the protocol finds it)
    termination: Termination        # how it ends at the base disk: its own, else the material's
    mirrored_from: str | None = None


def tendon_paths(d: Design) -> list[TendonPath]:
    """Every tendon of the design, mirrors expanded, in YAML order."""
    out: list[TendonPath] = []
    st = d.stations
    for t in d.tendons:
        r = t.routing
        fpts = sample_function(r.function, st, d.backbone.length) if r.function is not None else None
        pts = np.asarray(r.table, dtype=float) if r.table is not None else fpts
        budget = t.budget_mm
        if budget is None and t.channel != d.tensioner.actuating_channel:
            budget = DEFAULT_BUDGET_MM
        src = "table" if r.table is not None else "function"
        term = termination(t.termination if t.termination is not None else d.tendon_material.termination)
        out.append(TendonPath(t.name, t.channel, pts, fpts if r.table is not None else None, budget, src,
                              t.pretension_n, term))
        if r.mirror:
            flip = np.array([1.0, -1.0])
            out.append(TendonPath(t.names[1], t.channel, pts * flip,
                                  None if fpts is None or r.table is None else fpts * flip,
                                  budget, src, t.pretension_n, term, mirrored_from=t.name))
    return out


@dataclass(frozen=True)
class Deviation:
    tendon: str
    station: int
    table: tuple[float, float]
    function: tuple[float, float]
    distance: float


def table_deviations(paths: list[TendonPath]) -> list[Deviation]:
    """Station-by-station distance between a tendon's table and the function it names."""
    out = []
    for p in paths:
        if p.function_points is None:
            continue
        dist = np.linalg.norm(p.points - p.function_points, axis=1)
        for j, dj in enumerate(dist):
            out.append(Deviation(p.name, j, tuple(p.points[j]), tuple(p.function_points[j]), float(dj)))
    return out
