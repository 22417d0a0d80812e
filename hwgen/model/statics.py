"""Statics of a tendon-driven strip robot in newtons: a discrete elastic rod with rigid disks and
straight tendon segments between eyelets, solved by energy minimisation (numpy and scipy only).

Formulation. The strip is a Kirchhoff rod (inextensible, unshearable) discretised as in the
pseudo-rigid / per-subsegment models Rao et al. (2021, "How to model tendon-driven continuum
robots and benchmark modelling performance", Front. Robot. AI 7:630245) compare with the
Cosserat rod of Rucker & Webster (2011, IEEE T-RO 27(6)): the rod is cut into short segments,
each rigid, joined at its middle by an elastic joint whose relative rotation vector θ (in the
segment's own frame: x across the strip's height, y along it, z through its thickness) stores

    U = ½ Σ_axes θ_a² / c_a,      c_a = ∫ ds / K_a(s) over the segment,

with K = (E·I_x, G·J, E·I_z) the bending stiffness about x (the strip's thin, flexible direction),
the torsional stiffness and the bending stiffness about z (its stiff direction). A joint per
segment at its midpoint is the midpoint rule for ∫ M/K ds: a tip moment bends it exactly, a tip
force to O(h²). Where a span holds the strip (a disk's plate: rigid; a glued hub: the strip's K
plus the hub's) K is the span's, as :mod:`hwgen.model.sag` models the own-weight case (its
:class:`~hwgen.model.sag.Span` records are reused here for bending about x). A rigid segment has
no joint.

The disks are rigid bodies fixed to the rod's frame at their stations and carry the eyelets. A
tendon is the chord sum through its eyelets, eq. (2) of the paper (the partially supported
tendon), in the deformed frames; each is in one of three states:

    slack      no force;
    locked     a one-way spring of stiffness k (tendon EA over its length in series with the
               tie-off's compliance): tension k·max(0, ℓ - ℓ₀), energy ½ k max(0, ℓ - ℓ₀)² —
               it pulls and never pushes (a worm that self-locks holds ℓ₀: the displacement-
               controlled tendon of Oliver-Butler, Till & Rucker 2019);
    tension    a prescribed tension τ (a tendon pulled by a weight or a force-controlled drive,
               Rucker & Webster's tension-controlled case): energy τ·ℓ.

Gravity acts on point masses at arc lengths along the rod (the disks, at their centres of mass
on the centre line), on the strip itself (lumped to the segments' ends) and on a tip assembly
fixed to the tip frame; external forces act at nodes. The total potential

    V(θ) = U + Σ tendon energies + Σ m g·z − Σ F·p

is minimised over every joint's rotation with scipy's trust-region method on the Hessian
(``trust-krylov``): the gradient is analytic (each joint's generalised force is the moment, about
the joint, of every force beyond it, through the rotation's right Jacobian); the Hessian is the
difference of that gradient, all perturbations evaluated in one vectorised pass (forward while
iterating, central at the equilibrium, where it gives the stiffness). No
shooting: a locked tendon's length is a constraint shooting methods are known to converge badly
on.

A small load's response follows from the Hessian H at an equilibrium: the displacement of a
point along u under a force along u is j H⁻¹ jᵀ per newton, j the point's Jacobian; a rotation's
likewise. This is the tangent stiffness (a small push), one-way springs as they are at that state.

Units: mm, N, N·mm, MPa (N/mm²), g; angles in radians.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits

from .sag import G_ACC, Span

H_MAX = 1.5              # mm: longest rod segment (tip deflection error ~ (h/L)², 3e-5 at L = 270)
FD_STEP = 1e-6           # rad: central-difference step of the Hessian (relative error ~1e-9)
GTOL = 1e-9              # N·mm: largest generalised force left at an equilibrium
SMALL_ANGLE = 1e-8       # rad: below this the rotation's series are used
BLAS_THREADS = 1         # a 500 × 500 Cholesky: 3 ms on one thread, 15-370 ms on two of a shared 2-core machine


@dataclass(frozen=True)
class Section:
    """The strip's section: E (MPa) and G (MPa) of the laminate, height h (mm, along x) and
    thickness t (mm, along z), and its mass per length (g/mm)."""

    E: float
    G: float
    height: float
    thickness: float
    lin_density: float = 0.0

    @property
    def ei_flex(self) -> float:
        """E·h·t³/12: bending about x, the flexible direction (deflects along z), N·mm²."""
        return self.E * self.height * self.thickness ** 3 / 12.0

    @property
    def ei_stiff(self) -> float:
        """E·t·h³/12: bending about z, the strip's width (deflects along x), N·mm²."""
        return self.E * self.thickness * self.height ** 3 / 12.0

    @property
    def gj(self) -> float:
        """G·J of a thin rectangle, J = h t³/3 (1 − 0.63 t/h) (Saint-Venant, Roark's Table 10.1), N·mm²."""
        t, h = self.thickness, self.height
        return self.G * h * t ** 3 / 3.0 * (1.0 - 0.63 * t / h)

    @property
    def stiffness(self) -> np.ndarray:
        """(K_x, K_y, K_z) = (E·I_x, G·J, E·I_z) in the segment frame, N·mm²."""
        return np.array([self.ei_flex, self.gj, self.ei_stiff])


