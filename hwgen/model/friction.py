"""Eyelet friction as bounds on a small push's stiffness (numpy and scipy only), from one
equilibrium of :mod:`hwgen.model.statics` and its Hessian.

A locked tendon runs through its eyelets; between two consecutive eyelets it is a straight
*segment* (a chord of eq. (2)), and beyond the tip eyelet it runs to its drum (the *run*, fixed to
the tip body, so its length does not change as the robot bends). Where the tendon may slide
through an eyelet decides how its segments share a change of length:

``none``     frictionless eyelets: one tension along the whole tendon, which is one spring
             (its free length over EA in series with the tie-off): the Hessian the solver returns.
``stuck``    every segment held at its eyelets (static friction, the small-push limit): each
             segment its own spring of its own length, k_j = EA/ℓ_j (the first also in series
             with the knot's half of the tie-off). The Hessian is the frictionless one with each
             tendon's rank-one spring term k g gᵀ (g = dℓ/dq) replaced by the segments'
             Σ k_j g_j g_jᵀ: the tension, and so every other term, is the same at the
             equilibrium. Stuck is never less stiff than none (a chain of springs held at its
             joints is stiffer than the same springs free to share one stretch).
``capstan``  between the two, for a push of a given size: Coulomb friction at each eyelet with
             coefficient μ over the angle θ the tendon turns there. Every eyelet starts stuck,
             each tendon at one tension (the line worked through its eyelets after tensioning);
             as the push grows, segment tensions part, and an eyelet slips once the higher
             tension reaches e^(μθ) times the lower (capstan), then goes on slipping with that
             ratio held (the line sliding from the lower segment into the higher, never back).
             An eyelet the tendon runs straight through (θ = 0) slips at once. The push is
             followed from zero through each slip as it comes (the response is linear between
             them: the Hessian at the equilibrium, the turn θ as there); the stiffness is the
             push over the displacement it reached (a secant, as a load-cell fit over a push
             gives). It depends on the push's size and direction: friction's is a path.

The knot at the base eyelet does not slip. Segment and run springs are from the tendon's
straight chord lengths (their change under load is a tiny part of EA/ℓ); the tie-off's
compliance is split evenly between the knot and the drum (the model has nothing to split it by).

Everything about the segments is worked out in their own small space: with H the stuck Hessian
and G the segments' rows dℓ_j/dq, P = G H⁻¹ Gᵀ, p = G H⁻¹ jᵀ and c = j H⁻¹ jᵀ (j the push's
Jacobian) give every slip phase from an n_slip × n_slip solve, one Cholesky per equilibrium.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from . import statics as st

FRICTIONS = ("none", "stuck")     # the bounds, always reported; "capstan" with a friction coefficient
SLACK_N = 1e-9                    # N: a tension at or under this is slack
REFINE_TOL = 1e-11                # the kept inverse's answer, refined once, must hold A x = r to this (relative)
MAX_PHASES = 2000                 # slips followed before a push gives up (never reached: a slip per eyelet per phase)


# ------------------------------------------------------------------ segments and their rows

def segment_compliances(line: st.TendonLine, chord_lengths: np.ndarray, ea: float | None = None) -> np.ndarray:
    """(M,) compliances, mm/N, of a tendon's M-1 segments (base first) and its run: from
    ``line.compliances`` when given, else the tendon's one compliance 1/k shared by the segments in
    proportion to their lengths (no run)."""
    if line.compliances:
        c = np.asarray(line.compliances, float)
        if len(c) != len(chord_lengths) + 1:
            raise ValueError(f"tendon {line.name}: {len(c)} compliances for {len(chord_lengths)} segments and a run")
        return c
    share = np.asarray(chord_lengths, float) / float(np.sum(chord_lengths))
    return np.r_[share / line.stiffness, 0.0]


@dataclass(frozen=True)
class Chords:
    """A tendon's segments at coordinates q: lengths (M-1,), unit vectors base to tip (M-1, 3) in the
    base frame, rows dℓ_j/dq (M-1, n_dof), the angle the tendon turns at each interior eyelet
    (M-2,) and at the tip eyelet toward its run, rad."""

    lengths: np.ndarray
    units: np.ndarray
    rows: np.ndarray
    turns: np.ndarray
    exit_turn: float


def point_rows(model: st.Model, kinematics, nodes, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For points fixed to node frames (``points`` (K, 3) in the base frame, on ``nodes`` (K,)):
    (the joint-coordinate rows of ω_d × (x − o_d), (K, n_dof, 3), zero where DOF d does not move the
    node; and the DOFs' world axes ω (n_dof, 3))."""
    P, R, O, W, _ = kinematics
    jd, ax = model.dof_joint, model.dof_axis
    omega = W[jd, :, ax]                                        # (n, 3)
    lever = points[:, None, :] - O[jd][None, :, :]              # (K, n, 3)
    d = np.cross(omega[None, :, :], lever)
    moves = model.dof_reach[None, :] <= np.asarray(nodes)[:, None]
    return d * moves[:, :, None], omega


