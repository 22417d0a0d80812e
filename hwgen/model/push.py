"""The bench's push (the paper's Sect. III-C) on a tensioned state: displacement-controlled, out and
back, with Coulomb friction at every eyelet by the angle the line turns there, and tendons going
slack and taut again as they do (numpy, scipy and the compiled event loop of :mod:`.push_kernels`,
on :mod:`hwgen.model.friction`'s segments).

The robot. The state's equilibrium (:mod:`hwgen.model.protocol`) and its Hessian with every locked
tendon cut at its eyelets, each segment its own spring (friction's ``stuck`` Hessian, H): the
response to the push is linear in H about that equilibrium, the tendons' segments and the eyelets
are followed exactly. Every locked tendon is a chain of segments (its chords between eyelets, then
its run to the drum); each segment j has a spring k_j and a tension τ_j; line may slide through an
eyelet from one segment into the next, which moves free length between them (x, one coordinate per
eyelet, + toward the tip), and a slack tendon's free length follows its path, keeping it at no
tension (one more coordinate per tendon, on its last segment: the line it has to spare, negative). With D the map from those coordinates to each
segment's change of free length, G the segments' rows dℓ_j/dq, j the push point's row and
u its displacement along the push (displacement control: the arm sets u, the load cell reads F):

    u = c F + aᵀx,         τ = τ₀ + v u + M x,

c = j H⁻¹ jᵀ, p = G H⁻¹ jᵀ, P = G H⁻¹ Gᵀ, a = Dᵀ K p, v = K p / c and
M = K (P − p pᵀ/c) K D − K D. Everything after one Cholesky of H is in segment space (a few dozen
unknowns), for every push point at once.

Friction (the capstan, Euler–Eytelwein). An eyelet where the line turns by θ holds while the
tension on either side is within e^(μθ) of the other's; it slips once the higher reaches that
ratio, line sliding into the higher side and the ratio held, until the motion would reverse, when
it holds again. Under that rule a tendon goes slack as a whole (no tension can be held against a
slack neighbour), and is taut again once its path has grown back to the line it has; it comes
back with no tension and every eyelet held. The push is followed from event to event (an eyelet
slips or holds, a tendon slackens or tautens, the contact opens, the stroke ends): between them
every rate is constant.

The push. The arm moves from its start (where it touched the disk the first time) out by the
stroke and back. The load cell only pushes: going back, once F reaches zero the block leaves the
disk and the robot stays where friction holds it; the next push finds it there. What the model
leaves out: the change of the robot's geometry over the push (the linearisation: measured against
the full statics in tests/test_experiment.py), the tension's share of the Hessian as it changes
(under 0.2 % of the prototype's tip stiffness), the load cell's own give and the robot's dynamics
(the push is slow).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve

from . import friction as fr
from . import push_kernels as pk
from . import statics as st

FREE_RATIO = 1e-9          # an eyelet whose e^(μθ) is this close to 1 slips both ways without holding
SAME_MM = 1e-9             # a push that leaves every slip within this of where it found it repeats itself


@dataclass(frozen=True)
class Lines:
    """A tensioned state's locked, taut tendons cut at their eyelets (see the module's docstring):
    per segment its spring, tension and tendon; per eyelet its two segments (base side, tip side),
    its turn and capstan ratio; D and P; the push points' c and p."""

    springs: np.ndarray          # (m,) N/mm
    tension: np.ndarray          # (m,) N
    tendon: np.ndarray           # (m,) index into names
    names: tuple[str, ...]
    eyelets: np.ndarray          # (e, 2) segment indices, base side then tip side
    turns: np.ndarray            # (e,) θ, rad
    ratio: np.ndarray            # (e,) e^(μθ)
    D: np.ndarray                # (m, e + T): free-length change per slip and per slack tendon's spare line
    P: np.ndarray                # (m, m)
    c: np.ndarray                # (k,) per push point
    p: np.ndarray                # (k, m) per push point

    @property
    def n_eyelets(self) -> int:
        return len(self.eyelets)


