"""Stiffness as the paper measured it: the tensioning protocol (hwgen.model.protocol) and eyelet
friction as bounds (hwgen.model.friction) against closed forms — a stuck two-segment tendon's
stiffness from the beam equations, a capstan slip load, the tension that holds a tip weight's
moment straight (T·d = M) — then the prototype's states in every orientation, and the build."""
import json
import math

import numpy as np
import pytest
from scipy.linalg import cho_factor

from hwgen.model import friction as fr
from hwgen.model import protocol as pr
from hwgen.model import statics as st

L = 270.0
SECTION = st.Section(E=50e3, G=4e3, height=60.0, thickness=0.59)
EI = SECTION.ei_flex
UP = (0.0, 0.0, 1.0)


def _line(name, stations, z, compliances=()):
    s = np.asarray(stations, float)
    pts = np.column_stack([np.zeros_like(s), np.full_like(s, z)])
    k = 1.0 / float(np.sum(compliances))
    return st.TendonLine(name, "P", tuple(s), pts, k, tuple(compliances))


# ------------------------------------------------------------------ closed forms

def _beam_tip_stiffness(d: float, Kt: np.ndarray, s1: float) -> float:
    """Tip stiffness of a clamped Euler-Bernoulli strip with a pair of tendons at ±d through eyelets
    at 0, s1 and L, whose segments' springs couple the rotations (θ(s1), θ(L)) by Kt: the tendons
    put moments M = −2d² Kt θ at s1 and L."""
    C = np.array([[s1, s1], [s1, L]]) / EI                       # θ_i per unit moment at s_a: min(s_i, s_a)/EI
    b = np.array([L * s1 - s1 ** 2 / 2, L ** 2 / 2]) / EI          # θ_i per unit tip force
    theta = np.linalg.solve(np.eye(2) + 2 * d * d * C @ Kt, b)
    M = -2 * d * d * Kt @ theta
    w = L ** 3 / (3 * EI) + sum(m * a * (L - a / 2) / EI for m, a in zip(M, (s1, L)))
    return 1.0 / w


def test_a_stuck_two_segment_tendon_stiffens_as_the_beam_equations_say():
    """A pair at ±d through eyelets at 0, L/2, L, barely tensioned: frictionless, each tendon one
    spring k₁k₂/(k₁+k₂) on θ(L); stuck, each segment its own spring on the rotation across it."""
    d, ea = 10.0, 510.0
    k1 = k2 = ea / (L / 2)
    comp = (1 / k1, 1 / k2, 0.0)
    model = st.Model(st.Robot(L, SECTION, tendons=(_line("P", (0, L / 2, L), d, comp),
                                                   _line("M", (0, L / 2, L), -d, comp))))
    eq = st.solve(model, st.Loads(tendons=st.locked_at(model, {"P": 1e-4, "M": 1e-4})))
    b = fr.bounds(eq)
    j = model.point_jacobian(eq.q, L, UP)
    ks = k1 * k2 / (k1 + k2)
    none = _beam_tip_stiffness(d, np.array([[0.0, 0.0], [0.0, ks]]), L / 2)
    stuck = _beam_tip_stiffness(d, np.array([[k1 + k2, -k2], [-k2, k2]]), L / 2)
    assert 1.0 / b.compliance(j, "none")[0] == pytest.approx(none, rel=1e-3)
    assert 1.0 / b.compliance(j, "stuck")[0] == pytest.approx(stuck, rel=1e-3)
    assert stuck > 1.3 * none > 1.3 * 3 * EI / L ** 3             # the bounds are apart, and both stiffen
    beta = 2 * ks * L * d * d / EI                                 # and frictionless is the locked pair's closed form
    assert none * L ** 3 / (3 * EI) == pytest.approx(4 * (1 + beta) / (4 + beta), rel=1e-3)


def _one_eyelet(K0, ka, kb, tau, turn):
    """A block on a spring K0 (its one coordinate u, pushed along +u) carrying an eyelet a line runs
    through from one wall to the other: u lengthens the line's first segment and shortens the
    second, each carrying tau."""
    H = np.array([[K0 + ka + kb]])
    return fr.Bounds(None, ("T",), np.array([[1.0], [-1.0]]), np.array([ka, kb]), np.array([tau, tau]),
                     ("T", "T"), np.array([[0, 1]]), np.array([turn]),
                     {"stuck": cho_factor(H), "none": cho_factor(np.array([[K0]]))})


