"""Taut tendon paths: the shortest line a tendon can take through the free apertures of its holes.

A hole of diameter D passes a tendon of diameter d with (D − d)/2 of play. A taut tendon does
not run through hole centres (eq. (2)); it takes the shortest path the hole walls allow. Each
hole is modelled as a disc in its own plane (normal = the hole's axis) at the hole's centre, of
free radius r = (D − d)/2 (r = 0: the centre itself). For one tendon at one bending angle:

    minimise  F(w) = Σ_m |P_m − P_{m−1}|,  P_{−1} = a,  P_j = c_j + E_j w_j,  P_N = b,  |w_j| ≤ r_j

a the anchor (base disk frame), b the end (tip disk frame), E_j a 3×2 basis of aperture j's
plane. A sum of norms of affine maps over discs: convex (an SOCP); its minimum is the taut length.

Solver: projected Newton with an active set. Each w_j meets only its two segments, so the
Hessian is block tridiagonal with 2×2 blocks and one Newton step costs O(N). A point on its
rim is *active*: pinned radially, free along the rim, whose curvature adds μ = −g·u/r ≥ 0
(the contact force per unit tension) to the tangential stiffness; it is released when the
gradient points outward. Backtracking on F keeps every step a descent step. Stop: the Newton
decrement (the predicted length decrease) under ``tol`` with no active-set change.

Sweep: θ = 0 cold, to TOL_REST (L(0) enters every ΔL), then outward in θ, each angle started
from the linear extrapolation of the two before; one Newton step per angle is then usual.
Vectorised over samples (numba, parallel), every tendon and angle of a sample in one task.
The compiled code is in :mod:`.taut_kernels` (numba, compiled once per machine and cached on
disk), imported when first needed: commands that check nothing do not import numba.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

TOL = 1e-8          # Newton decrement λ²/2 (mm of predicted length decrease) along the sweep: error ~1e-9 mm


@dataclass(frozen=True)
class Chains:
    """Every tendon's apertures for S samples, in the straight robot's disk frames.

    Hole h sits on disk ``hole_disk[h]``: centre ``C[s, h]``, plane basis ``E[s, h]`` (columns)
    and free radius ``r[s, h]``, already moved by that sample's print scatter and the disk's tilt
    and offset on the strip, in the disk's own frame (origin on the backbone at its station, y
    along the backbone, y = 0 at its mid-plane). ``stations`` are the mid-planes' arc lengths,
    ``dy[s, i]``: disk i's slip along the backbone. ``chain[t, j]``: the hole
    of tendon t's j-th aperture. ``anchor[s, t]`` is in the base disk's frame, ``end[s, t]`` in
    the tip disk's."""

    stations: np.ndarray      # (ND,) mm
    C: np.ndarray             # (S, H, 3)
    E: np.ndarray             # (S, H, 3, 2)
    r: np.ndarray             # (S, H)
    hole_disk: np.ndarray     # (H,) int
    dy: np.ndarray            # (S, ND)
    chain: np.ndarray         # (T, N) int
    anchor: np.ndarray        # (S, T, 3)
    end: np.ndarray           # (S, T, 3)


def sweep(ch: Chains, angles_deg, length: float, tol: float = TOL) -> tuple[np.ndarray, np.ndarray, int]:
    """Taut lengths over the sweep: L (S, T, K), L at θ = 0 (S, T), and how many solves did not
    converge. ``angles_deg`` must increase strictly."""
    ang = np.asarray(angles_deg, dtype=float)
    if np.any(np.diff(ang) <= 0):
        raise ValueError("angles must increase strictly")
    k0 = int(np.searchsorted(ang, 0.0))
    up = np.arange(k0 + (1 if k0 < len(ang) and ang[k0] == 0 else 0), len(ang))
    down = np.arange(k0 - 1, -1, -1)
    S, T = ch.C.shape[0], ch.chain.shape[0]
    L = np.empty((S, T, len(ang)))
    L0 = np.empty((S, T))
    bad = np.zeros(S, np.int64)
    f = np.ascontiguousarray
    from . import taut_kernels as k        # deferred: see the module's docstring
    k.sweep_kernel(f(ch.stations, float), np.radians(ang) / length, up, down, f(ch.C, float), f(ch.E, float),
                  f(ch.r, float), f(ch.hole_disk, np.int64), f(ch.dy, float), f(ch.chain, np.int64),
                  f(ch.anchor, float), f(ch.end, float), tol, L, L0, bad)
    if k0 < len(ang) and ang[k0] == 0:
        L[:, :, k0] = L0
    return L, L0, int(bad.sum())


def tendons(ch: Chains, which) -> Chains:
    """The chains of tendons ``which`` (indices) alone. A tendon's solves read only its own holes,
    anchor and end and the disks' stations and slips, each starting from its own last: a sweep of
    these gives, to the bit, their rows of the sweep of ``ch`` (the disks' frames, worked out once
    per sample and angle for every tendon of a sweep, are why a sweep of many costs less than
    sweeps of each)."""
    which = np.asarray(which, np.int64)
    return replace(ch, chain=ch.chain[which], anchor=ch.anchor[:, which], end=ch.end[:, which])


def shortest(a, b, C, E, r, tol: float | None = None) -> tuple[float, np.ndarray, bool]:
    """One chain in world coordinates, solved cold: (length, aperture coordinates w (N, 2), converged)."""
    from . import taut_kernels as k
    f = np.ascontiguousarray
    a, b, C, E, r = f(a, float), f(b, float), f(C, float), f(E, float), f(r, float)
    w = np.zeros((len(r), 2))
    act = np.zeros(len(r), np.int8)
    k.cold_start(a, b, C, E, r, w, act)
    F, ok = k.newton(a, b, C, E, r, w, act, k.TOL_REST if tol is None else tol, k.workspace(len(r)))
    return F, w, ok