def chords(model: st.Model, q: np.ndarray, names=None) -> dict[str, Chords]:
    """:class:`Chords` of the named tendons (default: all) at ``q``, from one forward pass."""
    kin = tuple(x[0] for x in model.forward(np.asarray(q, float)[None, :]))
    P, R = kin[0], kin[1]
    out = {}
    for t in model.robot.tendons:
        if names is not None and t.name not in names:
            continue
        nodes = model.tendon_nodes[t.name]
        pts = P[nodes] + np.einsum("nij,nj->ni", R[nodes], model.tendon_local[t.name])
        d = np.diff(pts, axis=0)
        ln = np.linalg.norm(d, axis=1)
        u = d / ln[:, None]
        move, _ = point_rows(model, kin, nodes, pts)             # (M, n, 3)
        rows = np.einsum("mni,mi->mn", move[1:], u) - np.einsum("mni,mi->mn", move[:-1], u)
        turns = np.arccos(np.clip(np.einsum("mi,mi->m", u[:-1], u[1:]), -1.0, 1.0))
        exit_local = np.asarray(t.exit if t.exit is not None else (0.0, 1.0, 0.0), float)
        exit_dir = R[-1] @ (exit_local / np.linalg.norm(exit_local))
        out[t.name] = Chords(ln, u, rows, turns, float(np.arccos(np.clip(u[-1] @ exit_dir, -1.0, 1.0))))
    return out


# ------------------------------------------------------------------ the bounds at an equilibrium

@dataclass
class Bounds:
    """The friction bounds at a solved equilibrium whose locked tendons are taut: the frictionless
    and the stuck Hessian's factors, and what the capstan push needs (segment rows G, springs k,
    tensions, and per eyelet its two segments and turn)."""

    eq: st.Equilibrium
    tendons: tuple[str, ...]          # the locked, taut tendons
    rows: np.ndarray                  # (m, n_dof): each segment's dℓ/dq (a run's is zero)
    springs: np.ndarray               # (m,) N/mm
    tension: np.ndarray               # (m,) N
    owner: tuple[str, ...]            # (m,) the tendon of each segment
    eyelets: np.ndarray               # (e, 2) the segments either side of each eyelet that may slip
    turns: np.ndarray                 # (e,) rad
    factors: dict                     # friction -> Cholesky factor, () when not positive definite

    def compliance(self, jac: np.ndarray, friction: str) -> np.ndarray:
        """j H⁻¹ jᵀ per row of ``jac`` (k, n_dof) with that friction's Hessian; inf if not stable."""
        jac = np.atleast_2d(jac)
        f = self.factors[friction]
        if not f:
            return np.full(len(jac), math.inf)
        with st.blas_threads():
            y = cho_solve(f, jac.T)
        return np.einsum("kn,nk->k", jac, y)

    def tension_rates(self, jac: np.ndarray, friction: str) -> np.ndarray:
        """Each segment's tension per newton of the push whose Jacobian is ``jac`` (n_dof,): with
        that friction (none: every segment of a tendon the same)."""
        f = self.factors[friction]
        if not f:
            return np.full(len(self.springs), np.nan)
        with st.blas_threads():
            dq = cho_solve(f, np.asarray(jac, float))
        y = self.rows @ dq
        if friction == "stuck":
            return self.springs * y
        out = np.zeros_like(y)
        for name in self.tendons:
            m = np.array([o == name for o in self.owner])
            out[m] = np.sum(y[m]) / np.sum(1.0 / self.springs[m])
        return out