@dataclass(frozen=True)
class Stiffening:
    """Where something holds the strip, per axis: ``flex`` for bending about x (sag's Spans, the
    same records its own-weight model uses), ``torsion`` and ``stiff`` (bending about z) likewise;
    math.inf holds that axis straight."""

    flex: tuple[Span, ...] = ()
    torsion: tuple[Span, ...] = ()
    stiff: tuple[Span, ...] = ()


@dataclass(frozen=True)
class TendonLine:
    """A tendon through eyelets: ``points`` (M, 2) its (x, z) in the disk frames at arc lengths
    ``stations`` (M,), base first; ``stiffness`` k (N/mm) of the locked tendon as one spring
    (its free length, the run to its drum included, over EA, in series with the tie-off)."""

    name: str
    channel: str
    stations: tuple[float, ...]
    points: np.ndarray
    stiffness: float


@dataclass(frozen=True)
class Robot:
    """What the statics is of: a strip of ``length`` (clamped at s = 0, tip at s = length), its
    section, where it is held stiffer, the tendons, and the weights it carries: point masses (s, g)
    on the centre line, a tip assembly of ``tip_mass`` g with its centre of mass at ``tip_offset``
    (along the tip's tangent y, along its normal z) in the tip frame."""

    length: float
    section: Section
    stiffening: Stiffening = Stiffening()
    tendons: tuple[TendonLine, ...] = ()
    point_masses: tuple[tuple[float, float], ...] = ()
    tip_mass: float = 0.0
    tip_offset: tuple[float, float] = (0.0, 0.0)
    g: float = G_ACC

    def tendon(self, name: str) -> TendonLine:
        return next(t for t in self.tendons if t.name == name)


@dataclass(frozen=True)
class Loads:
    """One load case: per tendon name ("locked", rest length ℓ₀ mm) or ("tension", τ N); a tendon
    not named is slack. ``gravity``: the unit direction of gravity in the base frame, or None;
    ``forces``: (arc length s of a node, force vector N in the base frame)."""

    tendons: dict = field(default_factory=dict)
    gravity: tuple[float, float, float] | None = None
    forces: tuple[tuple[float, tuple[float, float, float]], ...] = ()


# ------------------------------------------------------------------ rotations

def _hat(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices."""
    z = np.zeros(v.shape[:-1])
    return np.stack([np.stack([z, -v[..., 2], v[..., 1]], -1),
                     np.stack([v[..., 2], z, -v[..., 0]], -1),
                     np.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def _exp_and_jr(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation exp(θ^) and its right Jacobian J_r(θ) for (..., 3) rotation vectors."""
    a2 = np.sum(th * th, axis=-1)
    a = np.sqrt(a2)
    small = a < SMALL_ANGLE
    a_ = np.where(small, 1.0, a)
    a2_ = np.where(small, 1.0, a2)
    s1 = np.where(small, 1.0 - a2 / 6.0, np.sin(a_) / a_)                  # sin a / a
    s2 = np.where(small, 0.5 - a2 / 24.0, (1.0 - np.cos(a_)) / a2_)         # (1 - cos a) / a²
    s3 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (a_ - np.sin(a_)) / (a2_ * a_))   # (a - sin a) / a³
    K = _hat(th)
    K2 = K @ K
    eye = np.eye(3)
    R = eye + s1[..., None, None] * K + s2[..., None, None] * K2
    Jr = eye - s2[..., None, None] * K + s3[..., None, None] * K2
    return R, Jr


