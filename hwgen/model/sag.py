"""Own-weight sag of the robot lying horizontal with no tendon tensioned: the paper's state N
(Sect. III-B; the letter N is Fig. 8's). numpy and scipy only.

Model. The carbon-fibre strip is a planar, inextensible, unshearable Kirchhoff rod (the
elastica), clamped at s = 0 with a horizontal tangent, hanging in the vertical plane that holds
its thin (flexible) direction. s is arc length from the clamp, y horizontal along the
undeformed strip, z vertical (up), ψ(s) the tangent angle from +y (negative: pointing down).

Loads, all dead and vertical: the strip's weight w = λg per mm; point weights P_j = m_j g at
arc lengths s_j (the disks, their centres of mass on the centre line); and the tip assembly
P_c = m_c g fixed to the tip frame with its centre of mass at (a along the tip tangent, b along
the tip normal), which loads the tip with P_c and the moment -P_c (a cos ψ_L - b sin ψ_L).
Every load being vertical, the internal force at s is (0, -W(s)) with W(s) the weight beyond s,
and the rod's moment balance m' + r' × n = 0 with m = EI(s) ψ' reads

    ψ' = M / EI(s),     M' = W(s) cos ψ,     ψ(0) = 0,     M(L) = -P_c (a cos ψ_L - b sin ψ_L).

EI(s) is the strip's E·I except over ``spans`` given with their own stiffness (a disk's hub,
glued to the strip, adds its walls' E·I; infinite holds the strip straight). The strip's bending
stress is |M| (t/2) E / EI(s): the strip's share of the moment where a span stiffens it.

Solver. Shooting on the tip angle ψ_L: (ψ, M) are integrated from the tip to the base with a
fixed-step classical RK4 whose mesh has every station and span end as a node (each step sees
a smooth right-hand side; the load jumps are exact); y and z alongside. The residual ψ(0; ψ_L)
is scanned over ψ_L in [-π, π] in one vectorised integration, each sign change refined with
Brent's method; where a heavy load admits several equilibria (the others loop the strip over
itself) the one with the least potential energy (bending + gravity) is kept, the stable state
reached by loading the straight strip. At the 1 mm default step the error is about 1e-12 of the
tip sag (it falls as h⁴).

The small-deflection (Euler-Bernoulli) estimate with the same loads and undeformed lever arms
is computed too (unit-load method, 3-point Gauss per step): it is the upper bound of the base
moment, and useless for the sag once the robot carries its tensioner.

Units: mm, g (masses), N, N·mm, MPa; g in m/s².

This module was written as a standalone prototype for hwgen (its checks against closed forms,
the Bisshopp-Drucker elastica and an independent collocation solver are in tests/test_sag.py).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

G_ACC = 9.81             # m/s²: standard gravity (9.80665 changes results by 0.03 %)
SCAN_POINTS = 181        # tip angles tried over [-π, π] to bracket every equilibrium
STATION_TOL = 1e-9       # mm: a station this close to a mesh node is on it


@dataclass(frozen=True)
class Span:
    """A stretch of strip [start, end] (arc length, mm) with its own bending stiffness EI (N·mm²);
    math.inf holds it straight."""

    start: float
    end: float
    ei: float


@dataclass(frozen=True)
class Strip:
    """The clamped strip's section: E (MPa), I (mm⁴), thickness (mm, for the stress) and weight
    per length (g/mm)."""

    E: float
    I: float
    thickness: float
    lin_density: float


@dataclass(frozen=True)
class Tip:
    """The tip assembly's mass (g) and the offset (a, b) of its centre of mass in the tip frame, mm."""

    mass: float = 0.0
    offset: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class SagLoads:
    """What a solve was given, as floats: the clamp-to-tip length ``L`` (mm), the point loads'
    ``stations`` (mm) and ``point_masses`` (g), the ``strip``'s section and weight, the ``tip``
    assembly, gravity ``g`` (m/s²) and the stiffened ``spans``: enough to solve again with another
    section (:mod:`hwgen.checks.gravity`'s strip study) or to check the solution's statics."""

    L: float
    stations: np.ndarray
    point_masses: np.ndarray
    strip: Strip
    tip: Tip
    g: float
    spans: tuple

    @property
    def EI(self) -> float:
        """N·mm², the strip's own bending stiffness (the spans' are their own)."""
        return self.strip.E * self.strip.I