def lines(b: fr.Bounds, mu: float, jacs: np.ndarray) -> Lines:
    """:class:`Lines` of a state's friction bounds ``b`` with eyelet friction ``mu``, for the push
    points whose rows (the displacement along the push per unit of the coordinates) are ``jacs``
    (k, n_dof)."""
    keep = np.flatnonzero(np.isfinite(b.springs))            # a rigid run (no drum, no tie-off) is no segment
    index = np.full(len(b.springs), -1)
    index[keep] = np.arange(len(keep))
    names = tuple(dict.fromkeys(b.owner))
    tendon = np.array([names.index(b.owner[i]) for i in keep], np.int64)
    eyelets = index[b.eyelets] if len(b.eyelets) else np.zeros((0, 2), int)
    G = b.rows[keep]
    m, e, T = len(keep), len(eyelets), len(names)
    D = np.zeros((m, e + T))
    D[eyelets[:, 0], np.arange(e)] = -1.0                    # line slid tipward leaves the base side
    D[eyelets[:, 1], np.arange(e)] = 1.0
    for t in range(T):
        D[np.flatnonzero(tendon == t)[-1], e + t] = 1.0      # a slack tendon's free length, on its last segment
    factor = b.factors["stuck"]
    jacs = np.atleast_2d(jacs)
    with st.blas_threads():
        Z = cho_solve(factor, np.column_stack([jacs.T, G.T]))
    k = len(jacs)
    c = np.einsum("kn,nk->k", jacs, Z[:, :k])
    return Lines(springs=b.springs[keep], tension=b.tension[keep], tendon=tendon, names=names, eyelets=eyelets,
                 turns=b.turns, ratio=np.exp(mu * b.turns), D=D, P=G @ Z[:, k:], c=c, p=(G @ Z[:, :k]).T)


def with_friction(ln: Lines, mu: float) -> Lines:
    """The same lines with eyelet friction ``mu``."""
    return dataclasses.replace(ln, ratio=np.exp(mu * ln.turns))


@dataclass
class Rest:
    """Where a push leaves the lines: the coordinates x (each eyelet's slip, each slack tendon's free
    length), and which tendons are slack (every eyelet holds between pushes). Locked tendons slack
    in the tensioned state are not among the lines: the protocol leaves none."""

    x: np.ndarray
    slack: np.ndarray


def at_rest(ln: Lines) -> Rest:
    """The lines as the protocol left them: no slip, every tendon taut."""
    return Rest(np.zeros(ln.D.shape[1]), np.zeros(len(ln.names), bool))


@dataclass(frozen=True)
class Branch:
    """One stroke of a push: the displacement u (mm, along the push, from the tensioned state) and
    the force F (N) at each event, and whether it ended because the contact opened."""

    u: list
    force: list
    opened: bool


class _Point:
    """The push at one point of :class:`Lines`, and the state it moves through (the event loop is
    :func:`hwgen.model.push_kernels.follow`)."""

    def __init__(self, ln: Lines, k: int, rest: Rest):
        self.ln = ln
        K = ln.springs
        c, p = float(ln.c[k]), ln.p[k]
        self.c = c
        self.a = ln.D.T @ (K * p)
        self.v = K * p / c
        Q = ln.P - np.outer(p, p) / c
        self.M = np.ascontiguousarray((K[:, None] * Q * K[None, :]) @ ln.D - K[:, None] * ln.D)
        self.free = ln.ratio - 1.0 < FREE_RATIO
        self.x = rest.x.copy()
        self.slack = rest.slack.copy()
        self.mode = np.zeros(ln.n_eyelets, np.int64)            # +1 slipping tipward (tip side high), -1 baseward, 0 held
        self.eye_tendon = ln.tendon[ln.eyelets[:, 0]] if ln.n_eyelets else np.zeros(0, np.int64)
        self.slackened = np.zeros(len(ln.names), bool)          # tendons that went slack

    def rest(self) -> Rest:
        return Rest(self.x.copy(), self.slack.copy())

    def follow(self, u: float, u_to: float | None, s: float, *, target_n: float | None = None,
               until_open: bool = False) -> tuple[Branch, float]:
        """Move the push point from ``u`` in direction ``s`` (±1) to ``u_to`` (None: until an end
        condition); ``target_n``: stop once F reaches it; ``until_open``: stop once F falls to zero.
        Returns the branch (each event's u and F) and where it stopped."""
        ln = self.ln
        out_u = np.empty(pk.MAX_EVENTS + 2)
        out_f = np.empty(pk.MAX_EVENTS + 2)
        system = (self.M, self.v, self.a, self.c, ln.tension, ln.tendon)
        eyes = (ln.eyelets[:, 0].copy(), ln.eyelets[:, 1].copy(), ln.ratio, self.free, self.eye_tendon)
        motion = (float(u), math.nan if u_to is None else float(u_to), float(s),
                  math.nan if target_n is None else float(target_n), until_open)
        n, u, why = pk.follow(system, eyes, (self.x, self.mode, self.slack, self.slackened), motion, out_u, out_f)
        return Branch(out_u[:n].tolist(), out_f[:n].tolist(), why == pk.OPEN), float(u)


