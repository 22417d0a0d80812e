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
the joint, of every force beyond it, through the rotation's right Jacobian), and so is the Hessian
(below). No shooting: a locked tendon's length is a constraint shooting methods are known to
converge badly on.

The Hessian. Every load acts at a point x fixed to a node's frame. A coordinate q_a of joint j
turns all beyond the joint about its centre o_j at ω_a (a column of R_after·J_r), so
dx/dq_a = ω_a × (x − o_j) = [−x^, I] ξ_a with the twist ξ_a = (ω_a, o_j × ω_a), and

    H = K + Jᵀ (∂²V/∂x²) J + Σ f·∂²x/∂q²,     f = ∂V/∂x at each point:

K the joints' stiffness (diagonal); ∂²V/∂x² only the tendons' (dead weights and forces are linear
in x): per chord τ (I − u uᵀ)/|d| (a taut chord's sideways stiffness), plus k (∂ℓ/∂x)(∂ℓ/∂x)ᵀ
while a locked tendon is stretched; the last term, for a on an earlier joint than b, is
ω_aᵀ S_b ω_b with S_b = Σ r fᵀ − (Σ r·f) I over the points beyond b's joint, r = x − o_b, and on
one joint the same plus the turn of its own axes, m·R_after (∂J_r/∂θ_b) e_a (m the moment about
it). What moves with a DOF is a suffix of the chain, so every sum is a suffix sum along the rod
and H is (n, 6) twists times their suffix-summed images, O(n²), no loop over DOFs; a chord whose
far eyelet b's joint moves and near one it does not adds one masked product per set of eyelet
stations. It replaces the forward difference of the gradient (n perturbed gradients per
Hessian, 85 % of a tension check's sweeps): exact, no step to choose, and what the stiffness
reads, and far cheaper. :meth:`Model.difference_hessian` (central, relative error ~1e-9) stays as the reference
it is tested against.

A small load's response follows from the Hessian H at an equilibrium: the displacement of a
point along u under a force along u is j H⁻¹ jᵀ per newton, j the point's Jacobian; a rotation's
likewise. This is the tangent stiffness (a small push), one-way springs as they are at that state.

Units: mm, N, N·mm, MPa (N/mm²), g; angles in radians.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize
from threadpoolctl import ThreadpoolController

from .sag import G_ACC, Span

H_MAX = 1.5              # mm: longest rod segment (tip deflection error ~ (h/L)², 3e-5 at L = 270)
FD_STEP = 1e-6           # rad: central-difference step of the Hessian (relative error ~1e-9)
GTOL = 1e-9              # N·mm: largest generalised force left at an equilibrium
SMALL_ANGLE = 1e-8       # rad: below this the rotation's series are used
SERIES_ANGLE = 0.1       # rad: below this dJ_r/dθ's coefficients are series (truncation ~1e-20)
BLAS_THREADS = 1         # the factorisations are small: a second thread on a shared machine waits more than it computes


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
    (its free length, the run to its drum included, over EA, in series with the tie-off).
    For eyelet friction (:mod:`hwgen.model.friction`): ``compliances`` (M,), mm/N, of its M-1
    segments between eyelets and of its run beyond the tip eyelet, summing to 1/k (empty: 1/k
    shared by the segments by length); ``exit``, the run's direction in the tip frame (None: +y)."""

    name: str
    channel: str
    stations: tuple[float, ...]
    points: np.ndarray
    stiffness: float
    compliances: tuple[float, ...] = ()
    exit: tuple[float, float, float] | None = None


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


@lru_cache(maxsize=1)
def _blas() -> ThreadpoolController:
    """The process's BLAS libraries, found once (:func:`blas_threads`)."""
    return ThreadpoolController()


def blas_threads():
    """Within: BLAS on BLAS_THREADS threads. threadpoolctl's threadpool_limits looks for the loaded
    libraries anew on every entry (reading the process's maps, twice per solve); they are found once here, on first use (numpy's and scipy's BLAS are loaded
    with this module)."""
    return _blas().limit(limits=BLAS_THREADS, user_api="blas")


# ------------------------------------------------------------------ rotations

def _hat(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices (written into one array: the statics makes
    thousands of small ones, where nine stacked copies cost more than the arithmetic)."""
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _cross(a, b) -> np.ndarray:
    """np.cross of (..., 3) vectors, the same products and differences in the same order (so the
    same bits) without np.cross's axis handling, which costs more than the arithmetic on the
    statics' small arrays."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _exp_and_jr(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation exp(θ^) and its right Jacobian J_r(θ) for (..., 3) rotation vectors."""
    a2 = np.sum(th * th, axis=-1)
    a = np.sqrt(a2)
    small = a < SMALL_ANGLE
    a_ = np.where(small, 1.0, a)
    a2_ = np.where(small, 1.0, a2)
    s1 = np.where(small, 1.0 - a2 / 6.0, np.sin(a_) / a_)                  # sin a / a
    s2 = np.where(small, 0.5 - a2 / 24.0, 2.0 * np.sin(0.5 * a_) ** 2 / a2_)   # (1 - cos a) / a², no cancellation
    s3 = np.where(small, 1.0 / 6.0 - a2 / 120.0, (a_ - np.sin(a_)) / (a2_ * a_))   # (a - sin a) / a³
    K = _hat(th)
    K2 = K @ K
    eye = np.eye(3)
    R = eye + s1[..., None, None] * K + s2[..., None, None] * K2
    Jr = eye - s2[..., None, None] * K + s3[..., None, None] * K2
    return R, Jr


def _jr_derivative(th: np.ndarray) -> np.ndarray:
    """dJ_r/dθ_b for (J, 3) rotation vectors: (J, 3, 3, 3), index [j, b] the 3 × 3 derivative.

    J_r = I − s₂(a) θ^ + s₃(a) (θ^)², a = |θ|, so dJ_r/dθ_b = −t₂ θ_b θ^ − s₂ e_b^ + t₃ θ_b (θ^)²
    + s₃ (e_b^ θ^ + θ^ e_b^) with t = (ds/da)/a. Below SERIES_ANGLE each coefficient is its Taylor
    series (the closed forms lose digits to cancellation as 1/a⁴ there)."""
    a2 = np.sum(th * th, axis=-1)
    a = np.sqrt(a2)
    small = a < SERIES_ANGLE
    a_ = np.where(small, 1.0, a)
    sin = np.sin(a_)
    one_cos = 2.0 * np.sin(0.5 * a_) ** 2                                   # 1 − cos a without cancellation
    s2 = np.where(small, 0.5 - a2 / 24 + a2 ** 2 / 720 - a2 ** 3 / 40320 + a2 ** 4 / 3628800, one_cos / a_ ** 2)
    s3 = np.where(small, 1 / 6 - a2 / 120 + a2 ** 2 / 5040 - a2 ** 3 / 362880 + a2 ** 4 / 39916800,
                  (a_ - sin) / a_ ** 3)
    t2 = np.where(small, -1 / 12 + a2 / 180 - a2 ** 2 / 6720 + a2 ** 3 / 453600 - a2 ** 4 / 47900160,
                  sin / a_ ** 3 - 2.0 * one_cos / a_ ** 4)
    t3 = np.where(small, -1 / 60 + a2 / 1260 - a2 ** 2 / 60480 + a2 ** 3 / 4989600 - a2 ** 4 / 622702080,
                  one_cos / a_ ** 4 - 3.0 * (a_ - sin) / a_ ** 5)
    K = _hat(th)                                   # (J, 3, 3)
    K2 = K @ K
    Eb = _hat(np.eye(3))                           # (3, 3, 3): e_b^
    EK = Eb[None] @ K[:, None]                     # (J, 3, 3, 3)
    KE = K[:, None] @ Eb[None]
    tb = th[:, :, None, None]                      # θ_b
    return (-(t2[:, None, None, None] * tb) * K[:, None] - s2[:, None, None, None] * Eb[None]
            + (t3[:, None, None, None] * tb) * K2[:, None] + s3[:, None, None, None] * (EK + KE))


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
        for name, nodes in self.tendon_nodes.items():
            if np.any(np.diff(nodes) <= 0):
                raise ValueError(f"tendon {name}: its stations do not run from the base to the tip")
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
        # each node's frame: that after the last joint before it (0: the base's)
        self._frame_of_node = np.searchsorted(self.joint_seg + 1, np.arange(len(self.nodes_s)), side="right")
        self.dof_reach = self.joint_seg[self.dof_joint] + 1        # each DOF moves the nodes from here on
        same = self.dof_joint[:, None] == self.dof_joint[None, :]
        self._same_joint = np.nonzero(same)                        # DOF pairs (a, b) of one joint
        order = {pair: k for k, pair in enumerate(zip(*self._same_joint))}
        self._same_swap = np.array([order[(b, a)] for a, b in zip(*self._same_joint)], dtype=int)
        self._later_joint = (self.dof_joint[:, None] < self.dof_joint[None, :]).astype(float)
        # per set of eyelet nodes: the chord each DOF's reach falls in (its near eyelet stays, its far one
        # moves), and which earlier DOFs move that near eyelet (see "The Hessian")
        self._chord_group_of = {name: tuple(int(k) for k in v) for name, v in self.tendon_nodes.items()}
        self._chord_groups = {}
        for nodes in set(self._chord_group_of.values()):
            far = np.searchsorted(np.array(nodes), self.dof_reach, side="left")
            inside = (far >= 1) & (far < len(nodes))
            chord = np.where(inside, far - 1, 0)
            near = np.where(inside, np.array(nodes)[chord], -1)
            cut = (self.dof_reach[:, None] <= near[None, :]).astype(float)
            self._chord_groups[nodes] = (chord, cut)

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
        the map W = R_after·J_r from its coordinates to the world rotation of all beyond it.

        Vectorised along the rod: the frames after the joints are the running products
        E₀E₁…E_j, taken as a prefix scan (log₂ J batched 3 × 3 products); each segment then
        advances its node by half its length along the frame before its joint and half along the
        frame after (the whole length along the one frame of a rigid segment)."""
        q = np.atleast_2d(q)
        B = q.shape[0]
        th = self.thetas(q)
        E, Jr = _exp_and_jr(th)
        C = E.copy()                                # C[:, j] = E_0 E_1 … E_j: the frame after joint j
        d = 1
        while d < C.shape[1]:
            C[:, d:] = C[:, :-d] @ C[:, d:]
            d *= 2
        frames = np.concatenate([np.broadcast_to(np.eye(3), (B, 1, 3, 3)), C], axis=1)
        R = frames[:, self._frame_of_node]          # (B, n+1, 3, 3)
        y = R[:, :, :, 1]                           # each node's tangent
        step = 0.5 * self.seg_len[None, :, None] * (y[:, :-1] + y[:, 1:])
        P = np.concatenate([np.zeros((B, 1, 3)), np.cumsum(step, axis=1)], axis=1)
        seg = self.joint_seg
        O = P[:, seg] + 0.5 * self.seg_len[seg][None, :, None] * y[:, seg]
        W = C @ Jr
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
            A[:, nodes] += gp                         # a tendon's nodes are distinct (checked when built)
            C[:, nodes] += _cross(pts, gp)
        kg = 1e-3 * robot.g
        if loads.gravity is not None:
            gdir = np.asarray(loads.gravity, float)
            f = -kg * self.node_mass[None, :, None] * gdir            # dV/dp = -F
            A += f
            C += _cross(P, f)
            V += -np.einsum("bn,n->b", P @ gdir, kg * self.node_mass)
            if robot.tip_mass > 0:
                pt = P[:, -1] + R[:, -1] @ self.tip_local
                ft = -kg * robot.tip_mass * gdir
                A[:, -1] += ft
                C[:, -1] += _cross(pt, ft)
                V += -kg * robot.tip_mass * (pt @ gdir)
        for s, F in loads.forces:
            k = self.node_at(s)
            f = -np.asarray(F, float)
            A[:, k] += f
            C[:, k] += _cross(P[:, k], f)
            V += P[:, k] @ f
        return A, C, V, lengths, tensions

    def energy_and_gradient(self, q: np.ndarray, loads: Loads):
        """V (B,) and dV/dq (B, n_dof) for (B, n_dof) coordinates."""
        q = np.atleast_2d(q)
        V, grad, _, _ = self._energy(q, self.forward(q), loads)
        return V, grad

    def _energy(self, q: np.ndarray, kinematics, loads: Loads):
        """:meth:`energy_and_gradient` of ``q`` (B, n_dof) whose :meth:`forward` is ``kinematics``,
        and every tendon's length and tension (B,) there."""
        P, R, O, W, th = kinematics
        A, C, V, lengths, tensions = self._point_forces(P, R, loads)
        # what acts beyond each joint: nodes after the joint's segment
        SA = np.cumsum(A[:, ::-1], axis=1)[:, ::-1]
        SC = np.cumsum(C[:, ::-1], axis=1)[:, ::-1]
        beyond = self.joint_seg + 1
        mom = SC[:, beyond] - _cross(O, SA[:, beyond])            # (B, J, 3) about each joint
        gen = np.einsum("bjia,bji->bja", W, mom)                    # W^T m
        grad = gen[:, self.dof_joint, self.dof_axis] + self.dof_stiff * q
        V = V + 0.5 * np.sum(self.dof_stiff * q * q, axis=1)
        return V, grad, lengths, tensions

    def hessian(self, q: np.ndarray, loads: Loads) -> np.ndarray:
        """d²V/dq² at the coordinates q (n_dof,), exact: see the module's docstring, "The Hessian"."""
        n = self.n_dof
        if n == 0:
            return np.zeros((0, 0))
        q = np.asarray(q, float)
        return self._hessian(q, self.forward(q[None, :]), loads)

    def _hessian(self, q: np.ndarray, kinematics, loads: Loads) -> np.ndarray:
        """:meth:`hessian` at ``q`` (n_dof,) whose :meth:`forward` (of ``q[None]``) is ``kinematics``."""
        n = self.n_dof
        P, R, O, W, th = (x[0] for x in kinematics)
        jd, ax, reach = self.dof_joint, self.dof_axis, self.dof_reach
        omega = W[jd, :, ax]                                      # (n, 3): each DOF's world rotation axis
        xi = np.concatenate([omega, _cross(O[jd], omega)], axis=1)      # (n, 6): dx/dq_a = [−x^, I] ξ_a
        nn = len(self.nodes_s)
        A = np.zeros((nn, 3))                                     # per node Σ f, f = dV/dx at a point x
        M = np.zeros((nn, 3, 3))                                  # per node Σ x fᵀ
        N = np.zeros((nn, 6, 6))                                  # per node the tendons' chords, twist coordinates
        across = {key: np.zeros((len(key) - 1, 6, 6)) for key in self._chord_groups}
        rows = []                                                 # √k dℓ/dq of each stretched locked tendon
        for t in self.robot.tendons:
            mode = loads.tendons.get(t.name)
            if mode is None:
                continue
            nodes = self.tendon_nodes[t.name]
            pts = P[nodes] + np.einsum("nij,nj->ni", R[nodes], self.tendon_local[t.name])
            d = np.diff(pts, axis=0)
            ln = np.linalg.norm(d, axis=1)
            u = d / ln[:, None]
            tau, rate = self._tendon_law(t, mode, float(ln.sum()))
            grad = np.zeros_like(pts)                             # dℓ/dx per eyelet
            grad[:-1] -= u
            grad[1:] += u
            f = tau * grad
            A[nodes] += f
            M[nodes] += pts[:, :, None] * f[:, None, :]
            lift = np.zeros((len(pts), 3, 6))                     # [−x^, I]
            lift[:, :, :3] = -_hat(pts)
            lift[:, :, 3:] = np.eye(3)
            if tau > 0.0:
                Q = tau * (np.eye(3) - u[:, :, None] * u[:, None, :]) / ln[:, None, None]
                Qd = np.zeros((len(pts), 3, 3))
                Qd[:-1] += Q
                Qd[1:] += Q
                liftT = lift.transpose(0, 2, 1)
                own = liftT @ Qd @ lift
                pair = -(liftT[:-1] @ Q @ lift[1:])               # eyelet c with eyelet c + 1
                N[nodes] += own
                N[nodes[:-1]] += pair + pair.transpose(0, 2, 1)
                across[self._chord_group_of[t.name]] += pair
            if rate > 0.0:
                v = np.zeros((nn, 6))
                v[nodes] = np.einsum("mki,mk->mi", lift, grad)
                v = np.cumsum(v[::-1], axis=0)[::-1]
                rows.append(math.sqrt(rate) * np.sum(xi * v[reach], axis=1))
        kg = 1e-3 * self.robot.g
        if loads.gravity is not None:
            gdir = np.asarray(loads.gravity, float)
            f = -kg * self.node_mass[:, None] * gdir
            A += f
            M += P[:, :, None] * f[:, None, :]
            if self.robot.tip_mass > 0:
                pt = P[-1] + R[-1] @ self.tip_local
                ft = -kg * self.robot.tip_mass * gdir
                A[-1] += ft
                M[-1] += np.outer(pt, ft)
        for s, F in loads.forces:
            k = self.node_at(s)
            f = -np.asarray(F, float)
            A[k] += f
            M[k] += np.outer(P[k], f)
        # what acts beyond each joint, about the joint: S = Σ r fᵀ − (Σ r·f) I with r = x − o
        beyond = self.joint_seg + 1
        SA = np.cumsum(A[::-1], axis=0)[::-1][beyond]
        SM = np.cumsum(M[::-1], axis=0)[::-1][beyond]
        rf = SM - O[:, :, None] * SA[:, None, :]
        mom = np.stack([rf[:, 1, 2] - rf[:, 2, 1], rf[:, 2, 0] - rf[:, 0, 2], rf[:, 0, 1] - rf[:, 1, 0]], axis=1)
        S = rf - np.trace(rf, axis1=1, axis2=2)[:, None, None] * np.eye(3)
        # a on an earlier joint than b: ξ_aᵀ (N beyond b + S_b) ξ_b, and each chord b's joint cuts
        N = np.cumsum(N[::-1], axis=0)[::-1]
        T = np.einsum("nij,nj->ni", N[reach], xi)
        T[:, :3] += np.einsum("nij,nj->ni", S[jd], omega)
        F = xi @ T.T
        upper = F * self._later_joint
        for key, (chord, cut) in self._chord_groups.items():
            U = np.einsum("nij,nj->ni", across[key][chord], xi)
            upper += (xi @ U.T) * cut
        H = upper + upper.T
        # one joint: ξ_bᵀ N ξ_a + ω_bᵀ S ω_a, and the turn of its own axes, mom · R_after (dJ_r/dθ_b) e_a
        ia, ib = self._same_joint
        dW = R[beyond][:, None] @ _jr_derivative(th)              # (J, b, 3, a)
        turn = np.einsum("ji,jbia->jab", mom, dW)
        block = F[ib, ia] + turn[jd[ia], ax[ia], ax[ib]]
        H[ia, ib] += 0.5 * (block + block[self._same_swap])
        H[np.arange(n), np.arange(n)] += self.dof_stiff
        if rows:
            rows = np.array(rows)
            H += rows.T @ rows
        return H

    @staticmethod
    def _tendon_law(t: TendonLine, mode, length: float) -> tuple[float, float]:
        """A tendon's tension τ (N) and dτ/dℓ (N/mm) at path length ``length`` in its mode."""
        kind, value = mode
        if kind == "locked":
            stretch = max(length - value, 0.0)
            return t.stiffness * stretch, (t.stiffness if stretch > 0.0 else 0.0)
        if kind == "tension":
            return float(value), 0.0
        raise ValueError(f"tendon {t.name}: unknown mode {kind!r}")

    def difference_hessian(self, q: np.ndarray, loads: Loads, step: float = FD_STEP,
                           central: bool = True) -> np.ndarray:
        """d²V/dq² by differences of the analytic gradient, in one vectorised pass: central (error
        ~step²) or forward (half the work, error ~step). The reference :meth:`hessian` is tested
        against; the solver does not use it."""
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
        lever = _cross(P[0, k] - O[0], u)                        # (J, 3): r × u about each joint
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
        with blas_threads():
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
    potential (scipy's trust-krylov on the analytic gradient and Hessian)."""
    t0 = time.perf_counter()
    n = model.n_dof
    x0 = np.zeros(n) if q0 is None else np.asarray(q0, float)
    last: dict = {}     # at the last coordinates asked about: the kinematics, energy (and gradient), Hessian

    def at(x: np.ndarray, what: str):
        """scipy asks for the energy, the gradient and the Hessian at one x in turn (and the result
        is its last x): each is worked out once there, on one :meth:`Model.forward`."""
        key = x.tobytes()
        if last.get("x") != key:
            last.clear()
            last["x"], last["kinematics"] = key, model.forward(x[None, :])
        if what not in last:
            last[what] = (model._energy(x[None, :], last["kinematics"], loads) if what == "energy" else
                          model._hessian(x, last["kinematics"], loads) if n else np.zeros((0, 0)))
        return last[what]

    with blas_threads():
        if n:
            res = minimize(lambda x: float(at(x, "energy")[0][0]), x0, jac=lambda x: at(x, "energy")[1][0],
                           hess=lambda x: at(x, "hessian"), method="trust-krylov",
                           options={"gtol": gtol, "maxiter": max_iter})
            x, its = res.x, int(res.nit)
        else:
            x, its = x0, 0
        Vt, g, lengths, tensions = at(x, "energy")
        P, R = at(x, "kinematics")[:2]
        H = at(x, "hessian")
    return Equilibrium(model=model, loads=loads, q=x, s=model.nodes_s.copy(), p=P[0], frames=R[0],
                       lengths={k: float(v[0]) for k, v in lengths.items()},
                       tensions={k: float(v[0]) for k, v in tensions.items()}, energy=float(Vt[0]), hessian=H,
                       residual=float(np.abs(g).max()) if n else 0.0, iterations=its,
                       solve_time=time.perf_counter() - t0)


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