# ------------------------------------------------------------------ the discretised rod

def _span_value(spans, mid: float, default: float) -> float:
    for sp in spans:
        if sp.start < mid < sp.end:
            return sp.ei
    return default


class Model:
    """A :class:`Robot` discretised: segments, joints, where loads attach. Build it once per
    robot; :func:`solve` uses it for any :class:`Loads`."""

    def __init__(self, robot: Robot, h_max: float = H_MAX):
        self.robot = robot
        L = float(robot.length)
        K = robot.section.stiffness
        pts = [0.0, L]
        for t in robot.tendons:
            pts += [float(s) for s in t.stations]
        pts += [float(s) for s, _ in robot.point_masses]
        st = robot.stiffening
        for sp in (*st.flex, *st.torsion, *st.stiff):
            pts += [sp.start, sp.end]
        bp = np.unique(np.round(np.clip(np.asarray(pts, float), 0.0, L), 9))
        edges = [0.0]
        for lo, hi in zip(bp[:-1], bp[1:]):
            if hi - lo < 1e-9:
                continue
            n = max(1, math.ceil((hi - lo) / h_max - 1e-9))
            edges += list(np.linspace(lo, hi, n + 1)[1:])
        self.nodes_s = np.array(edges)
        self.seg_len = np.diff(self.nodes_s)
        mids = 0.5 * (self.nodes_s[1:] + self.nodes_s[:-1])
        comp = np.zeros((len(mids), 3))
        for m, (mid, ln) in enumerate(zip(mids, self.seg_len)):
            for a, spans in enumerate((st.flex, st.torsion, st.stiff)):
                k = _span_value(spans, mid, K[a])
                comp[m, a] = 0.0 if math.isinf(k) else ln / k
        self.compliance = comp                      # (segments, 3), rad per N·mm
        self.joint_seg = np.flatnonzero(comp.max(axis=1) > 0)     # segments with a joint
        mask = comp[self.joint_seg] > 0
        self.dof_joint, self.dof_axis = np.nonzero(mask)          # each DOF: (joint index, axis)
        self.n_dof = len(self.dof_joint)
        self.dof_stiff = 1.0 / comp[self.joint_seg][mask]         # N·mm per rad
        self.joint_of_seg = np.full(len(mids), -1)
        self.joint_of_seg[self.joint_seg] = np.arange(len(self.joint_seg))
        # loads
        self.tendon_nodes = {t.name: np.array([self.node_at(s) for s in t.stations]) for t in robot.tendons}
        self.tendon_local = {t.name: np.column_stack([np.asarray(t.points, float)[:, 0], np.zeros(len(t.points)),
                                                      np.asarray(t.points, float)[:, 1]]) for t in robot.tendons}
        masses = np.zeros(len(self.nodes_s))
        w = robot.section.lin_density
        masses[:-1] += 0.5 * w * self.seg_len
        masses[1:] += 0.5 * w * self.seg_len
        for s, m in robot.point_masses:
            masses[self.node_at(s)] += m
        self.node_mass = masses                     # g
        self.tip_local = np.array([0.0, robot.tip_offset[0], robot.tip_offset[1]])

    def node_at(self, s: float) -> int:
        k = int(np.argmin(np.abs(self.nodes_s - s)))
        if abs(self.nodes_s[k] - s) > 1e-6:
            raise ValueError(f"no node at s = {s} mm")
        return k

    # -------------------------------------------------------------- kinematics
    def thetas(self, q: np.ndarray) -> np.ndarray:
        """(B, joints, 3) rotation vectors from (B, n_dof) coordinates."""
        th = np.zeros((q.shape[0], len(self.joint_seg), 3))
        th[:, self.dof_joint, self.dof_axis] = q
        return th

    def forward(self, q: np.ndarray):
        """Node positions (B, n+1, 3) and frames (B, n+1, 3, 3); per joint its position (B, J, 3) and
        the map W = R_after·J_r from its coordinates to the world rotation of all beyond it."""
        q = np.atleast_2d(q)
        B = q.shape[0]
        th = self.thetas(q)
        E, Jr = _exp_and_jr(th)
        nn = len(self.nodes_s)
        P = np.zeros((B, nn, 3))
        R = np.zeros((B, nn, 3, 3))
        O = np.zeros((B, len(self.joint_seg), 3))
        W = np.zeros((B, len(self.joint_seg), 3, 3))
        p = np.zeros((B, 3))
        r = np.broadcast_to(np.eye(3), (B, 3, 3)).copy()
        R[:, 0] = r
        for m, ln in enumerate(self.seg_len):
            j = self.joint_of_seg[m]
            if j < 0:
                p = p + ln * r[:, :, 1]
            else:
                p = p + 0.5 * ln * r[:, :, 1]
                r = r @ E[:, j]
                O[:, j] = p
                W[:, j] = r @ Jr[:, j]
                p = p + 0.5 * ln * r[:, :, 1]
            P[:, m + 1] = p
            R[:, m + 1] = r
        return P, R, O, W, th

    # -------------------------------------------------------------- energy and gradient
    def _point_forces(self, P, R, loads: Loads):
        """dV/dp at every attached point, gathered per node: (Σ g, Σ p × g) (B, n+1, 3) each, the
        potential (B,), and every tendon's length (B,) and tension (B,)."""
        B, nn = P.shape[:2]
        A = np.zeros((B, nn, 3))
        C = np.zeros((B, nn, 3))
        V = np.zeros(B)
        lengths, tensions = {}, {}
        robot = self.robot
        for t in robot.tendons:
            mode = loads.tendons.get(t.name)
            nodes = self.tendon_nodes[t.name]
            pts = P[:, nodes] + np.einsum("bnij,nj->bni", R[:, nodes], self.tendon_local[t.name])
            d = np.diff(pts, axis=1)
            ln = np.linalg.norm(d, axis=2)
            u = d / ln[..., None]
            ell = ln.sum(axis=1)
            lengths[t.name] = ell
            if mode is None:
                tensions[t.name] = np.zeros(B)
                continue
            kind, value = mode
            if kind == "locked":
                stretch = np.maximum(ell - value, 0.0)
                tau = t.stiffness * stretch
                V += 0.5 * t.stiffness * stretch ** 2
            elif kind == "tension":
                tau = np.full(B, float(value))
                V += value * ell
            else:
                raise ValueError(f"tendon {t.name}: unknown mode {kind!r}")
            tensions[t.name] = tau
            gp = np.zeros_like(pts)                   # dℓ/dp per eyelet
            gp[:, :-1] -= u
            gp[:, 1:] += u
            gp *= tau[:, None, None]
            np.add.at(A, (slice(None), nodes), gp)
            np.add.at(C, (slice(None), nodes), np.cross(pts, gp))
        kg = 1e-3 * robot.g
        if loads.gravity is not None:
            gdir = np.asarray(loads.gravity, float)
            f = -kg * self.node_mass[None, :, None] * gdir            # dV/dp = -F
            A += f
            C += np.cross(P, f)
            V += -np.einsum("bn,n->b", P @ gdir, kg * self.node_mass)
            if robot.tip_mass > 0:
                pt = P[:, -1] + R[:, -1] @ self.tip_local
                ft = -kg * robot.tip_mass * gdir
                A[:, -1] += ft
                C[:, -1] += np.cross(pt, ft)
                V += -kg * robot.tip_mass * (pt @ gdir)
        for s, F in loads.forces:
            k = self.node_at(s)
            f = -np.asarray(F, float)
            A[:, k] += f
            C[:, k] += np.cross(P[:, k], f)
            V += P[:, k] @ f
        return A, C, V, lengths, tensions

    def energy_and_gradient(self, q: np.ndarray, loads: Loads):
        """V (B,) and dV/dq (B, n_dof) for (B, n_dof) coordinates."""
        q = np.atleast_2d(q)
        P, R, O, W, th = self.forward(q)
        A, C, V, _, _ = self._point_forces(P, R, loads)
        # what acts beyond each joint: nodes after the joint's segment
        SA = np.cumsum(A[:, ::-1], axis=1)[:, ::-1]
        SC = np.cumsum(C[:, ::-1], axis=1)[:, ::-1]
        beyond = self.joint_seg + 1
        mom = SC[:, beyond] - np.cross(O, SA[:, beyond])            # (B, J, 3) about each joint
        gen = np.einsum("bjia,bji->bja", W, mom)                    # W^T m
        grad = gen[:, self.dof_joint, self.dof_axis] + self.dof_stiff * q
        V = V + 0.5 * np.sum(self.dof_stiff * q * q, axis=1)
        return V, grad

    def hessian(self, q: np.ndarray, loads: Loads, step: float = FD_STEP, central: bool = True) -> np.ndarray:
        """d²V/dq² by differences of the analytic gradient, in one vectorised pass: central (error
        ~step², for the stiffness) or forward (half the work, error ~step: the solver's steps)."""
        n = self.n_dof
        idx = np.arange(n)
        if central:
            Q = np.repeat(q[None, :], 2 * n, axis=0)
            Q[idx, idx] += step
            Q[n + idx, idx] -= step
            _, g = self.energy_and_gradient(Q, loads)
            H = (g[:n] - g[n:]) / (2 * step)
        else:
            Q = np.repeat(q[None, :], n + 1, axis=0)
            Q[idx, idx] += step
            _, g = self.energy_and_gradient(Q, loads)
            H = (g[:n] - g[n]) / step
        return 0.5 * (H + H.T)

    # -------------------------------------------------------------- Jacobians of outputs
    def point_jacobian(self, q: np.ndarray, s: float, direction) -> np.ndarray:
        """d(u·p)/dq of the node at arc length s along the base-frame direction u."""
        P, R, O, W, _ = self.forward(q)
        k = self.node_at(s)
        u = np.asarray(direction, float)
        lever = np.cross(P[0, k] - O[0], u)                        # (J, 3): r × u about each joint
        J = np.einsum("jia,ji->ja", W[0], lever)
        J[self.joint_seg + 1 > k] = 0.0
        return J[self.dof_joint, self.dof_axis]

    def rotation_jacobian(self, q: np.ndarray, s: float, axis_local) -> np.ndarray:
        """d(rotation about the node's own axis)/dq (the axis in the node frame: (0, 1, 0) is the
        tangent, the twist)."""
        P, R, O, W, _ = self.forward(q)
        k = self.node_at(s)
        u = R[0, k] @ np.asarray(axis_local, float)
        J = np.einsum("jia,i->ja", W[0], u)
        J[self.joint_seg + 1 > k] = 0.0
        return J[self.dof_joint, self.dof_axis]


