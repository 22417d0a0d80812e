"""The paper's push test (Sect. III-C) predicted for a design, as the bench measures it (numpy and
scipy only, from the plan; `hwgen experiment`).

For every tendon state (:func:`hwgen.model.stiffness.states`, the paper's nine for the prototype):
the robot in ``experiment.orientation``, tensioned and locked by the paper's protocol
(:mod:`hwgen.model.protocol`, as `hwgen stiffness` does it); then pushed at each disk from
``experiment.first_disk`` to the tip, in that order, ``experiment.repetitions`` times each, toward
``experiment.push_toward`` by the arm (displacement-controlled, out and back, at
``experiment.displacement_rate_mm_s``), with eyelet friction by each segment's turn and tendons
slackening as they do (:mod:`hwgen.model.push`); each push from where the last left the robot.
The samples the load cell would give (``experiment.sample_rate_hz``) over
``experiment.fit_window_samples`` either side of each peak are fitted with the paper's eq. (4),
F = β x + η, one β over the repetitions, an η each: that β is what the bench would report.

How far each disk is pushed: as far as keeps the force within ``experiment.load_fraction`` of the
load cell's range for the stiffest robot of the band (the paper: "adjusted individually to ensure
that the forces were within the sensing range"), at most ``experiment.max_push_mm``.

The band. The values the paper does not give and the prediction depends on (the line's EA, the
tie-off's give, the eyelets' friction, the strip's E) each have a range in
``experiment.ranges``. Each one stiffens the robot one way (EA, μ and E up, the tie-off's give
down): a row's band is the robot with every ranged value at its softening end and at its
stiffening end (and the nominal, should it fall outside). A ratio of two states is no such
function: its band is taken over every corner of the ranges, each corner tensioning both states
again, since the protocol locks every tendon through its spring.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import DesignError
from . import friction as fr
from . import protocol
from . import push as pu
from . import statics as st
from . import stiffness as sf
from .settings import RANGED

PAPER_ENDPOINT_RATIO = sf.PAPER_ENDPOINT_RATIO
FIELDS = tuple(RANGED.values())     # EA, the tie-off's give, μ, the strip's E: the values the band can span
STIFFENS = {"tendon_material.axial_stiffness_n": 1, "tendon_material.tie_off_compliance_mm_per_n": -1,
            "tendon_material.eyelet_friction": 1, "backbone.modulus_gpa": 1}     # which end of a range is the stiffer
ROLL_DEG = {"gravity -z": 0.0, "gravity +z": 180.0}      # about the backbone, from the robot with +z up
ON_EDGE_DEG = 90.0                                       # the strip on edge: its height along gravity
STRIP_STEPS = 6                                          # forces the strip alone's push is solved at, at least
SIZING = 4                                               # tries at a push's length before it stays under the target
FORCE_TOL = 1e-3                                         # a peak this far over the target is at it
KEPT_ROBOTS = 8                                          # robots a Bench keeps tensioned (each a few MB)


# ------------------------------------------------------------------ the values the band spans

def nominal(plan) -> dict[str, float]:
    """The design's own value of every field in :data:`FIELDS` (no eyelet friction given: 0)."""
    tm, bb = plan.tendon_material, plan.backbone
    return {FIELDS[0]: tm.axial_stiffness_n, FIELDS[1]: tm.tie_off_compliance_mm_per_n,
            FIELDS[2]: tm.eyelet_friction or 0.0, FIELDS[3]: bb.modulus_gpa}


def with_values(plan, values: dict[str, float]):
    """The plan with the fields of :data:`FIELDS` named in ``values`` set to them."""
    tm = dataclasses.replace(plan.tendon_material, **{f.split(".")[1]: v for f, v in values.items()
                                                      if f.startswith("tendon_material.")})
    bb = dataclasses.replace(plan.backbone, **{f.split(".")[1]: v for f, v in values.items()
                                               if f.startswith("backbone.")})
    return dataclasses.replace(plan, tendon_material=tm, backbone=bb)