@dataclass(frozen=True)
class LinearSag:
    """The small-deflection estimate under the same loads: the tip's drop (mm), its angle (rad), the
    base moment (N·mm) and the deflection ``z`` on the solver's mesh."""

    tip_sag: float
    tip_angle: float
    base_moment: float
    z: np.ndarray


@dataclass(frozen=True)
class SagSolve:
    """How the elastica was solved: the integration steps, the residual |ψ(0)| at the solution (rad),
    the equilibria the scan found, the rejected (higher-energy) ones' tip angles (rad), seconds."""

    n_steps: int = 0
    residual: float = 0.0
    n_roots_in_scan: int = 0
    other_tip_angles: tuple = ()
    seconds: float = 0.0


@dataclass
class SagResult:
    """What :func:`solve_sag` finds: the deflected strip along the solver's mesh and its figures,
    with the ``loads`` it was solved for, the ``linear`` estimate and the ``solver``'s figures.
    Lengths mm, forces N, moments N·mm, stress MPa."""

    s: np.ndarray            # solver mesh, base at index 0
    y: np.ndarray
    z: np.ndarray
    psi: np.ndarray          # rad, tangent angle from +y (negative: pointing down)
    moment: np.ndarray       # N·mm, M = EI ψ' (negative: hogging under gravity)
    weight_beyond: np.ndarray  # N, W(s)
    stress: np.ndarray       # MPa, the strip's bending stress along s
    tip_y: float
    tip_z: float
    tip_sag: float           # mm, the tip station's drop (= -tip_z)
    tip_angle: float         # rad, ψ(L)
    base_moment: float       # N·mm, M(0)
    base_stress: float       # MPa, the strip's stress at s = 0
    max_stress: float        # MPa, the largest along s
    s_max_stress: float      # mm, where it is
    tip_com: tuple           # (y, z) of the tip assembly's centre of mass, deformed
    loads: SagLoads
    linear: LinearSag
    solver: SagSolve = field(default_factory=SagSolve)
    info: dict = field(default_factory=dict)

    @property
    def tip_angle_deg(self) -> float:
        return math.degrees(self.tip_angle)

    @property
    def total_weight(self) -> float:
        """N: everything the strip carries beyond the clamp."""
        return float(self.weight_beyond[0])


def second_moment(width: float, thickness: float) -> float:
    """I = h t³ / 12 of the strip about its thin direction's neutral axis, mm⁴."""
    return width * thickness ** 3 / 12.0


def _ei_at(spans, EI: float, mid: float) -> float:
    for sp in spans:
        if sp.start < mid < sp.end:
            return sp.ei
    return EI


def _mesh(L, stations, spans, h_max):
    """Segments (lo, hi, steps, EI): every station and span end is a node."""
    pts = [0.0, L] + [float(s) for s in stations if 0.0 < s < L]
    for sp in spans:
        pts += [min(max(sp.start, 0.0), L), min(max(sp.end, 0.0), L)]
    bp = np.unique(np.round(np.asarray(pts, float), 12))
    return [(lo, hi, max(1, math.ceil((hi - lo) / h_max - 1e-9)), mid)
            for lo, hi in zip(bp[:-1], bp[1:]) if hi - lo > 1e-12 for mid in [0.5 * (lo + hi)]]


