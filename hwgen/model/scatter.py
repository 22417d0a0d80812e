"""As-built scatter: a seeded Monte Carlo of taut tendon lengths over the bending sweep (numpy).

Each sample is one build of the robot. Per printed hole (a shared hole once, for all its
tendons): its centre moves in its own plane by a 2-D Gaussian of σ_pos per axis and its
diameter by a Gaussian of σ_dia; free radius r = max(0, (D − d)/2). Per disk: it slips along
the backbone uniformly within the jig's station tolerance (a bound, not a σ), and it sits in its
slot anywhere the slot lets it: pitch about x with the offset in z, and yaw about z with the
offset in x, each pair uniform over the diamond |offset|/play + |angle|/tilt ≤ 1 that a
rectangular slot allows (a strip at its largest tilt has no room left to shift), roll about y
uniform within its range. The anchor (its seat on the base disk) and the end (the tangent
point on the tensioner's drum, which is fixed to the tip disk) ride their disks.

Every random number is drawn whatever the scatter, so a smaller scatter moves the same samples
less (the distribution narrows sample by sample) and zero scatter is the nominal print.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numpy as np

from . import taut

PERCENTILES = (5, 50, 95)   # the band drawn per angle

Solver = Callable[[taut.Chains, np.ndarray, float], tuple[np.ndarray, np.ndarray, int]]   # as taut.sweep


@dataclass(frozen=True)
class Robot:
    """The printed robot as the taut-path model sees it (disk frames: y = 0 at each mid-plane)."""

    stations: np.ndarray        # (ND,) arc length of each disk's mid-plane, mm
    hole_disk: np.ndarray       # (H,) disk of each physical hole
    hole_xz: np.ndarray         # (H, 2) where its axis crosses the mid-plane, mm
    hole_axis: np.ndarray       # (H, 3) unit, +y
    hole_diameter: np.ndarray   # (H,) mm
    chain: np.ndarray           # (T, ND) hole of tendon t at disk i
    anchor: np.ndarray          # (T, 3) in the base disk's frame
    end: np.ndarray             # (T, 3) in the tip disk's frame
    tendon_diameter: float
    length: float               # L, for θ = κL


@dataclass(frozen=True)
class Scatter:
    """What the process and the assembly leave free (mm, degrees); all zero: the nominal print."""

    sigma_pos: float = 0.0                  # hole centre, per in-plane axis (Gaussian σ)
    sigma_dia: float = 0.0                  # hole diameter (Gaussian σ)
    station: float = 0.0                    # disk slip along the backbone, uniform ±
    tilt: np.ndarray | None = None          # (ND, 3) half ranges about x, y, z, deg
    play: np.ndarray | None = None          # (ND, 2) half ranges of the offset in x and z
    hole_play: float | None = None          # if given, every hole's free radius is this (a what-if)

    def scaled(self, f: float) -> "Scatter":
        return replace(self, sigma_pos=f * self.sigma_pos, sigma_dia=f * self.sigma_dia, station=f * self.station,
                       tilt=None if self.tilt is None else f * self.tilt,
                       play=None if self.play is None else f * self.play)


def basis(axis: np.ndarray) -> np.ndarray:
    """(..., 3, 2): two unit vectors across each axis: the first toward +x, the second n × the first."""
    n = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    e1 = np.array([1.0, 0.0, 0.0]) - n[..., :1] * n
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return np.stack([e1, np.cross(n, e1)], axis=-1)


def _rotation(ax, ay, az) -> np.ndarray:
    """R_z(az) R_x(ax) R_y(ay), (..., 3, 3), angles in radians."""
    def rot(a, i, j):
        R = np.zeros(np.shape(a) + (3, 3))
        R[..., 0, 0] = R[..., 1, 1] = R[..., 2, 2] = 1.0
        R[..., i, i], R[..., j, j] = np.cos(a), np.cos(a)
        R[..., i, j], R[..., j, i] = -np.sin(a), np.sin(a)
        return R
    return rot(az, 0, 1) @ rot(ax, 1, 2) @ rot(ay, 2, 0)


def _diamond(rng, shape) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) uniform over |u| + |v| ≤ 1: a square turned by 45°."""
    p, q = rng.uniform(-1.0, 1.0, shape), rng.uniform(-1.0, 1.0, shape)
    return (p + q) / 2, (p - q) / 2