def bounds(eq: st.Equilibrium) -> Bounds:
    """:class:`Bounds` at ``eq`` (its loads' locked tendons; those slack there carry nothing either way)."""
    model = eq.model
    lines = {t.name: t for t in model.robot.tendons}
    locked = [n for n, mode in eq.loads.tendons.items() if mode[0] == "locked" and eq.tensions.get(n, 0.0) > SLACK_N]
    ch = chords(model, eq.q, set(locked))
    rows, springs, tension, owner, eyelets, turns = [], [], [], [], [], []
    H = eq.hessian.copy()
    for name in locked:
        c = ch[name]
        comp = segment_compliances(lines[name], c.lengths)
        k = lines[name].stiffness
        g = c.rows.sum(axis=0)
        H -= k * np.outer(g, g)                               # the frictionless tendon's one spring
        H += (c.rows.T / comp[:-1]) @ c.rows                  # each segment's own
        first = len(springs)
        M = len(c.lengths)
        rows += [*c.rows, np.zeros(model.n_dof)]
        run_k = 1.0 / comp[-1] if comp[-1] > 0 else math.inf
        springs += [*(1.0 / comp[:-1]), run_k]
        tension += [eq.tensions[name]] * (M + 1)
        owner += [name] * (M + 1)
        for i in range(1, M):                                 # interior eyelets: segments i-1 and i
            eyelets.append((first + i - 1, first + i))
            turns.append(c.turns[i - 1])
        if math.isfinite(run_k):                              # the tip eyelet, toward the run
            eyelets.append((first + M - 1, first + M))
            turns.append(c.exit_turn)
    H = 0.5 * (H + H.T)
    factors = {"none": _factor(eq.hessian), "stuck": _factor(H)}
    return Bounds(eq=eq, tendons=tuple(locked), rows=np.array(rows).reshape(-1, model.n_dof),
                  springs=np.array(springs), tension=np.array(tension), owner=tuple(owner),
                  eyelets=np.array(eyelets, int).reshape(-1, 2), turns=np.array(turns), factors=factors)


def _factor(H: np.ndarray):
    with st.blas_threads():
        try:
            return cho_factor(H)
        except np.linalg.LinAlgError:
            return ()


# ------------------------------------------------------------------ the capstan push

@dataclass(frozen=True)
class Push:
    """A push followed through its slips: the secant stiffness at its full size (N/mm), the size
    reached (N: less when a segment went slack first), how many eyelets slipped of how many, and
    the force at which the first slipped."""

    stiffness: float
    reached_n: float
    slipped: int
    eyelets: int
    first_slip_n: float | None
    slack: bool


def capstan_push(b: Bounds, jac: np.ndarray, push_n: float, mu: float) -> Push:
    """The push of ``push_n`` newtons along the output whose Jacobian is ``jac`` (its displacement
    per unit of the coordinates: the push's direction is its sign), followed through the eyelets'
    slips with friction coefficient ``mu`` (see the module's docstring)."""
    f = b.factors["stuck"]
    if not f:
        return Push(0.0, 0.0, 0, len(b.eyelets), None, False)
    m = len(b.springs)
    finite = np.isfinite(b.springs)
    K = np.where(finite, b.springs, 0.0)
    with st.blas_threads():
        Z = cho_solve(f, np.column_stack([jac, b.rows.T]))
    c = float(jac @ Z[:, 0])
    p = b.rows @ Z[:, 0]
    P = b.rows @ Z[:, 1:]
    e = len(b.eyelets)
    lo_seg, hi_seg = b.eyelets[:, 0], b.eyelets[:, 1]
    D = np.zeros((m, e))                                    # segment free-length change per slip (line tip side → base side)
    D[lo_seg, np.arange(e)] = -1.0
    D[hi_seg, np.arange(e)] = 1.0
    Kp = K * p
    MD = K[:, None] * (D - P @ (K[:, None] * D))            # K (I − P K) D: each slip's tension change per mm
    pKD = Kp @ D                                            # and the output's, less, per mm of each slip
    ratio = np.exp(mu * b.turns)
    tau = b.tension.copy()
    high = np.zeros(e, int)                                 # 0 stuck; +1 the tip side higher and slipping; -1 the base side
    F = u = 0.0
    first = None
    slack = False
    slipping = _Slipping(MD, ratio, lo_seg, hi_seg)
    for _ in range(MAX_PHASES):
        x = np.zeros(e)
        S, xs = slipping.solve(high, Kp)
        if len(S):
            x[S] = xs
            bad = S[high[S] * x[S] > 1e-15]                 # would slide back: it holds again
            if len(bad):
                high[bad] = 0
                continue
        rate = Kp + MD[:, S] @ x[S]                         # each segment's tension per newton
        w = c - pKD[S] @ x[S]                               # the output's displacement per newton
        step, which, side = push_n - F, -1, 0
        held = np.flatnonzero(high == 0)
        if len(held):
            a_, b_ = lo_seg[held], hi_seg[held]
            for sgn, (h_, l_) in ((1, (b_, a_)), (-1, (a_, b_))):
                den = rate[h_] - ratio[held] * rate[l_]
                ok = den > 1e-15
                dF = np.where(ok, np.maximum(0.0, (ratio[held] * tau[l_] - tau[h_]) / np.where(ok, den, 1.0)), np.inf)
                k = int(np.argmin(dF))
                if dF[k] < step:
                    step, which, side = float(dF[k]), int(held[k]), sgn
        falling = (rate < 0) & finite
        if np.any(falling):
            gone = float(np.min(np.where(falling, tau / np.where(falling, -rate, 1.0), np.inf)))
            if gone < step:
                step, which, slack = gone, -1, True
        F += step
        u += w * step
        tau = tau + rate * step
        if which < 0:
            break
        high[which] = side
        first = F if first is None else first
    return Push(F / u if u > 0 else math.inf, F, int(np.count_nonzero(high)), e, first, slack)