class _Problem:
    """Loads made ready; :meth:`shoot` integrates tip -> base."""

    def __init__(self, L, stations, masses, strip: Strip, tip: Tip, spans, g, h_max):
        self.L, self.EI = float(L), float(strip.E * strip.I)
        kg = 1e-3 * g                                  # N per g
        self.w = strip.lin_density * kg
        self.P = np.asarray(masses, float) * kg
        self.st = np.asarray(stations, float)
        self.Pc = tip.mass * kg
        self.a, self.b = float(tip.offset[0]), float(tip.offset[1])
        self.segs = [(lo, hi, n, _ei_at(spans, self.EI, mid)) for lo, hi, n, mid in _mesh(L, stations, spans, h_max)]
        # the weight of the tip assembly and of every point load at or beyond each segment's end
        self.C = [self.Pc + float(self.P[self.st >= hi - 1e-12].sum()) for (_, hi, _, _) in self.segs]
        self.n_steps = sum(n for (_, _, n, _) in self.segs)

    def tip_moment(self, psiL):
        return -self.Pc * (self.a * np.cos(psiL) - self.b * np.sin(psiL))

    def shoot(self, psiL, path=False):
        """ψ(0) for a tip angle (scalar, math module: fastest for one trajectory); with ``path``
        the whole trajectory (s, ψ, M, y, z), base first, y and z relative to the tip."""
        L, w = self.L, self.w
        psi = float(psiL)
        M = float(self.tip_moment(psiL))
        y = z = 0.0
        if path:
            S, PSI, MM, Y, Z = [L], [psi], [M], [0.0], [0.0]
        cos, sin = math.cos, math.sin
        for (lo, hi, n, ei), C in zip(reversed(self.segs), reversed(self.C)):
            c = 0.0 if math.isinf(ei) else 1.0 / ei
            h = (hi - lo) / n
            hh = 0.5 * h
            s = hi
            for _ in range(n):
                # RK4 with ds = -h; state (ψ, M, y, z)
                W1 = C + w * (L - s)
                W2 = C + w * (L - s + hh)
                W3 = C + w * (L - s + h)
                k1p = c * M
                k1m = W1 * cos(psi)
                p2, m2 = psi - hh * k1p, M - hh * k1m
                k2p, k2m = c * m2, W2 * cos(p2)
                p3, m3 = psi - hh * k2p, M - hh * k2m
                k3p, k3m = c * m3, W2 * cos(p3)
                p4, m4 = psi - h * k3p, M - h * k3m
                k4p, k4m = c * m4, W3 * cos(p4)
                if path:
                    y -= h / 6.0 * (cos(psi) + 2 * cos(p2) + 2 * cos(p3) + cos(p4))
                    z -= h / 6.0 * (sin(psi) + 2 * sin(p2) + 2 * sin(p3) + sin(p4))
                psi -= h / 6.0 * (k1p + 2 * k2p + 2 * k3p + k4p)
                M -= h / 6.0 * (k1m + 2 * k2m + 2 * k3m + k4m)
                s -= h
                if path:
                    S.append(s)
                    PSI.append(psi)
                    MM.append(M)
                    Y.append(y)
                    Z.append(z)
        if path:
            return tuple(np.array(v[::-1]) for v in (S, PSI, MM, Y, Z))
        return psi

    def shoot_many(self, psiL):
        """ψ(0) for many tip angles at once (the bracketing scan)."""
        L, w = self.L, self.w
        psi = np.array(psiL, float)
        M = self.tip_moment(psi)
        for (lo, hi, n, ei), C in zip(reversed(self.segs), reversed(self.C)):
            c = 0.0 if math.isinf(ei) else 1.0 / ei
            h = (hi - lo) / n
            hh = 0.5 * h
            s = hi
            for _ in range(n):
                W1 = C + w * (L - s)
                W2, W3 = W1 + w * hh, W1 + w * h
                k1p, k1m = c * M, W1 * np.cos(psi)
                p2, m2 = psi - hh * k1p, M - hh * k1m
                k2p, k2m = c * m2, W2 * np.cos(p2)
                p3, m3 = psi - hh * k2p, M - hh * k2m
                k3p, k3m = c * m3, W2 * np.cos(p3)
                p4, m4 = psi - h * k3p, M - h * k3m
                k4p, k4m = c * m4, W3 * np.cos(p4)
                psi = psi - h / 6.0 * (k1p + 2 * k2p + 2 * k3p + k4p)
                M = M - h / 6.0 * (k1m + 2 * k2m + 2 * k3m + k4m)
                s -= h
        return psi

    def weight_beyond(self, s):
        s = np.asarray(s, float)
        W = self.Pc + self.w * (self.L - s)
        for sj, Pj in zip(self.st, self.P):
            W = W + np.where(s < sj - STATION_TOL, Pj, 0.0)
        return W

    def ei_nodes(self, s):
        """EI at each node (the segment to its right; the last node takes the last segment's)."""
        out = np.empty(len(s))
        for k, sk in enumerate(s):
            seg = next((g for g in self.segs if g[0] - 1e-12 <= sk < g[1] - 1e-12), self.segs[-1])
            out[k] = seg[3]
        return out


