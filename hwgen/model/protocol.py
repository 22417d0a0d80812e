"""How the tendons of a state are tensioned and locked: the paper's protocol (Sect. III-B), in the
robot's stated orientation (numpy and scipy only, on :mod:`hwgen.model.statics`).

The paper: "the actuating tendon pair is first pre-tensioned so that when the stiff direction
of the backbone is turned against gravity, the beam is straight"; then, the flexible direction
along gravity again, "subsequent tendons are pre-tensioned such that the backbone remains as
straight as possible by visual inspection". Read as a procedure, for one tendon state and one
orientation of the robot (gravity's direction in the base frame, or none):

1. A tendon whose ``pretension_n`` the design gives is locked at that tension with the robot
   held straight (ℓ₀ = ℓ_straight − τ/k, as in the jig) before anything else: the user's value
   wins, as the schema describes it.
2. The actuating channel's tendons are tensioned together with the strip on edge (gravity
   across its height, along x: the weight then bends only the stiff direction, by a tiny part of
   a millimetre, which is left out), to one tension at which the beam is straight, and locked
   there (ℓ₀ = ℓ_straight − T_A/k). Straightness fixes how the pair shares its tension (a
   mirrored pair equally), not its level: T_A is the least that keeps every tendon of the pair at
   or above ``check.taut_floor_n`` once the robot is turned into the stated orientation (the
   paper: both sides taut).
3. Each further channel of the state, in the tensioner's channel order, is pulled (all its
   tendons at one tension T, tension-controlled) with the robot in the stated orientation and
   the earlier tendons locked; T is the one that leaves the backbone straightest (least
   Σ (x² + z²) of the disks' centres: how far they lie off the straight line from the clamp,
   which is what a photograph shows), but not under the floor; then each is locked where it
   is (ℓ₀ = ℓ − T/k), which leaves the robot in the same equilibrium.
4. If locking a later channel left an earlier protocol tendon under the floor (by more than
   :data:`FIXUP_TOL`), that channel's
   least tension is raised by the shortfall and the state tensioned again (a few times at most);
   what is still under it is said in the notes (its routing does not let it be held taut).

Weightless, nothing needs holding: the pair and every further channel sit at the floor. A state
is tensioned from the robot untensioned; states that share a first part of the sequence (A, then
AC1, then AC1C2) share its work.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from . import friction as fr
from . import statics as st

SUMMARY = ("the actuating pair locked straight (strip on edge) at the least tension that keeps it taut once "
           "turned; each further channel, in channel order, pulled in the stated orientation to the least tension "
           "that holds the disks within check.straight_within_mm of the straightest it can, never under "
           "check.taut_floor_n nor over the allowable load, and locked there (Sect. III-B)")
def set_words(name: str, set_n: float | None, source: str) -> str:
    """A tendon's set tension in the one wording every output uses: ``C1 to 5.60 N (its
    pretension_n)``; the tension it carries once its state is locked is :func:`locked_words`'s."""
    if set_n is None:
        return f"{name} taut"
    return f"{name} to {set_n:.2f} N" + (" (its pretension_n)" if source == "pretension_n" else "")


def locked_words(tensions: dict[str, float]) -> str:
    """The tensions the tendons carry once locked, in the one wording: ``C1 8.54 N, C2 7.10 N``."""
    return ", ".join(f"{n} {v:.2f} N" for n, v in tensions.items())


FLOOR_TOL = 1e-3                    # N: a tension this close to its goal is at it (the searches stop there)
FIXUP_TOL = 0.01                    # N: a protocol tendon that ends this far under the floor is set higher and tensioned again
LEVEL_ITERATIONS = 8                # the pair's level: solves at most (one suffices where both stay taut)
STRAIGHT_ITERATIONS = 6             # a further channel's straightest tension: Gauss-Newton steps at most
FIXUPS = 4                          # tensionings of a state again to lift a tendon back to its floor


@dataclass
class Tensioned:
    """A state tensioned in one orientation: every locked tendon's Loads entry, the equilibrium
    there (locked), the tension each was set to at its step and how (``"pretension_n"`` or
    ``"protocol"``), and notes in words."""

    locks: dict
    equilibrium: st.Equilibrium
    set_n: dict
    source: dict
    notes: list = field(default_factory=list)