class _Slipping:
    """The slipping eyelets' system A x = r of :func:`capstan_push` (a row per slipping eyelet: its
    capstan ratio held; a column per slip), A and its inverse kept as eyelets join and leave it
    (a bordered inverse: O(n²) a change where a fresh solve is O(n³); a push through a long robot's
    hundreds of eyelets slips them one phase at a time). Each answer is refined once against A,
    and solved afresh when the kept inverse no longer answers to REFINE_TOL."""

    def __init__(self, MD: np.ndarray, ratio: np.ndarray, lo_seg: np.ndarray, hi_seg: np.ndarray):
        self.MD, self.ratio, self.lo_seg, self.hi_seg = MD, ratio, lo_seg, hi_seg
        self.members: list[int] = []                # the slipping eyelets, in A's order
        self.sides: list[int] = []
        self.his: list[int] = []                    # each one's higher and lower segment
        self.los: list[int] = []
        self.A = np.zeros((0, 0))
        self.inv = np.zeros((0, 0))

    def _leave(self, i: int) -> None:
        M, keep = self.inv, np.arange(len(self.members)) != i
        self.inv = M[keep][:, keep] - np.outer(M[keep, i], M[i, keep]) / M[i, i]
        self.A = self.A[keep][:, keep]
        for seq in (self.members, self.sides, self.his, self.los):
            del seq[i]

    def _join(self, k: int, side: int) -> None:
        n, S = len(self.members), self.members
        hi, lo = (self.hi_seg[k], self.lo_seg[k]) if side > 0 else (self.lo_seg[k], self.hi_seg[k])
        u = self.MD[self.his, k] - self.ratio[S] * self.MD[self.los, k]     # its column, on the rows there
        v = self.MD[hi, S] - self.ratio[k] * self.MD[lo, S]                 # its row, on the columns there
        d = self.MD[hi, k] - self.ratio[k] * self.MD[lo, k]
        A = np.empty((n + 1, n + 1))
        A[:n, :n], A[:n, n], A[n, :n], A[n, n] = self.A, u, v, d
        Au, vA = self.inv @ u, v @ self.inv
        schur = d - v @ Au
        inv = np.full((n + 1, n + 1), np.nan)       # singular as bordered: solved afresh
        if schur != 0:
            inv[:n, :n] = self.inv + np.outer(Au, vA) / schur
            inv[:n, n], inv[n, :n], inv[n, n] = -Au / schur, -vA / schur, 1.0 / schur
        self.A, self.inv = A, inv
        self.members.append(k)
        self.sides.append(side)
        self.his.append(int(hi))
        self.los.append(int(lo))

    def solve(self, high: np.ndarray, Kp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(the slipping eyelets, their slips per newton of push) for the sides ``high`` gives."""
        for i in range(len(self.members) - 1, -1, -1):
            if high[self.members[i]] != self.sides[i]:
                self._leave(i)
        known = set(self.members)
        for k in np.flatnonzero(high):
            if int(k) not in known:
                self._join(int(k), int(high[k]))
        S = np.array(self.members, int)
        if not len(S):
            return S, np.zeros(0)
        r = self.ratio[S] * Kp[self.los] - Kp[self.his]
        x = self.inv @ r
        x = x + self.inv @ (r - self.A @ x)
        if not np.all(np.isfinite(x)) or np.any(np.abs(r - self.A @ x) >
                                                REFINE_TOL * (np.abs(self.A) @ np.abs(x) + np.abs(r))):
            x = np.linalg.solve(self.A, r)
            self.inv = np.linalg.inv(self.A)
        return S, x