def ends(plan) -> dict[str, dict[str, float]]:
    """The parameter sets of a row's band: ``nominal``, ``soft`` (every ranged value at its softening
    end) and ``stiff``."""
    base = nominal(plan)
    rng = {f: (lo, hi) for f, lo, hi in plan.experiment.ranges}
    soft = {f: (rng[f][0] if STIFFENS[f] > 0 else rng[f][1]) for f in rng}
    stiff = {f: (rng[f][1] if STIFFENS[f] > 0 else rng[f][0]) for f in rng}
    return {"nominal": base, "soft": {**base, **soft}, "stiff": {**base, **stiff}}


def corners(plan) -> list[dict[str, float]]:
    """Every corner of the ranges (the other fields nominal); none without ranges."""
    base = nominal(plan)
    rng = [(f, (lo, hi)) for f, lo, hi in plan.experiment.ranges]
    if not rng:
        return []
    return [{**base, **dict(zip([f for f, _ in rng], pick))} for pick in itertools.product(*[r for _, r in rng])]


# ------------------------------------------------------------------ one robot, tensioned

@dataclass
class Prepared:
    """One state of one robot, tensioned in the experiment's orientation and ready to push: the
    protocol's result and its lines for the push at every disk (friction given later)."""

    state: sf.State
    done: protocol.Tensioned
    lines: pu.Lines | None          # None: no locked, taut tendon (the strip alone); push point k is disk k + 2
    compliance: np.ndarray          # (k,) the push's j H⁻¹ jᵀ at every disk but the base (frictionless)
    toward: float                   # +1 or -1: the push along the base frame's z
    stations: tuple[float, ...]     # each disk's arc length, the base's first
    curves: dict = field(default_factory=dict)    # the strip alone: disk -> (u, F) of its push, the full statics


@dataclass
class Robot:
    """The robot of one set of the spring values (EA, the tie-off's give, the strip's E): the
    statics' description and model, and its states tensioned so far."""

    desc: sf.Described
    model: st.Model
    states: dict                    # state name -> Prepared


def disks_pushed(plan) -> list[int]:
    """The disks pushed, counted from 1 at the clamped base as the paper does; raises
    :class:`hwgen.errors.DesignError` when ``experiment.first_disk`` is past the tip."""
    n = len(plan.stations)
    if plan.experiment.first_disk > n:
        raise DesignError("experiment.first_disk", f"{plan.experiment.first_disk} is past the tip: this robot has "
                                                   f"{n} disks (1, the clamped base, to {n})")
    return list(range(plan.experiment.first_disk, n + 1))