def test_a_capstan_slips_when_the_tension_ratio_reaches_e_mu_theta():
    """Stuck, the segments' tensions part as τ + ka·u and τ − kb·u; the eyelet slips once the
    first is e^(μθ) times the second, at u* = τ(r−1)/(ka + r·kb); from there the line slides and
    only the block's spring is left."""
    K0, ka, kb, tau, mu, turn, push = 2.0, 30.0, 10.0, 5.0, 0.2, 0.8, 20.0
    r = math.exp(mu * turn)
    u_slip = tau * (r - 1) / (ka + r * kb)
    f_slip = (K0 + ka + kb) * u_slip
    p = fr.capstan_push(_one_eyelet(K0, ka, kb, tau, turn), np.array([1.0]), push, mu)
    assert p.first_slip_n == pytest.approx(f_slip, rel=1e-9)
    assert p.stiffness == pytest.approx(push / (u_slip + (push - f_slip) / K0), rel=1e-9)
    assert p.slipped == 1 and p.reached_n == push and not p.slack
    held = fr.capstan_push(_one_eyelet(K0, ka, kb, tau, turn), np.array([1.0]), 0.5 * f_slip, mu)
    assert held.slipped == 0 and held.stiffness == pytest.approx(K0 + ka + kb)       # under the slip load: stuck
    free = fr.capstan_push(_one_eyelet(K0, ka, kb, tau, turn), np.array([1.0]), push, 0.0)
    assert free.first_slip_n == 0.0 and free.stiffness == pytest.approx(K0)       # no friction: the line slides


def test_the_slipping_eyelets_kept_system_answers_as_a_fresh_solve():
    """A push through a long robot slips its hundreds of eyelets one phase at a time; the system of
    those slipping (issue 45: five channels over twenty disks spent minutes re-solving it from
    scratch each phase) is kept with its inverse as eyelets join and leave, and answers as
    np.linalg.solve does on the same system, over a random run of joins, leaves and side changes."""
    rng = np.random.default_rng(45)
    e = 60                                  # eyelet i between segments i and i + 1, as along a tendon
    lo_seg, hi_seg = np.arange(e), np.arange(1, e + 1)
    MD = 0.3 * rng.normal(size=(e + 1, e))  # a slip lengthens its segment above, shortens the one below
    MD[hi_seg, np.arange(e)] += 5.0
    MD[lo_seg, np.arange(e)] -= 5.0
    ratio = np.exp(0.15 * rng.uniform(0, 1, e))
    m = e + 1
    Kp = rng.normal(size=m)
    kept = fr._Slipping(MD, ratio, lo_seg, hi_seg)
    high = np.zeros(e, int)
    for step in range(150):
        k = int(rng.integers(e))
        high[k] = 0 if high[k] and rng.random() < 0.3 else (1 if rng.random() < 0.5 else -1)
        S, x = kept.solve(high, Kp)
        want = np.flatnonzero(high)
        assert sorted(S.tolist()) == want.tolist()
        if not len(want):
            continue
        hi = np.where(high[want] > 0, hi_seg[want], lo_seg[want])
        lo = np.where(high[want] > 0, lo_seg[want], hi_seg[want])
        A = MD[hi][:, want] - ratio[want, None] * MD[lo][:, want]
        fresh = np.linalg.solve(A, ratio[want] * Kp[lo] - Kp[hi])
        got = dict(zip(S.tolist(), x))
        assert np.allclose([got[i] for i in want], fresh, rtol=1e-9, atol=1e-12)