@dataclass
class Equilibrium:
    """A solved load case: the coordinates, the deformed nodes and frames, each tendon's length
    and tension, and the Hessian there."""

    model: Model
    loads: Loads
    q: np.ndarray
    s: np.ndarray                 # node arc lengths, mm
    p: np.ndarray                 # (n+1, 3) node positions, mm
    frames: np.ndarray            # (n+1, 3, 3)
    lengths: dict                 # tendon name -> path length, mm
    tensions: dict                # tendon name -> tension, N
    energy: float
    hessian: np.ndarray
    residual: float               # largest |dV/dq| left, N·mm
    iterations: int
    solve_time: float
    _factor: tuple | None = field(default=None, repr=False)   # the Hessian's Cholesky factor, () if not positive

    def at(self, s: float) -> np.ndarray:
        """Position of the node at arc length s."""
        return self.p[self.model.node_at(s)]

    def tip_angle(self) -> float:
        """Rotation of the tip's tangent about x from +y toward +z, rad (the bending angle)."""
        t = self.frames[-1][:, 1]
        return float(math.atan2(t[2], t[1]))

    def compliance(self, jac: np.ndarray) -> float | np.ndarray:
        """j H⁻¹ jᵀ: the response per unit load of the output whose Jacobian is j (inf if the state
        is not stable); for a stack of Jacobians (k, n_dof) the k responses."""
        jac = np.asarray(jac, float)
        if self.model.n_dof == 0:
            return np.zeros(jac.shape[:-1]) if jac.ndim > 1 else 0.0
        with threadpool_limits(BLAS_THREADS, user_api="blas"):
            if self._factor is None:
                try:
                    self._factor = cho_factor(self.hessian)
                except np.linalg.LinAlgError:
                    self._factor = ()
            if not self._factor:
                return np.full(jac.shape[:-1], math.inf) if jac.ndim > 1 else math.inf
            y = cho_solve(self._factor, np.atleast_2d(jac).T)
        c = np.einsum("kn,nk->k", np.atleast_2d(jac), y)
        return c if jac.ndim > 1 else float(c[0])

    def point_stiffnesses(self, stations, direction) -> np.ndarray:
        """:meth:`point_stiffness` at many arc lengths at once, N/mm."""
        J = np.array([self.model.point_jacobian(self.q, s, direction) for s in stations])
        return 1.0 / self.compliance(J)

    def point_stiffness(self, s: float, direction) -> float:
        """Force over displacement of a small push at the node at arc length s along the base-frame
        direction, N/mm."""
        return 1.0 / self.compliance(self.model.point_jacobian(self.q, s, direction))

    def twist_stiffness(self, s: float | None = None) -> float:
        """Torque over twist about the node's own tangent (default the tip), N·mm/rad."""
        s = self.model.robot.length if s is None else s
        return 1.0 / self.compliance(self.model.rotation_jacobian(self.q, s, (0.0, 1.0, 0.0)))