def _linear(prob: _Problem, s_nodes):
    """Small-deflection Euler-Bernoulli solution with the same loads (undeformed lever arms):
    tip deflection and slope by the unit-load method (3-point Gauss per step: the integrands are
    piecewise cubic), the shape on the nodes by cumulative trapezoids (plots only)."""
    L, w, Pc, a = prob.L, prob.w, prob.Pc, prob.a

    def M_lin(s):
        s = np.asarray(s, float)
        m = w * (L - s) ** 2 / 2 + Pc * (L + a - s)
        for sj, Pj in zip(prob.st, prob.P):
            m = m + np.where(s < sj, Pj * (sj - s), 0.0)
        return -m

    gx, gw = np.polynomial.legendre.leggauss(3)
    xs, ws, cs = [], [], []
    for lo, hi, n, ei in prob.segs:
        if math.isinf(ei):
            continue
        edges = np.linspace(lo, hi, n + 1)
        half = 0.5 * np.diff(edges)[:, None]
        x = (half * gx + 0.5 * (edges[1:] + edges[:-1])[:, None]).ravel()
        xs.append(x)
        ws.append((half * gw).ravel())
        cs.append(np.full(x.shape, 1.0 / ei))
    xs = np.concatenate(xs) if xs else np.zeros(0)
    ws = np.concatenate(ws) if ws else np.zeros(0)
    cs = np.concatenate(cs) if cs else np.zeros(0)
    m = M_lin(xs) * cs
    theta = float(np.sum(ws * m))
    delta = float(np.sum(ws * m * (L - xs)))
    ei = prob.ei_nodes(s_nodes)
    kap = np.where(np.isinf(ei), 0.0, M_lin(s_nodes) / np.where(np.isinf(ei), 1.0, ei))
    ds = np.diff(s_nodes)
    slope = np.concatenate([[0.0], np.cumsum(0.5 * (kap[1:] + kap[:-1]) * ds)])
    zlin = np.concatenate([[0.0], np.cumsum(0.5 * (slope[1:] + slope[:-1]) * ds)])
    return dict(tip_z=delta, tip_angle=theta, base_moment=float(M_lin(0.0)), z=zlin)


def _equilibria(prob: _Problem, n_scan: int = SCAN_POINTS):
    """Every tip angle in [-π, π] with ψ(0) = 0: a vectorised scan brackets each sign change,
    Brent's method refines it."""
    grid = np.linspace(-math.pi, math.pi, n_scan)
    f = prob.shoot_many(grid)
    roots = []
    for k in range(n_scan - 1):
        if f[k] == 0.0:
            roots.append(float(grid[k]))
        elif f[k] * f[k + 1] < 0:
            roots.append(brentq(prob.shoot, grid[k], grid[k + 1], xtol=1e-14, rtol=4 * np.finfo(float).eps,
                                maxiter=200))
    if f[-1] == 0.0:
        roots.append(float(grid[-1]))
    if not roots:
        raise RuntimeError("no equilibrium found for a tip angle in [-π, π]")
    return roots


def _potential_energy(prob: _Problem, path):
    """Bending plus gravity potential of an equilibrium, N·mm."""
    s, psi, M, y, z = path
    ei = prob.ei_nodes(s)
    e = np.where(np.isinf(ei), 0.0, 0.5 * M ** 2 / np.where(np.isinf(ei), 1.0, ei))
    U = float(np.sum(0.5 * (e[1:] + e[:-1]) * np.diff(s)))
    z0 = z - z[0]
    V = prob.w * float(np.sum(0.5 * (z0[1:] + z0[:-1]) * np.diff(s)))
    V += float(np.sum(prob.P * np.interp(prob.st, s, z0)))
    psiL = psi[-1]
    V += prob.Pc * (z0[-1] + prob.a * math.sin(psiL) + prob.b * math.cos(psiL))
    return U + V