@dataclass(frozen=True)
class Stroke:
    """One repetition of a push: the arm's displacement from its start and the force it reads at
    each event, out then back (the force zero where the block is off the disk)."""

    out_x: np.ndarray
    out_f: np.ndarray
    back_x: np.ndarray
    back_f: np.ndarray
    slackened: tuple[str, ...]      # the tendons that went slack in it


def repeat(ln: Lines, k: int, stroke_mm: float, repetitions: int, rest: Rest | None = None
           ) -> tuple[list[Stroke], Rest]:
    """``repetitions`` pushes at point ``k`` of ``ln``, each out by ``stroke_mm`` from where the arm
    first touched the disk and back, each from where the last left the robot (``rest``: from an
    earlier push elsewhere; default as tensioned). Returns the strokes and where they leave it."""
    rest = rest or at_rest(ln)
    pt = _Point(ln, k, rest)
    start = float(pt.a @ pt.x)                     # the arm first touches the disk where F is zero there
    strokes: list[Stroke] = []
    while len(strokes) < repetitions:
        before = pt.rest()
        contact = float(pt.a @ pt.x)
        out, u = pt.follow(contact, start + stroke_mm, 1.0)
        back, _ = pt.follow(u, None, -1.0, until_open=True)
        strokes.append(_stroke(out, back, start, contact, tuple(n for n, f in zip(ln.names, pt.slackened) if f)))
        pt.slackened[:] = False
        if np.array_equal(before.slack, pt.slack) and np.allclose(before.x, pt.x, rtol=0.0, atol=SAME_MM):
            strokes += strokes[-1:] * (repetitions - len(strokes))      # it left the robot as it found it
    return strokes, pt.rest()


def _stroke(out: Branch, back: Branch, start: float, contact: float, slackened: tuple[str, ...]) -> Stroke:
    ox = np.asarray(out.u) - start
    of = np.maximum(np.asarray(out.force), 0.0)
    if contact > start:                             # the arm closes the gap before it touches
        ox, of = np.r_[0.0, ox], np.r_[0.0, of]
    bx = np.asarray(back.u) - start
    bf = np.maximum(np.asarray(back.force), 0.0)
    return Stroke(ox, of, bx, bf, slackened)


def force_reached(ln: Lines, k: int, target_n: float, most_mm: float, rest: Rest | None = None) -> float:
    """How far (mm, from where the arm touches the disk) a push at point ``k`` goes before the force
    reaches ``target_n``, at most ``most_mm``; from ``rest`` (default: as tensioned)."""
    pt = _Point(ln, k, rest or at_rest(ln))
    start = float(pt.a @ pt.x)
    _, u = pt.follow(start, start + most_mm, 1.0, target_n=target_n)
    return float(min(u - start, most_mm))


def recorded(strokes: list[Stroke], step_mm: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """What the arm and the load cell record of each repetition, a sample every ``step_mm`` of the
    arm's travel (its speed over the sample rate): (displacement, force), out and back."""
    out = []
    for s in strokes:
        peak = float(s.out_x[-1])
        n = max(2, int(round(peak / step_mm)) + 1)
        xs = np.linspace(0.0, peak, n)
        fo = np.interp(xs, s.out_x, s.out_f, left=0.0)
        bx, bf = s.back_x[::-1], s.back_f[::-1]                # increasing for interp
        fb = np.interp(xs[:-1][::-1], bx, bf, left=0.0, right=float(s.back_f[0]))
        out.append((np.r_[xs, xs[:-1][::-1]], np.r_[fo, fb]))
    return out


def peak_window(x: np.ndarray, samples: int) -> slice:
    """The samples within ``samples`` of a push's peak (its largest displacement), either side: the
    paper's "400 samples before and after each peak"."""
    k = int(np.argmax(x))
    return slice(max(0, k - samples), k + samples + 1)


def sampled(strokes: list[Stroke], step_mm: float, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples eq. (4) is fitted to: :func:`recorded` within ``samples`` of each repetition's peak,
    as (displacement, force, repetition index)."""
    X, F, R = [], [], []
    for r, (x, f) in enumerate(recorded(strokes, step_mm)):
        w = peak_window(x, samples)
        X.append(x[w])
        F.append(f[w])
        R.append(np.full(len(x[w]), r))
    return np.concatenate(X), np.concatenate(F), np.concatenate(R)


def eq4(x: np.ndarray, force: np.ndarray, rep: np.ndarray) -> float:
    """β of the paper's eq. (4), F = β x + η_l: one slope for every repetition, an intercept each
    (least squares)."""
    reps = np.unique(rep)
    A = np.column_stack([x] + [(rep == r).astype(float) for r in reps])
    return float(np.linalg.lstsq(A, force, rcond=None)[0][0])