def solve(model: Model, loads: Loads, q0: np.ndarray | None = None, gtol: float = GTOL,
          max_iter: int = 200) -> Equilibrium:
    """The equilibrium of ``loads`` nearest ``q0`` (default: the straight rod) that minimises the
    potential (scipy's trust-krylov on the analytic gradient and the differenced Hessian)."""
    t0 = time.perf_counter()
    n = model.n_dof
    x0 = np.zeros(n) if q0 is None else np.asarray(q0, float)
    cache = {}

    def fg(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            V, g = model.energy_and_gradient(x[None, :], loads)
            cache[key] = (float(V[0]), g[0])
        return cache[key]

    if n:
        with threadpool_limits(BLAS_THREADS, user_api="blas"):
            res = minimize(lambda x: fg(x)[0], x0, jac=lambda x: fg(x)[1], hess=lambda x: model.hessian(x, loads, central=False),
                           method="trust-krylov", options={"gtol": gtol, "maxiter": max_iter})
        x, its = res.x, int(res.nit)
    else:
        x, its = x0, 0
    P, R, _, _, _ = model.forward(x[None, :])
    _, _, V, lengths, tensions = model._point_forces(P, R, loads)
    Vt, g = model.energy_and_gradient(x[None, :], loads)
    H = model.hessian(x, loads) if n else np.zeros((0, 0))
    return Equilibrium(model, loads, x, model.nodes_s.copy(), P[0], R[0],
                       {k: float(v[0]) for k, v in lengths.items()}, {k: float(v[0]) for k, v in tensions.items()},
                       float(Vt[0]), H, float(np.abs(g).max()) if n else 0.0, its, time.perf_counter() - t0)


def straight_lengths(model: Model) -> dict:
    """Every tendon's path length in the straight, unloaded robot, mm."""
    P, R, _, _, _ = model.forward(np.zeros((1, model.n_dof)))
    _, _, _, lengths, _ = model._point_forces(P, R, Loads())
    return {k: float(v[0]) for k, v in lengths.items()}


def locked_at(model: Model, pretension: dict) -> dict:
    """Loads entries that lock each named tendon at the length its pre-tension gives in the straight
    robot (ℓ₀ = ℓ_straight − τ/k): {name: ("locked", ℓ₀)}. The robot held straight while they are
    locked; let go, a tendon that bends the strip (one that is not straight) relaxes."""
    ls = straight_lengths(model)
    return {name: ("locked", ls[name] - tau / model.robot.tendon(name).stiffness) for name, tau in pretension.items()}


def locked_settled(model: Model, pretension: dict, base: Loads | None = None) -> tuple[dict, Equilibrium]:
    """Loads entries that lock each named tendon so that it carries its pre-tension in the robot as
    it settles under them (and ``base``'s other loads): the tendons pulled with those tensions
    (tension-controlled), the robot let find its shape, each then locked at ℓ₀ = ℓ − τ/k. The
    locked robot is in the same equilibrium, so each tendon keeps exactly its pre-tension there.
    Returns ({name: ("locked", ℓ₀)}, that equilibrium)."""
    base = base or Loads()
    pulled = Loads(tendons={**base.tendons, **{n: ("tension", t) for n, t in pretension.items()}},
                   gravity=base.gravity, forces=base.forces)
    eq = solve(model, pulled)
    locks = {n: ("locked", eq.lengths[n] - t / model.robot.tendon(n).stiffness) for n, t in pretension.items()}
    return locks, eq