def chains(rb: Robot, sc: Scatter, n: int, seed: int) -> taut.Chains:
    """The solver's input for ``n`` as-built samples of ``rb`` under ``sc``."""
    H, ND = len(rb.hole_disk), len(rb.stations)
    rng = np.random.default_rng(seed)
    n_pos, n_dia = rng.standard_normal((n, H, 2)), rng.standard_normal((n, H))
    u_sta = rng.uniform(-1.0, 1.0, (n, ND))
    pitch, dz = _diamond(rng, (n, ND))
    yaw, dx = _diamond(rng, (n, ND))
    roll = rng.uniform(-1.0, 1.0, (n, ND))
    tilt = np.zeros((ND, 3)) if sc.tilt is None else np.asarray(sc.tilt, float)
    play = np.zeros((ND, 2)) if sc.play is None else np.asarray(sc.play, float)
    R = _rotation(*np.radians([pitch * tilt[:, 0], roll * tilt[:, 1], yaw * tilt[:, 2]]))   # (n, ND, 3, 3)
    shift = np.stack([dx * play[:, 0], np.zeros_like(dx), dz * play[:, 1]], axis=-1)      # (n, ND, 3)
    E0 = basis(rb.hole_axis)                                                                # (H, 3, 2)
    c0 = np.column_stack([rb.hole_xz[:, 0], np.zeros(H), rb.hole_xz[:, 1]])
    c = c0 + sc.sigma_pos * np.einsum("hij,shj->shi", E0, n_pos)
    if sc.hole_play is None:
        r = np.maximum(0.0, (rb.hole_diameter + sc.sigma_dia * n_dia - rb.tendon_diameter) / 2)
    else:
        r = np.full((n, H), float(sc.hole_play))
    Rh = R[:, rb.hole_disk]
    return taut.Chains(
        stations=np.asarray(rb.stations, float),
        C=np.einsum("shij,shj->shi", Rh, c) + shift[:, rb.hole_disk],
        E=np.einsum("shij,hjk->shik", Rh, E0),
        r=r, hole_disk=np.asarray(rb.hole_disk), dy=sc.station * u_sta, chain=np.asarray(rb.chain),
        anchor=np.einsum("sij,tj->sti", R[:, 0], rb.anchor) + shift[:, None, 0],
        end=np.einsum("sij,tj->sti", R[:, -1], rb.end) + shift[:, None, -1])


def centreline(rb: Robot, angles_deg, solve: Solver = taut.sweep) -> np.ndarray:
    """Lengths (T, K) through the hole centres of the nominal print, anchor and end included."""
    ch = chains(rb, Scatter(hole_play=0.0), 1, 0)
    L, _, _ = solve(ch, angles_deg, rb.length)
    return L[0]


@dataclass
class Result:
    """The Monte Carlo over the sweep. ΔL of each sample is from its own straight pose."""

    angles: np.ndarray          # (K,) deg
    centreline: np.ndarray      # (T, K) ΔL through the hole centres, nominal print
    nominal: np.ndarray         # (T, K) ΔL of the taut path, nominal print
    rest: np.ndarray            # (T,) taut rest length, nominal print
    band: np.ndarray            # (len(PERCENTILES), T, K) of ΔL over the samples
    envelope: np.ndarray        # (2, T, K) min, max of ΔL over the samples
    worst: np.ndarray           # (S, T) each sample's largest |ΔL| over the sweep
    take_up: np.ndarray | None  # (S,) each sample's largest −(ΔL1 + ΔL2) of the pair (slack), or None
    pair_nominal: tuple[float, float] | None   # the same through the centres, taut nominal
    unconverged: int


FIRST_LOOK = 1000      # samples drawn before the first look of a run that may stop early (then doubling)


def looks(n: int) -> list[int]:
    """The sample counts at which a run of at most ``n`` samples may stop: 1000, 2000, 4000, … and ``n``."""
    out, m = [], FIRST_LOOK
    while m < n:
        out.append(m)
        m *= 2
    return out + [n]