class Bench:
    """The experiment of a plan on robots of several parameter sets. The design's own robot is
    tensioned by the paper's protocol (:func:`hwgen.model.protocol.tension_state`); any other is
    tensioned as protocol.md tells a lab to, to the tensions the protocol set on the design's robot
    (:func:`replay`): a lab does not know its robot's springs. Each robot is tensioned once for every
    set that shares its springs (friction does not change the tensions), each state's pushes once
    per set."""

    def __init__(self, plan, measured: dict | None = None, h_max: float = sf.STUDY_H_MAX):
        self.plan, self.measured, self.h_max = plan, measured, h_max
        self.design = self._springs(nominal(plan))
        self.robots: dict[tuple, Robot] = {}
        self.pushes: dict[tuple, list[Pushed]] = {}

    @staticmethod
    def _springs(values: dict) -> tuple:
        return tuple(sorted((f, v) for f, v in values.items() if f != FIELDS[2]))

    def robot(self, values: dict, which) -> Robot:
        """The robot of ``values`` with the states named tensioned."""
        key = self._springs(values)
        if key not in self.robots:
            desc = sf.describe(with_values(self.plan, values), self.measured)
            while len(self.robots) >= KEPT_ROBOTS:
                self.robots.pop(next(k for k in self.robots if k != self.design))    # the longest unused first
            self.robots[key] = Robot(desc, st.Model(desc.robot, self.h_max), {})
        r = self.robots.pop(key)
        self.robots[key] = r
        todo = [s for s in sf.states(self.plan) if s.name in which and s.name not in r.states]
        if todo:
            self._tension(r, todo, key == self.design)
        return r

    def _tension(self, r: Robot, todo: list[sf.State], design: bool) -> None:
        x = self.plan.experiment
        gravity = sf.ORIENTATIONS[x.orientation]
        sign = 1.0 if x.push_toward == "+z" else -1.0
        stations = r.desc.stations[1:]
        memo = r.__dict__.setdefault("_memo", {})
        for s in todo:
            if design:
                done = protocol.tension_state(r.model, s.channels, gravity, r.desc.pretension, r.desc.rules,
                                              r.desc.stations, memo)
            else:
                done = replay(r, s, self.robot(nominal(self.plan), [s.name]).states[s.name].done, gravity, memo)
            eq = done.equilibrium
            jacs = sign * sf.push_rows(r.model, eq, stations)
            b = fr.bounds(eq)
            r.states[s.name] = Prepared(s, done, pu.lines(b, 0.0, jacs) if b.tendons else None,
                                        eq.compliance(jacs), sign, r.desc.stations)

    def tensioned(self, values: dict, state: str) -> Prepared:
        """A state of the robot of ``values``, its lines with the set's eyelet friction."""
        t = self.robot(values, [state]).states[state]
        if t.lines is None:
            return t
        return dataclasses.replace(t, lines=pu.with_friction(t.lines, values[FIELDS[2]]))

    @staticmethod
    def key(values: dict, state: str, sequence: list[tuple[int, float]]) -> tuple:
        return tuple(sorted(values.items())), state, tuple(sequence)

    def pushed(self, values: dict, state: str, sequence: list[tuple[int, float]]) -> list["Pushed"]:
        """The pushes of one state, (disk, mm) in the order pushed (:func:`push_state`)."""
        key = self.key(values, state, sequence)
        if key not in self.pushes:
            self.pushes[key] = push_state(self.tensioned(values, state), sequence, self.plan.experiment)
        return self.pushes[key]


def replay(r: Robot, state: sf.State, design: protocol.Tensioned, gravity, memo: dict) -> protocol.Tensioned:
    """A state of robot ``r`` tensioned to the tensions the protocol set on the design's robot
    (``design``), in the protocol's order and poses: a tendon's own pretension_n locked with the
    robot held straight first; the actuating channel locked at its tension with the robot straight
    on edge; each further channel pulled at its tension in the experiment's orientation, the
    earlier ones locked, and locked where it is. ``memo``: shared by the states of ``r``."""
    desc, model = r.desc, r.model
    springs = {t.name: t.stiffness for t in desc.robot.tendons}
    given = {n: design.set_n[n] for n, src in design.source.items() if src == "pretension_n"}
    locks, eq, q = st.locked_at(model, given), None, None
    for k, c in enumerate(state.channels):
        key = ("replay", state.channels[: k + 1])
        if key in memo:
            locks, eq = memo[key]
            q = eq.q
            continue
        names = [n for n in design.locks if desc.channel_of[n] == c and n not in given]
        if c == desc.rules.actuating:
            locks = {**locks, **st.locked_at(model, {n: design.set_n[n] for n in names})}
            eq = st.solve(model, st.Loads(tendons=locks, gravity=gravity), q)
        elif names:
            pulled = {**locks, **{n: ("tension", design.set_n[n]) for n in names}}
            eq = st.solve(model, st.Loads(tendons=pulled, gravity=gravity), q)
            locks = {**locks, **{n: ("locked", eq.lengths[n] - design.set_n[n] / springs[n]) for n in names}}
        q = eq.q if eq is not None else q
        memo[key] = (locks, eq)
    final = st.solve(model, st.Loads(tendons=locks, gravity=gravity), q)
    return protocol.Tensioned(locks, final, dict(design.set_n), dict(design.source),
                              ["tensioned as protocol.md says, to the tensions the protocol set on the design's robot"])


# ------------------------------------------------------------------ the pushes of one state

@dataclass(frozen=True)
class Pushed:
    """One disk's pushes: β by eq. (4), the largest force and the tendons that went slack."""

    beta: float
    peak_n: float
    slackened: tuple[str, ...]