def test_the_straight_holding_tension_of_one_offset_tendon_is_the_moment_over_its_offset():
    """The robot hanging from its clamp (gravity along +y) with a tip weight W held off the centre
    line by b: a uniform moment W·b. One straight tendon at offset d holds it straight at T·d = W·b,
    which the protocol finds (the straightness tolerance set tiny)."""
    d, b, mass = 12.0, 20.0, 30.0
    s = np.linspace(0.0, L, 13)
    line = st.TendonLine("C", "C", tuple(s), np.column_stack([np.zeros_like(s), np.full_like(s, d)]), 5.0)
    model = st.Model(st.Robot(L, SECTION, tendons=(line,), tip_mass=mass, tip_offset=(0.0, b)))
    rules = pr.Rules("A", 0.01, 100.0, 1e-5)
    done = pr.tension_state(model, ("C",), (0.0, 1.0, 0.0), {"C": None}, rules, tuple(s))
    W = mass * 1e-3 * model.robot.g
    assert done.set_n["C"] == pytest.approx(W * b / d, rel=1e-3)
    assert np.abs(done.equilibrium.p[:, 2]).max() < 0.01               # straight, to 10 µm over 270 mm
    assert done.source == {"C": "protocol"}
    light = pr.tension_state(model, ("C",), None, {"C": None}, rules, tuple(s))
    assert light.set_n["C"] == pytest.approx(rules.floor_n)             # weightless, nothing to hold: the floor


def test_the_stuck_bound_is_the_frictionless_robot_with_its_tendons_cut_at_every_eyelet():
    """Independent of friction.bounds' algebra: each segment of a tendon made a tendon of its own
    (two eyelets, its own spring), locked at the same tension, is what "stuck" means."""
    s = np.array([0.0, 60.0, 150.0, 200.0, L])
    z = 10 * np.cos(np.pi * s / L)
    comp = np.r_[np.diff(s) / 800.0, 0.0]
    comp[0] += 0.02
    whole = st.TendonLine("T", "T", tuple(s), np.column_stack([np.zeros_like(s), z]), 1 / comp.sum(), tuple(comp))
    pieces = tuple(st.TendonLine(f"T{i}", "T", (s[i], s[i + 1]), np.column_stack([[0.0, 0.0], z[i:i + 2]]),
                                 1 / comp[i], (comp[i], 0.0)) for i in range(len(s) - 1))
    a = st.Model(st.Robot(L, SECTION, tendons=(whole,), tip_mass=20.0, tip_offset=(10.0, 3.0)))
    b = st.Model(st.Robot(L, SECTION, tendons=pieces, tip_mass=20.0, tip_offset=(10.0, 3.0)))
    eq = st.solve(a, st.Loads(tendons=st.locked_at(a, {"T": 3.0}), gravity=(0.0, 0.0, -1.0)))
    lengths = fr.chords(a, eq.q)["T"].lengths
    cut = st.solve(b, st.Loads(tendons={f"T{i}": ("locked", lengths[i] - eq.tensions["T"] * comp[i])
                                        for i in range(len(pieces))}, gravity=(0.0, 0.0, -1.0)), eq.q)
    assert np.abs(cut.q - eq.q).max() < 1e-9                            # the same equilibrium
    bounds = fr.bounds(eq)
    for where in (L, 150.0, 60.0):
        j = a.point_jacobian(eq.q, where, UP)
        assert 1 / bounds.compliance(j, "stuck")[0] == pytest.approx(cut.point_stiffness(where, UP), rel=1e-8)
        assert 1 / bounds.compliance(j, "none")[0] == pytest.approx(eq.point_stiffness(where, UP), rel=1e-12)


def test_the_chords_rows_are_the_derivatives_of_their_lengths():
    s = np.array([0.0, 40.0, 150.0, L])
    line = st.TendonLine("T", "T", tuple(s), np.column_stack([8 * np.sin(s / 50), 10 * np.cos(s / 70)]), 4.0)
    model = st.Model(st.Robot(L, SECTION, tendons=(line,)), 3.0)
    rng = np.random.default_rng(4)
    soft = model.dof_stiff.min() / model.dof_stiff
    q = 0.3 * soft * rng.standard_normal(model.n_dof)
    dirs = soft * rng.standard_normal(model.n_dof)
    h = 1e-6
    up, down = fr.chords(model, q + h * dirs)["T"], fr.chords(model, q - h * dirs)["T"]
    at = fr.chords(model, q)["T"]
    assert np.allclose((up.lengths - down.lengths) / (2 * h), at.rows @ dirs, rtol=1e-6, atol=1e-9)
    assert np.allclose(at.rows.sum(axis=0) @ dirs, (up.lengths.sum() - down.lengths.sum()) / (2 * h), rtol=1e-6)