def run(rb: Robot, sc: Scatter, angles_deg, n: int, seed: int, pair: tuple[int, int] | None = None,
        enough: Callable[[np.ndarray, int], bool] | None = None, solve: Solver = taut.sweep) -> Result:
    """Nominal taut path, centre line and ``n`` samples; ``pair``: tendon indices of the actuating pair.

    ``enough(worst, looks)``: a run may stop at each of :func:`looks` ``(n)`` once it says so of the
    samples' largest |ΔL| so far ((S, T), as :attr:`Result.worst`; ``looks``: how many looks the run
    may take). The samples then come in batches, the first from ``seed``, batch ``j`` from
    ``(seed, j)``: the first m samples are the same whatever ``n`` and wherever the run stops.
    ``solve``: :func:`hwgen.model.taut.sweep` or what gives the same (every taut length worked out
    through it)."""
    ang = np.asarray(angles_deg, float)
    k0 = int(np.flatnonzero(ang == 0)[0])
    Lc = centreline(rb, ang, solve)
    dc = Lc - Lc[:, k0:k0 + 1]
    Ln, Ln0, bad0 = solve(chains(rb, replace(sc, sigma_pos=0.0, sigma_dia=0.0, station=0.0, tilt=None,
                                             play=None), 1, 0), ang, rb.length)
    dn = Ln[0] - Ln0[0][:, None]
    bad = 0
    if n and enough is not None:
        parts, done, marks = [], 0, looks(n)
        for j, m in enumerate(marks):
            L, L0, b = solve(chains(rb, sc, m - done, seed if j == 0 else [seed, j]), ang, rb.length)
            parts.append(L - L0[:, :, None])
            bad, done = bad + b, m
            if m < n and enough(np.abs(np.concatenate(parts)).max(axis=2), len(marks)):
                break
        dL = np.concatenate(parts)
        n = done
    elif n:
        L, L0, bad = solve(chains(rb, sc, n, seed), ang, rb.length)
        dL = L - L0[:, :, None]
    else:                   # no samples: the band and envelope are the nominal print's curve
        dL = dn[None]
    band = np.percentile(dL, PERCENTILES, axis=0)
    take_up = pair_nominal = None
    if pair is not None:
        i, j = pair
        take_up = -(dL[:, i] + dL[:, j]).min(axis=1)[:n]
        pair_nominal = (float(-(dc[i] + dc[j]).min()), float(-(dn[i] + dn[j]).min()))
    return Result(angles=ang, centreline=dc, nominal=dn, rest=Ln0[0], band=band,
                  envelope=np.stack([dL.min(axis=0), dL.max(axis=0)]), worst=np.abs(dL).max(axis=2)[:n],
                  take_up=take_up, pair_nominal=pair_nominal, unconverged=bad0 + bad)


def to_json(res: Result) -> dict:
    """A result as plain JSON values (:func:`from_json` gives it back, floats exactly)."""
    return {f.name: (v.tolist() if isinstance(v, np.ndarray) else v) for f in fields(res)
            for v in [getattr(res, f.name)]}


def from_json(doc: dict) -> Result:
    T = len(doc["rest"])
    arr = {k: np.asarray(doc[k], float) for k in ("angles", "centreline", "nominal", "rest", "band", "envelope")}
    return Result(**arr, worst=np.asarray(doc["worst"], float).reshape(-1, T),
                  take_up=None if doc["take_up"] is None else np.asarray(doc["take_up"], float),
                  pair_nominal=None if doc["pair_nominal"] is None else tuple(doc["pair_nominal"]),
                  unconverged=int(doc["unconverged"]))


def quantile_interval(values: np.ndarray, q: float, confidence: float) -> tuple[float, float]:
    """A distribution-free confidence interval on the ``q``-quantile (0 < q < 1) of what ``values``
    sample: the order statistics X(l) ≤ X(u) between which the quantile lies with probability at
    least ``confidence``, since the count of samples below it is binomial(n, q). (-inf, inf)
    where the samples are too few to bound it on a side."""
    x = np.sort(np.asarray(values, float))
    n, a = len(x), (1.0 - confidence) / 2
    lo = binomial_quantile(a, n, q)             # P(count < lo) ≤ a: X(lo), 1-based, lies below the quantile
    hi = binomial_quantile(1.0 - a, n, q) + 1   # P(count ≥ hi) ≤ a: X(hi) lies above it
    return (float(x[lo - 1]) if lo >= 1 else -np.inf, float(x[hi - 1]) if hi <= n else np.inf)


def binomial_quantile(p: float, n: int, q: float) -> int:
    """The smallest k with P(count ≤ k) ≥ p for count ~ binomial(n, q): scipy.stats' binom.ppf, from
    scipy.special's binomial CDF (scipy.stats is a costly import for a build; tests/test_taut.py
    holds the two equal)."""
    from scipy.special import bdtr
    cdf = bdtr(np.arange(n + 1), n, q)
    return int(min(np.searchsorted(cdf, p, side="left"), n))


def statistics(values: np.ndarray, budget: float | None = None) -> dict:
    """p50, p95, max of a sample, and the share within ``budget``."""
    out = {"p50_mm": float(np.percentile(values, 50)), "p95_mm": float(np.percentile(values, 95)),
           "max_mm": float(values.max())}
    if budget is not None:
        out["p_within"] = float(np.mean(values <= budget))
    return out


def percentile(values: np.ndarray, robust: str) -> float:
    """The statistic a verdict is taken on: "p50" … "p99" or "max"."""
    return float(values.max()) if robust == "max" else float(np.percentile(values, float(robust[1:])))