def strip_curve(t: Prepared, disk: int, most_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The push on a robot with no locked tendon (elastic: the same out and back), through the full
    statics: the push point's displacement along the push (mm) and the force (N) at
    :data:`STRIP_STEPS` forces or more, up to one that moves it ``most_mm``. A robot sagging under its
    own weight alone is far from straight, and a push of tens of millimetres from there is not
    linear (the prototype's N: 16 % stiffer at 20 mm than its tangent says)."""
    key = (disk, most_mm)
    if key not in t.curves:
        eq = t.done.equilibrium
        s = t.stations[disk - 1]
        z0 = eq.at(s)[2]
        step = most_mm / float(t.compliance[disk - 2]) / STRIP_STEPS
        u, f, q = [0.0], [0.0], eq.q
        while u[-1] < most_mm and len(u) <= 4 * STRIP_STEPS:
            F = f[-1] + step
            e = st.solve(eq.model, st.Loads(tendons=eq.loads.tendons, gravity=eq.loads.gravity,
                                            forces=((s, (0.0, 0.0, t.toward * F)),)), q)
            u.append(t.toward * (e.at(s)[2] - z0))
            f.append(F)
            q = e.q
        t.curves[key] = (np.array(u), np.array(f))
    return t.curves[key]


def _strip_alone(t: Prepared, disk: int, stroke: float, x) -> list[pu.Stroke]:
    """A push on a robot with no locked tendon (:func:`strip_curve`): the same out and back."""
    u, f = strip_curve(t, disk, x.max_push_mm)
    xs = np.r_[u[u < stroke], stroke]
    fs = np.interp(xs, u, f)
    return [pu.Stroke(xs, fs, xs[::-1], fs[::-1], ())] * x.repetitions


def _repetitions(t: Prepared, disk: int, stroke: float, x, rest: pu.Rest | None
                 ) -> tuple[list[pu.Stroke], pu.Rest | None]:
    if t.lines is None:
        return _strip_alone(t, disk, stroke, x), None
    return pu.repeat(t.lines, disk - 2, stroke, x.repetitions, rest or pu.at_rest(t.lines))


def push_one(t: Prepared, disk: int, stroke: float, x, rest: pu.Rest | None) -> tuple[Pushed, pu.Rest | None]:
    """The repetitions at one disk of a tensioned state from ``rest``: eq. (4)'s β, and where they
    leave the robot."""
    strokes, rest = _repetitions(t, disk, stroke, x, rest)
    X, F, R = pu.sampled(strokes, x.displacement_rate_mm_s / x.sample_rate_hz, x.fit_window_samples)
    return Pushed(pu.eq4(X, F, R), float(max(s.out_f.max() for s in strokes)),
                  tuple(sorted({n for s in strokes for n in s.slackened}))), rest


def push_state(t: Prepared, sequence: list[tuple[int, float]], x) -> list[Pushed]:
    """The pushes of a tensioned state at each (disk, mm) of ``sequence`` in turn, each from where the
    last left the robot: eq. (4)'s β of each."""
    rest, out = None, []
    for disk, stroke in sequence:
        p, rest = push_one(t, disk, stroke, x, rest)
        out.append(p)
    return out


def _reach(t: Prepared, disk: int, target: float, x, rest: pu.Rest | None) -> float:
    if t.lines is None:
        u, f = strip_curve(t, disk, x.max_push_mm)
        return float(min(x.max_push_mm, np.interp(target, f, u)))
    return pu.force_reached(t.lines, disk - 2, target, x.max_push_mm, rest)


def sized(bench: Bench, sets: dict, state: str, disks: list[int]) -> list[tuple[int, float]]:
    """The pushes of one state, disk by disk as the bench goes: each as long as keeps the largest
    force of any repetition on any robot of ``sets`` within ``load_fraction`` of the load cell's range
    (each robot from where its last pushes left it), at most ``max_push_mm``. The pushes are kept
    in the bench for :meth:`Bench.pushed`."""
    x = bench.plan.experiment
    target = x.load_fraction * x.load_cell_range_n
    ts = {name: bench.tensioned(v, state) for name, v in sets.items()}
    rests = {name: None for name in sets}
    seq, done = [], {name: [] for name in sets}
    for d in disks:
        stroke = min(_reach(t, d, target, x, rests[name]) for name, t in ts.items())
        for _ in range(SIZING):
            trial = {name: push_one(t, d, stroke, x, rests[name]) for name, t in ts.items()}
            peak = max(p.peak_n for p, _ in trial.values())
            if peak <= target * (1 + FORCE_TOL):
                break
            stroke *= target / peak                       # a later repetition pushed harder than the first
        seq.append((d, stroke))
        for name, (p, rest) in trial.items():
            done[name].append(p)
            rests[name] = rest
    for name, v in sets.items():
        bench.pushes[bench.key(v, state, seq)] = done[name]
    return seq


# ------------------------------------------------------------------ the experiment

def _pair(plan) -> tuple[str, str] | None:
    """(all channels, the actuating channel): the states the endpoint ratio is of."""
    names = [s.name for s in sf.states(plan)]
    act = plan.tensioner.actuating_channel
    full = names[-1]
    return (full, act) if act in names and full != act else None


def _sequences(plan, order: list[str], strokes: dict) -> dict[str, list[tuple[int, float]]]:
    """Per state, the (disk, mm) pushed in order: the disks ``strokes`` names for it."""
    return {s: sorted((d, mm) for (t, d), mm in strokes.items() if t == s) for s in order}


def predict(plan, strokes: dict | None = None, which: list[str] | None = None, measured: dict | None = None,
            steps: bool = False, bench: "Bench | None" = None) -> dict:
    """The experiment of a plan: every row (state, disk) with β nominal and its band, the push per
    disk, the endpoint ratio with its band (:func:`endpoint_ratio`); ``strokes``: {(state, disk): mm}
    to push instead of the disks and pushes the experiment sizes (a lab's own pushes); ``which``:
    the states (default all); ``measured``: the weights as :func:`hwgen.model.stiffness.describe`
    takes them; ``steps``: with what to set on the bench (:func:`settings_steps`); ``bench``: one
    already at work on this plan (its robots reused)."""
    bench = bench or Bench(plan, measured)
    sets = ends(plan)
    order = [s.name for s in sf.states(plan) if not which or s.name in which]
    if strokes is None:
        seq = {s: sized(bench, sets, s, disks_pushed(plan)) for s in order}
        strokes = {(s, d): mm for s in order for d, mm in seq[s]}
    else:
        seq = _sequences(plan, order, strokes)
    pushed = {name: {s: bench.pushed(v, s, seq[s]) for s in order} for name, v in sets.items()}
    stations = bench.robot(sets["nominal"], []).desc.stations
    rows = []
    for s in order:
        for i, (d, mm) in enumerate(seq[s]):
            b = {name: pushed[name][s][i] for name in sets}
            betas = [v.beta for v in b.values()]
            rows.append({"state": s, "disk": d, "s_mm": float(stations[d - 1]), "push_mm": mm,
                         "beta_n_per_mm": b["nominal"].beta, "beta_low_n_per_mm": min(betas),
                         "beta_high_n_per_mm": max(betas), "peak_force_n": b["nominal"].peak_n,
                         "peak_force_high_n": max(v.peak_n for v in b.values()),
                         "slackened": list(b["nominal"].slackened)})
    out = {"rows": rows, "sets": sets, "strokes": strokes}
    if steps:
        out["states"] = settings_steps(plan, bench, order)      # before the corners take the robots' places
    pair = _pair(plan)
    out["endpoint_ratio"] = endpoint_ratio(plan, bench, seq) if pair and set(pair) <= set(order) and \
        seq[pair[0]] and seq[pair[1]] and seq[pair[0]][-1][0] == seq[pair[1]][-1][0] else None
    return out


def recording(plan, values: dict, strokes: dict, which: list[str], measured: dict | None = None
              ) -> list[tuple[str, int, int, np.ndarray, np.ndarray]]:
    """What the bench would record of the robot of ``values`` pushed as ``strokes`` ({(state, disk):
    mm}, each state's disks in order): (state, disk, repetition, displacement, force) per
    repetition, a sample per the arm's speed over the sample rate, out and back."""
    x = plan.experiment
    bench = Bench(plan, measured)
    seq = _sequences(plan, which, strokes)
    out = []
    for s in which:
        t, rest = bench.tensioned(values, s), None
        for d, mm in seq[s]:
            reps, rest = _repetitions(t, d, mm, x, rest)
            out += [(s, d, k, xs, fs) for k, (xs, fs) in
                    enumerate(pu.recorded(reps, x.displacement_rate_mm_s / x.sample_rate_hz), start=1)]
    return out


def predict_nominal(plan, values: dict, strokes: dict, which: list[str], bench: "Bench | None" = None) -> dict:
    """{(state, disk): β} of the robot of ``values`` for the pushes ``strokes`` (no band)."""
    bench = bench or Bench(plan)
    seq = _sequences(plan, which, strokes)
    return {(s, d): p.beta for s in which for (d, _), p in zip(seq[s], bench.pushed(values, s, seq[s]))}


def endpoint_ratio(plan, bench: Bench, seq: dict) -> dict | None:
    """All tendons over the actuating pair at the last disk pushed: nominal, and its band over every
    corner of the ranges (each corner's robot tensioned and pushed in turn, as the bench goes),
    with the paper's 4.85× placed against it."""
    pair = _pair(plan)

    def ratio(values):
        b = [bench.pushed(values, s, seq[s])[-1].beta for s in pair]
        return b[0] / b[1]

    value = ratio(nominal(plan))
    ratios = [value] + [ratio(v) for v in corners(plan)]
    lo, hi = min(ratios), max(ratios)
    return {"state": pair[0], "over": pair[1], "disk": seq[pair[0]][-1][0], "nominal": value, "low": lo,
            "high": hi, "width": hi / lo, "corners": len(ratios) - 1, "paper": PAPER_ENDPOINT_RATIO,
            "paper_inside": lo <= PAPER_ENDPOINT_RATIO <= hi}


# ------------------------------------------------------------------ what to set on the bench

def settings_steps(plan, bench: Bench, order: list[str]) -> list[dict]:
    """Per state, in order: each channel as the protocol tensions it, the roll to set it at, each
    tendon's tension to set and what it reads once the state is locked, and the line its worm
    takes in after the line is just taut (the path's change and the stretch T/k, the stretch over
    the band's springs) in mm and in worm turns."""
    x = plan.experiment
    sets = ends(plan)
    robots = {name: bench.robot(v, order) for name, v in sets.items()}
    nom = robots["nominal"]
    lay = plan.tensioner_layout
    per_turn = None if lay is None else 2 * math.pi * lay.winding_radius / lay.pair.ratio      # mm of line a worm turn
    springs = {name: {t.name: t.stiffness for t in r.desc.robot.tendons} for name, r in robots.items()}
    gravity = sf.ORIENTATIONS[x.orientation]
    out = []
    for name, t in nom.states.items():
        done = t.done
        channels = []
        for c in t.state.channels:
            tendons = [n for n in done.locks if nom.desc.channel_of[n] == c]
            before = _before(nom, t, c, gravity)
            items = []
            for n in tendons:
                T = done.set_n.get(n)
                k = springs["nominal"][n]
                path = before[n] - (done.locks[n][1] + (T or 0.0) / k)
                take = {e: path + (T or 0.0) / springs[e][n] for e in springs}
                items.append({"tendon": n, "set_n": T, "from": done.source[n], "locked_n": done.equilibrium.tensions[n],
                              "take_in_mm": take["nominal"], "take_in_low_mm": min(take.values()),
                              "take_in_high_mm": max(take.values()),
                              "worm_turns": None if per_turn is None else take["nominal"] / per_turn,
                              "worm_turns_low": None if per_turn is None else min(take.values()) / per_turn,
                              "worm_turns_high": None if per_turn is None else max(take.values()) / per_turn})
            on_edge = c == plan.tensioner.actuating_channel
            channels.append({"channel": c, "roll_deg": ON_EDGE_DEG if on_edge else ROLL_DEG.get(x.orientation),
                             "on_edge": on_edge, "tendons": items})
        out.append({"state": name, "channels": channels, "notes": list(done.notes),
                    "push_roll_deg": ROLL_DEG.get(x.orientation)})
    return out


def _before(r: Robot, t: Prepared, channel: str, gravity) -> dict[str, float]:
    """Each tendon's path length just before ``channel`` is pulled: the actuating pair with the
    robot straight (it is locked on edge), a further channel with the channels before it locked, in
    the experiment's orientation."""
    chans = t.state.channels
    if channel == chans[0] and channel == r.desc.channels[0]:
        return st.straight_lengths(r.model)
    earlier = set(chans[: chans.index(channel)])
    locks = {n: v for n, v in t.done.locks.items() if r.desc.channel_of[n] in earlier}
    return st.solve(r.model, st.Loads(tendons=locks, gravity=gravity), t.done.equilibrium.q).lengths


# ------------------------------------------------------------------ the report

MODEL = ("the statics of hwgen stiffness (a discrete elastic rod, rigid disks, tendons as eq. (2) chords, locked by "
         "the paper's protocol) linearised about each tensioned state (the strip alone: the full statics), every "
         "locked tendon cut at its eyelets: the "
         "arm's push followed out and back from event to event, each eyelet holding or slipping by the capstan "
         "e^(μθ) of its turn, tendons slackening and tautening again (hwgen.model.push); the samples fitted by "
         "eq. (4) over the paper's window")
ASSUMPTIONS = (
    "the robot lies as experiment.orientation says and is tensioned by the paper's protocol (hwgen stiffness's "
    "tensions) before its pushes, and not again between them: each push starts where the last left it",
    "the arm pushes the disk's centre along the strip's flexible direction, quasi-statically (no sway); the load "
    "cell only pushes and reads zero once the block leaves the disk",
    "a state with locked tendons is pushed linearly about its tensioned shape: within 4 % of the full statics' "
    "force at a 20 mm push of the prototype's softest such state (A), under 1 % for the others "
    "(tests/test_experiment.py); the strip alone (N), sagging far from straight under its own weight, is pushed "
    "through the full statics",
    "eyelets are Coulomb contacts with one μ, by the angle the line turns in each (the turn toward the drum at "
    "the tip included); the knot at the base does not slip; the line has no bending stiffness",
    "the band is the robot with every ranged value at its softening end and at its stiffening end; the endpoint "
    "ratio's over every corner of the ranges",
)


def experiment(plan, measured: dict | None = None) -> dict:
    """The experiment's prediction as experiment.json holds it (see the module's docstring);
    ``measured``: the weights as :func:`hwgen.model.stiffness.describe` takes them."""
    res = predict(plan, measured=measured, steps=True)
    x = plan.experiment
    step = x.displacement_rate_mm_s / x.sample_rate_hz
    base = nominal(plan)
    unknown = [] if plan.tendon_material.eyelet_friction is not None else [
        "the design gives no tendon_material.eyelet_friction: its robot's eyelets are frictionless (a range in "
        "experiment.ranges.eyelet_friction still spans the band)"]
    return {
        "model": MODEL,
        "assumptions": [*ASSUMPTIONS, *unknown],
        "settings": {**dataclasses.asdict(x), "ranges": None, "sample_step_mm": step,
                     "window_mm": x.fit_window_samples * step, "disks": disks_pushed(plan)},
        "ranges": [{"field": f, "nominal": base[f], "low": lo, "high": hi} for f, lo, hi in x.ranges],
        "sets": res["sets"],
        "rows": res["rows"],
        "endpoint_ratio": res["endpoint_ratio"],
        "states": res["states"],
        "worm": None if plan.tensioner_layout is None else
        {"ratio": plan.tensioner_layout.pair.ratio, "winding_radius_mm": plan.tensioner_layout.winding_radius},
    }