# ------------------------------------------------------------------ the prototype

@pytest.fixture(scope="module")
def prototype():
    from hwgen import params
    from hwgen.model import stiffness as sf
    from hwgen.model.plan import make_plan
    plan = make_plan(params.read("params/prototype.yaml").design)
    return sf, plan, sf.study(plan)


def _entries(rep, **match):
    return [e for e in rep["states"] if all(e.get(k) == v for k, v in match.items())]


def test_every_state_is_reported_per_orientation_and_friction(prototype):
    sf, plan, rep = prototype
    names = [s.name for s in sf.states(plan)]
    assert list(rep["orientations"]) == ["gravity -z", "gravity +z", "weightless"]
    for o in rep["orientations"]:
        for f in ("none", "stuck"):
            assert [e["state"] for e in _entries(rep, orientation=o, friction=f)] == names
        for push in ("+z", "-z"):                                # the prototype gives eyelet_friction
            assert [e["state"] for e in _entries(rep, orientation=o, friction="capstan", push=push)] == names
    for e in rep["states"]:
        assert {"orientation", "friction", "tensions_n", "tip_stiffness_n_per_mm"} <= set(e)
        assert set(e["tensions_n"]) == set(e["locked"])


def test_no_locked_tendon_is_left_slack_and_stuck_is_never_softer(prototype):
    """The done-when of the issue: every locked tendon taut (at or over the floor, less the
    protocol's tolerance), the frictionless stiffness under the stuck one at every disk, the
    capstan between them at the tip."""
    _, plan, rep = prototype
    floor = plan.check.taut_floor_n
    for e in _entries(rep, friction="none"):
        assert e["locked"] == [] or min(e["tensions_n"].values()) >= floor - pr.FIXUP_TOL, (e["state"], e["orientation"])
        assert all(v == "protocol" for v in e["tension_from"].values())
        stuck = _entries(rep, state=e["state"], orientation=e["orientation"], friction="stuck")[0]
        for a, b in zip(e["disks"], stuck["disks"]):
            assert a["stiffness_n_per_mm"] <= b["stiffness_n_per_mm"] * (1 + 1e-9)
        for c in _entries(rep, state=e["state"], orientation=e["orientation"], friction="capstan"):
            assert e["tip_stiffness_n_per_mm"] * (1 - 1e-9) <= c["tip_stiffness_n_per_mm"] \
                <= stuck["tip_stiffness_n_per_mm"] * (1 + 1e-9)


def test_the_pair_is_taut_on_both_sides_and_c1_holds_the_weight_only_one_way(prototype):
    _, plan, rep = prototype
    floor = plan.check.taut_floor_n
    down = _entries(rep, state="A", orientation="gravity -z", friction="none")[0]
    assert down["tensions_n"]["A2"] == pytest.approx(floor, abs=pr.FIXUP_TOL)      # the lower one at the floor
    assert down["tensions_n"]["A1"] > 10 * floor
    assert down["set_n"]["A1"] == down["set_n"]["A2"] > floor                # one tension, straight, on edge
    light = _entries(rep, state="A", orientation="weightless", friction="none")[0]
    assert light["set_n"]["A1"] == pytest.approx(floor)
    held = _entries(rep, state="AC1", orientation="gravity -z", friction="none")[0]
    flipped = _entries(rep, state="AC1", orientation="gravity +z", friction="none")[0]
    assert held["set_n"]["C1"] > 10 * floor and abs(held["tip_z_mm"]) < 0.2 * abs(down["tip_z_mm"])
    assert flipped["set_n"]["C1"] == pytest.approx(floor)          # turned over, C1 cannot hold the weight up
    assert flipped["slack_at_tip_push_n"]["+z"] < 0.1 * held["slack_at_tip_push_n"]["+z"]