def station_nodes(model: st.Model, stations) -> np.ndarray:
    return np.array([model.node_at(s) for s in stations])


def _solve(model, tendons, gravity, q0):
    return st.solve(model, st.Loads(tendons=tendons, gravity=gravity), q0)


def _pair_level(model, locks, names, gravity, bounds, q0):
    """(T_A, locks with the pair's, equilibrium) for the actuating channel (step 2), T_A within
    ``bounds`` (least, most)."""
    springs = {t.name: t.stiffness for t in model.robot.tendons}
    least, most = bounds
    T = least
    for _ in range(LEVEL_ITERATIONS):
        trial = {**locks, **st.locked_at(model, {n: T for n in names})}
        eq = _solve(model, trial, gravity, q0)
        virtual = min(springs[n] * (eq.lengths[n] - trial[n][1]) for n in names)    # negative when slack
        new = min(most, max(least, T + least - virtual))      # both taut, each tension moves with T one for one
        if abs(new - T) < FLOOR_TOL:
            break
        T, q0 = new, eq.q
    return T, trial, eq


def _deviation(model, eq, names, nodes):
    """The disks' offsets from the straight line (x and z, (2K,)) at ``eq``, and their change per
    newton of the named tendons' common tension (tension-controlled: dq/dT = −H⁻¹ d(Σ ℓ)/dq); None
    for the change when the robot is not stable there."""
    kin = tuple(x[0] for x in model.forward(eq.q[None, :]))
    pts = kin[0][nodes]
    move, _ = fr.point_rows(model, kin, nodes, pts)
    ch = fr.chords(model, eq.q, set(names))
    pull = sum(ch[n].rows.sum(axis=0) for n in names)
    with st.blas_threads():
        try:
            dq = -cho_solve(cho_factor(eq.hessian), pull)
        except np.linalg.LinAlgError:
            return np.r_[pts[:, 0], pts[:, 2]], None
    return np.r_[pts[:, 0], pts[:, 2]], np.r_[move[:, :, 0] @ dq, move[:, :, 2] @ dq]


def rms(eq: st.Equilibrium, nodes) -> float:
    """How far the disks (at ``nodes``) lie off the straight line from the clamp, root mean square, mm."""
    return float(np.sqrt(np.mean(np.sum(eq.p[nodes][:, [0, 2]] ** 2, axis=1))))


def _straightest(model, locks, names, gravity, bounds, within, nodes, q0):
    """(T, equilibrium) for a further channel's tendons ``names`` (step 3), pulled at T with
    ``locks`` (the earlier tendons) locked: the least T in ``bounds`` (least, most) at which the
    disks lie within ``within`` mm (root mean square) of the straightest the channel can hold them."""
    least, most = bounds

    def pulled(T, q):
        return _solve(model, {**locks, **{n: ("tension", T) for n in names}}, gravity, q)

    eq = pulled(least, q0)
    T, at_least = least, eq
    if gravity is not None:
        for _ in range(STRAIGHT_ITERATIONS):                     # Gauss-Newton on Σ offset², within bounds
            dev, dp = _deviation(model, eq, names, nodes)
            if dp is None or dp @ dp <= 0:
                break
            new = min(most, max(least, T - float(dev @ dp) / float(dp @ dp)))
            if abs(new - T) < FLOOR_TOL:
                break
            T, eq = new, pulled(new, eq.q)
        goal = rms(eq, nodes) + within
        lo, hi = (least, rms(at_least, nodes) - goal), (T, -within)
        if lo[1] <= 0:
            T, eq = least, at_least                             # no visible gain over the floor
        else:
            for _ in range(STRAIGHT_ITERATIONS):                 # the least T at the goal: regula falsi
                t = lo[0] + (hi[0] - lo[0]) * lo[1] / (lo[1] - hi[1])
                eq = pulled(t, eq.q)
                g = rms(eq, nodes) - goal
                T = t
                if abs(g) < 0.01 * within:
                    break
                lo, hi = ((t, g), hi) if g > 0 else (lo, (t, g))
    return T, eq