def solve_sag(L: float, stations, point_masses, strip: Strip, *, tip: Tip = Tip(), g: float = G_ACC,
              spans=(), h_max: float = 1.0) -> SagResult:
    """Own-weight deflection of the clamped strip (elastica) and its small-deflection estimate.

    L: clamp (s = 0) to the tip station; stations, point_masses: where the point loads are
    (0 ≤ s_j ≤ L) and their masses in g; ``strip``: its section and weight; ``tip``: the tip
    assembly's mass and offset; spans: :class:`Span` stretches with their own EI; h_max: largest step.
    """
    E, I, thickness, strip_lin_density = strip.E, strip.I, strip.thickness, strip.lin_density
    tip_mass, tip_offset = tip.mass, tip.offset
    t0 = time.perf_counter()
    stations = np.atleast_1d(np.asarray(stations, float))
    point_masses = np.atleast_1d(np.asarray(point_masses, float))
    if stations.shape != point_masses.shape:
        raise ValueError("stations and point_masses must have the same length")
    if np.any(stations < 0) or np.any(stations > L + 1e-9):
        raise ValueError("stations must lie in [0, L]")
    if np.any(point_masses < 0) or tip_mass < 0:
        raise ValueError("masses must be non-negative")
    spans = tuple(spans)
    EI = E * I
    prob = _Problem(L, stations, point_masses, strip, tip, spans, g, h_max)
    if prob.w == 0 and prob.Pc == 0 and not np.any(prob.P[stations > 0] > 0):
        roots = [0.0]
    else:
        roots = _equilibria(prob)
    best = None
    for root in roots:
        path = prob.shoot(root, path=True)
        energy = _potential_energy(prob, path) if len(roots) > 1 else 0.0
        if best is None or energy < best[0]:
            best = (energy, root, path)
    _, psiL, (s, psi, M, y, z) = best
    y, z = y - y[0], z - z[0]                           # the base at the origin
    W = prob.weight_beyond(s)
    ei = prob.ei_nodes(s)
    share = np.where(np.isinf(ei), 0.0, EI / np.where(np.isinf(ei), 1.0, ei))
    stress = np.abs(M) * (thickness / 2.0) / I * share
    k = int(np.argmax(stress))
    a, b = prob.a, prob.b
    com = (float(y[-1] + a * math.cos(psiL) - b * math.sin(psiL)),
           float(z[-1] + a * math.sin(psiL) + b * math.cos(psiL)))
    lin = _linear(prob, s)
    loads = SagLoads(L=float(L), stations=stations, point_masses=point_masses,
                     strip=Strip(float(E), float(I), float(thickness), float(strip_lin_density)),
                     tip=Tip(float(tip_mass), (float(a), float(b))), g=float(g), spans=spans)
    linear = LinearSag(tip_sag=float(-lin["tip_z"]), tip_angle=float(lin["tip_angle"]),
                       base_moment=float(lin["base_moment"]), z=lin["z"])
    solver = SagSolve(n_steps=prob.n_steps, residual=abs(float(psi[0])), n_roots_in_scan=len(roots),
                      other_tip_angles=tuple(float(x) for x in roots if x != psiL), seconds=time.perf_counter() - t0)
    return SagResult(
        s=s, y=y, z=z, psi=psi, moment=M, weight_beyond=W, stress=stress,
        tip_y=float(y[-1]), tip_z=float(z[-1]), tip_sag=float(-z[-1]), tip_angle=float(psiL),
        base_moment=float(M[0]), base_stress=float(stress[0]), max_stress=float(stress[k]),
        s_max_stress=float(s[k]), tip_com=com, loads=loads, linear=linear, solver=solver)


def base_moment_from_statics(r: SagResult) -> float:
    """The base moment from the deformed geometry alone: -(each weight × its horizontal lever arm
    about the clamp), N·mm. Independent of the ODE's moment variable."""
    ld = r.loads
    kg = 1e-3 * ld.g
    m = 0.0
    for sj, mj in zip(ld.stations, ld.point_masses):
        if sj > 0:
            m += mj * kg * np.interp(sj, r.s, r.y)
    m += ld.strip.lin_density * kg * float(np.sum(0.5 * (r.y[1:] + r.y[:-1]) * np.diff(r.s)))
    m += ld.tip.mass * kg * r.tip_com[0]
    return -m


def bending_stress_under_uniform_moment(length: float, angle_rad: float, E: float, I: float, thickness: float,
                                        spans=()) -> tuple[float, float]:
    """The strip bent to a total angle by a moment uniform along it (an actuating pair at a constant
    offset, eq. (1)'s load), with stiffer spans: (largest stress in the strip, MPa; the curvature
    where the strip is bare, 1/mm). The angle is ∫ M / EI(s) ds; the bare strip takes M / (E I)."""
    EI = E * I
    flexible = length
    soft = 0.0
    for sp in spans:
        lo, hi = max(sp.start, 0.0), min(sp.end, length)
        if hi <= lo:
            continue
        flexible -= hi - lo
        if not math.isinf(sp.ei):
            soft += (hi - lo) * EI / sp.ei
    kappa = angle_rad / (flexible + soft)
    return E * thickness / 2 * abs(kappa), kappa