def test_the_paper_ratio_is_placed_against_the_band(prototype):
    _, _, rep = prototype
    r = rep["endpoint_ratio"]
    assert r["states"] == ["AC1C2H", "A"] and r["orientation"] == "gravity -z"
    lo, hi = r["band"]
    assert lo < hi and r["paper_inside"] == (lo <= 4.85 <= hi)
    assert set(r["by_friction"]) == {"none", "stuck", "capstan +z", "capstan -z"}
    s = rep["stiffening"]
    assert s["states"] == ["AC1C2H", "A"] and not s["low"] and s["lines"][0].startswith("Stiffening, AC1C2H over A")


def test_a_given_pretension_wins_and_says_so():
    from hwgen import params
    from hwgen.model import stiffness as sf
    from hwgen.model.plan import make_plan
    d = params.read("params/prototype.yaml").design
    tendons = tuple(t.model_copy(update={"pretension_n": 3.0}) if t.name == "C1" else t for t in d.tendons)
    plan = make_plan(d.model_copy(update={"tendons": tendons}))
    desc = sf.describe(plan)
    model = st.Model(desc.robot, sf.STUDY_H_MAX)
    e = sf.evaluate(desc, model, sf.State("AC1", ("A", "C1")), "weightless")[0]
    assert e["tension_from"] == {"A1": "protocol", "A2": "protocol", "C1": "pretension_n"}
    assert e["set_n"]["C1"] == 3.0
    assert e["locks_mm"]["C1"] == pytest.approx(st.straight_lengths(model)["C1"] - 3.0 / desc.robot.tendon("C1").stiffness)


def test_a_stiffening_tendon_on_the_neutral_plane_is_named_as_the_reason():
    """C1 moved onto the strip's plane (x = 20 mm, z = 0): locking it adds nothing to a push along
    z, and the report says so and why."""
    from hwgen import params
    from hwgen.model import stiffness as sf
    from hwgen.model.plan import make_plan
    d = params.read("params/prototype.yaml").design
    flat = {"function": {"kind": "straight", "x0": 20.0, "z0": 0.0}}
    tendons = tuple(t.model_copy(update={"routing": t.routing.model_validate(flat)}) if t.name == "C1" else t
                    for t in d.tendons if t.name in ("A1", "C1"))
    tens = d.tensioner.model_copy(update={"channels": ("A", "C1")})
    plan = make_plan(d.model_copy(update={"tendons": tendons, "tensioner": tens}))
    rep = sf.study(plan, orientations=["weightless"])
    s = rep["stiffening"]
    assert s["states"] == ["AC1", "A"] and s["low"]
    assert s["by_orientation"][0]["tip"]["none"] < 1.2
    assert any("C1 carries no change of load" in w and "neutral plane" in w for w in s["why"]), s["why"]
    assert "Under 1.2×" in s["lines"][-1]


# ------------------------------------------------------------------ the build

def test_the_build_writes_the_statics_and_states_the_stiffening(built):
    folder = built("prototype")
    rep = json.loads((folder / "report.json").read_text())
    study = json.loads((folder / "stiffness.json").read_text())
    assert rep["stiffening"] == study["stiffening"] and "measured" in study["masses"]["how"]
    for png in ("stiffness.png", "gravity.png"):
        assert (folder / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (folder / "summary.md").read_text()
    assert study["stiffening"]["lines"][0] in summary and "gravity -z" in summary


def test_a_statics_that_cannot_be_computed_is_said_and_the_checks_stand(monkeypatch):
    """The checks' report keeps every check and says why the stiffening is missing (a robot longer
    than the statics resolves, a solver that cannot factor): no traceback, no stiffness plots."""
    from hwgen import pipeline
    from hwgen.checks import report as rp
    from hwgen.checks import run
    monkeypatch.setattr(run, "run_checks", lambda *a: {"checks": [], "ok": True, "gravity": None})

    def fails(*a, **k):
        raise ValueError("2000 joint coordinates, more than the 1500 the statics is run with")

    monkeypatch.setattr(pipeline, "statics", fails)
    report, study = pipeline.checked(None, {}, None)
    assert report["ok"] and "1500" in report["stiffening"]["skipped"] and "skipped" in study
    assert rp.stiffening_lines(report) == ["", report["stiffening"]["skipped"] + "."]