@dataclass(frozen=True)
class Rules:
    """What the protocol holds to: the actuating channel, the least tension a locked tendon may end
    at (``check.taut_floor_n``), the most a tendon may be pulled to (the design's allowable: its
    break load over ``check.tendon_safety_factor``), and how near its straightest a further
    channel leaves the robot (``check.straight_within_mm``, root mean square over the disks)."""

    actuating: str
    floor_n: float
    allowable_n: float
    within_mm: float


def tension_state(model: st.Model, channels: tuple[str, ...], gravity, pretension: dict, rules: Rules,
                  stations, memo: dict | None = None) -> Tensioned:
    """The tendons of the channels named, tensioned and locked by the protocol (module docstring)
    with gravity along ``gravity`` (a unit vector in the base frame, or None). ``pretension``:
    each tendon's ``pretension_n`` (None where the design leaves it to the protocol); ``stations``:
    the disks' arc lengths (straightness is taken at them, the base's excluded); ``memo``: shared
    by the states of one orientation (and model and rules)."""
    memo = {} if memo is None else memo
    floor = rules.floor_n
    by_channel = {c: [t.name for t in model.robot.tendons if t.channel == c] for c in channels}
    given = {n: pretension[n] for c in channels for n in by_channel[c] if pretension.get(n) is not None}
    nodes = station_nodes(model, stations[1:])
    extra: dict[str, float] = {}
    notes: list[str] = []
    for attempt in range(FIXUPS + 1):
        locks, eq, set_n = _sequence(model, channels, given, gravity, rules, extra, nodes, memo)
        final = _solve(model, locks, gravity, eq.q)
        low = {n: final.tensions[n] for n in set_n if final.tensions[n] < floor - FIXUP_TOL}
        if not low:
            break
        if attempt == FIXUPS:
            notes += [f"{n} ends at {v:.2f} N, under the {floor:g} N floor: tensioning it harder at its turn does "
                      f"not keep it there once the later tendons are locked" for n, v in low.items()]
            break
        for n, v in low.items():
            c = next(c for c in channels if n in by_channel[c])
            extra[c] = extra.get(c, 0.0) + (floor - v)
    source = {n: ("pretension_n" if n in given else "protocol") for c in channels for n in by_channel[c]}
    if any(v > FLOOR_TOL for v in extra.values()):
        notes.append("set over the floor so that no tendon ends under it once the later ones are locked: "
                     + ", ".join(f"{c} +{v:.2f} N" for c, v in extra.items() if v > FLOOR_TOL))
    return Tensioned(locks, final, {**given, **set_n}, source, notes)


def _sequence(model, channels, given, gravity, rules: Rules, extra, nodes, memo):
    """Steps 1-3 for the channels in order: (locks, the last equilibrium, tension set per protocol tendon)."""
    springs = {t.name: t.stiffness for t in model.robot.tendons}
    by_channel = {c: [t.name for t in model.robot.tendons if t.channel == c] for c in channels}
    locks, eq, set_n, done = st.locked_at(model, given), None, {}, ()
    for c in channels:
        done = (*done, c)
        key = (gravity, done, tuple(sorted(given.items())),
               tuple(sorted((k, v) for k, v in extra.items() if k in done)))
        if key in memo:
            locks, eq, set_n = memo[key]
            continue
        names = [n for n in by_channel[c] if n not in given]
        least = min(rules.floor_n + extra.get(c, 0.0), rules.allowable_n)
        q0 = None if eq is None else eq.q
        T = None
        if not names:
            eq = _solve(model, locks, gravity, q0)
        elif c == rules.actuating:                  # straight, on edge: locked at the straight lengths
            T, locks, eq = _pair_level(model, locks, names, gravity, (least, rules.allowable_n), q0)
        else:                                       # in the stated orientation: pulled, then locked where it is
            T, eq = _straightest(model, locks, names, gravity, (least, rules.allowable_n), rules.within_mm, nodes, q0)
            locks = {**locks, **{n: ("locked", eq.lengths[n] - T / springs[n]) for n in names}}
        set_n = {**set_n, **({n: T for n in names} if T is not None else {})}
        memo[key] = (locks, eq, set_n)
    if eq is None:
        eq = _solve(model, locks, gravity, None)
    return locks, eq, set_n
