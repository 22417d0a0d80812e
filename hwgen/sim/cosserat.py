"""A Cosserat rod solved as a boundary-value problem: the independent reference the MuJoCo model
is checked against (numpy only; :mod:`hwgen.sim.independent` builds the robot from a build).

Formulation: the static Cosserat rod of Rucker & Webster (2011, IEEE T-RO 27(6)), with shear
and extension, in its strong form along arc length s:

    p' = R v,   R' = R û,   n' = −f,   m' = −p' × n,
    v = e_y + K_se⁻¹ Rᵀ n,   u = K_bt⁻¹ Rᵀ m,

p the centre line, R the section's frame (x across the strip's height, y along the rod, z
through its thickness), n and m the internal force and moment (what the rod beyond s exerts on
the rod before it), f the strip's weight per length, K_bt = diag(E·I_x, G·J, E·I_z) and
K_se = diag(κGA, EA, κGA). The frame is a unit quaternion, q' = ½ q ⊗ (0, u).

The rod is a sequence of pieces from a clamp: flexible stretches (the strip, bare or with a
glued hub's section added) and rigid ones (a disk's plate, and at the end the tip body: the tip
disk, the tensioner, the strip it clamps, the steel). A rigid piece carries point weights and
eyelets; across it the state jumps by the rigid body's balance,

    n_b = n_a − Σ F_i,   m_b = m_a − (p_b − p_a) × n_b − Σ (x_i − p_a) × F_i,

and beyond the last piece the rod is free (n = m = 0). A tendon pulled with a tension τ (Rucker
& Webster's tension-controlled case, partially supported: straight between eyelets, as the
paper's eq. (2)) pulls each eyelet it passes toward both its neighbours, τ(û_next + û_prev),
its last eyelet toward the one before; the run beyond the tip eyelet to its drum is inside the
tip body. Those directions depend on where the disks downstream go, so the unknowns are the
force and moment at the clamp and the world position of every tensioned tendon's eyelet on a
moving piece; the residuals are the free end's force and moment and each eyelet's position as
the shot puts it against the one assumed. Newton's method on a forward-difference Jacobian
(every column shot at once, vectorised), the loads brought in over a few steps from the
unloaded rod (continuation). Each flexible stretch is integrated by the classical RK4 at
:data:`H_MAX` with its ends as nodes, so every load jump is exact.

Units: mm, N, N·mm, g (masses), MPa.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..model.sag import G_ACC
from ..model.statics import blas_threads
from .cosserat_kernel import rk4

H_MAX = 1.0                      # mm: RK4 step (the prototype's tip moves by under 1e-7 mm at 0.5 or 0.25 mm)
LOAD_STEPS = (0.25, 0.5, 0.75, 1.0)
NEWTON_ITER = 40
TOL_N = 1e-9                     # N: the free end's force left (and N·mm / mm of its moment)
TOL_MM = 1e-7                    # mm: an eyelet's assumed position against the shot's
FD = {"n": 1e-6, "m": 1e-4, "e": 1e-6}    # forward-difference steps: N, N·mm, mm


@dataclass(frozen=True)
class Flexible:
    """A stretch of strip [start, end] (arc length, mm): K_bt (N·mm², about x, y, z), K_se (N,
    shear along x, extension along y, shear along z) and its mass per length (g/mm)."""

    start: float
    end: float
    bending: tuple[float, float, float]
    shear: tuple[float, float, float]
    weight: float


@dataclass(frozen=True)
class Rigid:
    """A rigid stretch [start, end] and what it carries: point masses (g, at a point of the body
    frame: the straight robot's coordinates less (0, start, 0)) and, per tendon, the eyelet it
    has here (same frame)."""

    start: float
    end: float
    masses: tuple[tuple[float, tuple[float, float, float]], ...] = ()
    eyelets: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Rod:
    """Pieces from the clamp (at pieces[0].start, frame the robot's, straight along +y) to the free
    end, and each tendon's eyelets fixed to the ground before the clamp (world points, base first)."""

    pieces: tuple
    ground_eyelets: dict = field(default_factory=dict)

    def tendon_path(self, name: str) -> list[tuple[int | None, np.ndarray]]:
        """(piece index, or None on the ground; point) of each eyelet of a tendon, base to tip."""
        out = [(None, np.asarray(x, float)) for x in self.ground_eyelets.get(name, ())]
        out += [(k, np.asarray(pc.eyelets[name], float)) for k, pc in enumerate(self.pieces)
                if isinstance(pc, Rigid) and name in pc.eyelets]
        return out


@dataclass(frozen=True)
class Loads:
    """Gravity (unit direction, world; None: weightless) and tendons pulled with a tension (N)."""

    gravity: tuple[float, float, float] | None = None
    tensions: dict = field(default_factory=dict)
    g: float = G_ACC


@dataclass
class Solution:
    """A solved rod: the force and moment at the clamp, the frame at each piece's start (and the
    free end), the centre line, Newton's iterations and the residual left."""

    rod: Rod
    loads: Loads
    n0: np.ndarray
    m0: np.ndarray
    starts: list                  # (p, R) at each piece's start, then at the free end
    s: np.ndarray                 # centre line: arc length, mm
    p: np.ndarray                 # (k, 3) mm
    iterations: int
    residual: float

    def point(self, piece: int, local) -> np.ndarray:
        """A point of a rigid piece's body frame (or of a flexible piece's start frame) in the world."""
        p, R = self.starts[piece]
        return p + R @ np.asarray(local, float)


# ------------------------------------------------------------------ kinematics, batched over columns

def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a × b of (B, 3) arrays (numpy's cross costs ten times as much on small ones)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def _rotation(q: np.ndarray) -> np.ndarray:
    """(B, 4) unit quaternions (w, x, y, z) -> (B, 3, 3)."""
    w, x, y, z = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def _integrate(state, piece: Flexible, f: np.ndarray, curve: list | None):
    """RK4 over a flexible piece (:func:`hwgen.sim.cosserat_kernel.rk4`); ``curve`` collects (s, p of
    column 0) at each step."""
    p, q, n, m = state
    length = piece.end - piece.start
    steps = max(1, math.ceil(length / H_MAX - 1e-9))
    Y = np.ascontiguousarray(np.concatenate([p, q, n, m], axis=1))
    path = np.empty((steps, 3))
    rk4(Y, float(length), steps, np.asarray(piece.bending, float), np.asarray(piece.shear, float),
        np.asarray(f, float), path)
    if curve is not None:
        curve += [(piece.start + (k + 1) * length / steps, path[k]) for k in range(steps)]
    return Y[:, 0:3], Y[:, 3:7], Y[:, 7:10], Y[:, 10:13]


# ------------------------------------------------------------------ the shot

class _Problem:
    """A rod and its loads made ready: which eyelets are unknowns, what each tendon pulls."""

    def __init__(self, rod: Rod, loads: Loads):
        self.rod, self.loads = rod, loads
        self.paths = {t: rod.tendon_path(t) for t, tau in loads.tensions.items() if tau}
        for t, path in self.paths.items():
            if len(path) < 2:
                raise ValueError(f"tendon {t} has fewer than two eyelets")
        self.unknown = [(t, i) for t, path in self.paths.items() for i, (k, _) in enumerate(path) if k is not None]
        self.slot = {key: j for j, key in enumerate(self.unknown)}
        self.n_x = 6 + 3 * len(self.unknown)
        self.on_piece: dict = {}          # piece -> [(slot, local point)] of the unknown eyelets on it
        for (t, i), j in self.slot.items():
            k, local = self.paths[t][i]
            self.on_piece.setdefault(k, []).append((j, local))

    def straight(self) -> np.ndarray:
        """The unknowns of the unloaded, straight rod."""
        x = np.zeros(self.n_x)
        for (t, i), j in self.slot.items():
            k, local = self.paths[t][i]
            x[6 + 3 * j: 9 + 3 * j] = local + [0.0, self.rod.pieces[k].start, 0.0]
        return x

    def _eyelet_forces(self, X: np.ndarray, scale: float) -> dict:
        """piece -> [(local point, force (B, 3))]: each tensioned tendon's pull on its eyelets there,
        τ(û_next + û_prev), from the assumed eyelet positions in the columns X."""
        B = X.shape[0]
        E = X[:, 6:].reshape(B, -1, 3)
        out: dict = {}
        for t, path in self.paths.items():
            pts = np.stack([E[:, self.slot[(t, i)]] if k is not None else np.broadcast_to(x, (B, 3))
                            for i, (k, x) in enumerate(path)], axis=1)
            d = np.diff(pts, axis=1)
            u = scale * self.loads.tensions[t] * d / np.linalg.norm(d, axis=2, keepdims=True)
            pull = np.zeros_like(pts)
            pull[:, :-1] += u
            pull[:, 1:] -= u
            for i, (k, local) in enumerate(path):
                if k is not None:
                    out.setdefault(k, []).append((local, pull[:, i]))
        return out

    def shoot(self, X: np.ndarray, scale: float, curve: list | None = None, starts: list | None = None):
        """Residuals of the columns X (B, n_x) at load factor ``scale``: the free end's force and
        moment, then each unknown eyelet's shot position less its assumed one."""
        B = X.shape[0]
        rod, loads = self.rod, self.loads
        gvec = np.zeros(3) if loads.gravity is None else np.asarray(loads.gravity, float) * scale * loads.g * 1e-3
        first = rod.pieces[0].start
        p = np.tile([0.0, first, 0.0], (B, 1))
        q = np.tile([1.0, 0.0, 0.0, 0.0], (B, 1))
        n, m = X[:, 0:3].copy(), X[:, 3:6].copy()
        pulls = self._eyelet_forces(X, scale)
        shot = np.zeros((B, len(self.unknown), 3))
        if curve is not None:
            curve.append((first, p[0].copy()))
        for k, piece in enumerate(rod.pieces):
            if starts is not None:
                starts.append((p[0].copy(), _rotation(q[:1])[0]))
            if isinstance(piece, Flexible):
                p, q, n, m = _integrate((p, q, n, m), piece, piece.weight * gvec, curve)
                continue
            R = _rotation(q)
            forces = [(np.asarray(x, float), np.broadcast_to(mass * gvec, (B, 3))) for mass, x in piece.masses]
            forces += pulls.get(k, [])
            end = p + R[:, :, 1] * (piece.end - piece.start)
            n_out, moment = n.copy(), np.zeros((B, 3))
            for local, F in forces:
                r = np.einsum("bij,j->bi", R, local)
                n_out -= F
                moment += _cross(r, F)
            m = m - _cross(end - p, n_out) - moment
            for j, local in self.on_piece.get(k, ()):
                shot[:, j] = p + np.einsum("bij,j->bi", R, local)
            p, n = end, n_out
            if curve is not None:
                curve.append((piece.end, p[0].copy()))
        if starts is not None:
            starts.append((p[0].copy(), _rotation(q[:1])[0]))
        return np.concatenate([n, m, (shot - X[:, 6:].reshape(B, -1, 3)).reshape(B, -1)], axis=1)


def _steps(n_x: int) -> np.ndarray:
    return np.r_[np.full(3, FD["n"]), np.full(3, FD["m"]), np.full(n_x - 6, FD["e"])]


def _newton(prob: _Problem, x: np.ndarray, scale: float, length: float) -> tuple[np.ndarray, int, float]:
    """Newton's method on the residuals at one load factor from ``x``; (x, iterations, residual)."""
    weight = np.r_[np.ones(3), np.full(3, 1.0 / length), np.ones(prob.n_x - 6)]
    h = _steps(prob.n_x)
    r = prob.shoot(x[None], scale)[0]
    for it in range(NEWTON_ITER):
        done = (np.abs(r[:3]).max() <= TOL_N and np.abs(r[3:6]).max() <= TOL_N * length
                and (prob.n_x == 6 or np.abs(r[6:]).max() <= TOL_MM))
        if done:
            return x, it, float(np.abs(r * weight).max())
        cols = np.repeat(x[None], prob.n_x, axis=0) + np.diag(h)
        J = ((prob.shoot(cols, scale) - r) / h[:, None]).T
        try:
            dx = np.linalg.solve(J, -r)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(J, -r, rcond=None)[0]
        size, step = np.linalg.norm(r * weight), 1.0
        while True:
            trial = x + step * dx
            rt = prob.shoot(trial[None], scale)[0]
            if np.linalg.norm(rt * weight) < size or step < 1e-3:
                break
            step /= 2
        x, r = trial, rt
    raise ArithmeticError(f"the Cosserat rod did not converge at load factor {scale:g} "
                          f"(residual {np.abs(r * weight).max():.3g})")


def solve(rod: Rod, loads: Loads, steps=LOAD_STEPS) -> Solution:
    """The rod at rest under ``loads``, brought in over ``steps`` (load factors ending at 1)."""
    prob = _Problem(rod, loads)
    length = rod.pieces[-1].end - rod.pieces[0].start
    x, its, left = prob.straight(), 0, 0.0
    with blas_threads():
        for scale in steps:
            x, n, left = _newton(prob, x, scale, length)
            its += n
    curve, starts = [], []
    prob.shoot(x[None], 1.0, curve, starts)
    s = np.array([c[0] for c in curve])
    p = np.array([c[1] for c in curve])
    return Solution(rod=rod, loads=loads, n0=x[:3], m0=x[3:6], starts=starts, s=s, p=p, iterations=its, residual=left)
