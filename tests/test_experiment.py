"""The paper's push test (hwgen experiment, hwgen compare): the bench's push against closed forms
(a capstan's loop, a tendon going slack, the friction bounds at their limits) and against the full
statics; eq. (4) and its window; the prototype's experiment; measurements synthesised from the
prototype with another line or other eyelets, and hwgen compare finding them; bad measurements."""
from __future__ import annotations

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.linalg import cho_factor
from scipy.optimize import brentq

from hwgen import params
from hwgen.model import experiment as ex
from hwgen.model import friction as fr
from hwgen.model import push as pu
from hwgen.model import statics as st
from hwgen.model import stiffness as sf

from .conftest import PARAMS

L = 270.0
SECTION = st.Section(E=50e3, G=4e3, height=60.0, thickness=0.59)
UP = (0.0, 0.0, 1.0)


def _run(*args, timeout=600):
    return subprocess.run([sys.executable, "-m", "hwgen.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


# ------------------------------------------------------------------ the push against closed forms

def _block(K0, ka, kb, tau, turn, mu):
    """A block on a spring K0 (its one coordinate u, pushed along +u) carrying an eyelet a line runs
    through from one wall to the other: u lengthens the line's base-side segment and shortens its
    tip-side one, each carrying tau."""
    H = np.array([[K0 + ka + kb]])
    b = fr.Bounds(None, ("T",), np.array([[1.0], [-1.0]]), np.array([ka, kb]), np.array([tau, tau]), ("T", "T"),
                  np.array([[0, 1]]), np.array([turn]), {"stuck": cho_factor(H), "none": cho_factor(np.array([[K0]]))})
    return pu.lines(b, mu, np.array([[1.0]]))


def test_a_push_through_one_eyelet_traces_the_capstans_loop():
    """Out: stuck (K0 + ka + kb) until the lengthened side is e^(μθ) times the other, then only K0
    (the line slides, both tensions held); back: stuck again until the other side is e^(μθ) times
    the first, then K0 again, down to where the block leaves it with the force at zero."""
    K0, ka, kb, tau, turn, mu, U = 2.0, 30.0, 10.0, 5.0, 0.8, 0.2, 1.0
    r = math.exp(mu * turn)
    ln = _block(K0, ka, kb, tau, turn, mu)
    (s,), _ = pu.repeat(ln, 0, U, 1)
    u1 = tau * (r - 1) / (ka + r * kb)                          # out: the base side reaches r times the tip side
    ta, tb = tau + ka * u1, tau - kb * u1
    def out(u):
        return (K0 + ka + kb) * u if u <= u1 else K0 * u + ta - tb
    d = (r * ta - tb) / (kb + r * ka)                            # back: holds until τ_b = r τ_a
    ta2, tb2 = ta - ka * d, tb + kb * d
    assert tb2 == pytest.approx(r * ta2, rel=1e-12)
    def back(u):
        return out(U) - (K0 + ka + kb) * (U - u) if U - u <= d else K0 * u + ta2 - tb2
    for u in np.linspace(0, U, 11):
        assert np.interp(u, s.out_x, s.out_f) == pytest.approx(out(u), abs=1e-9)
    opened = -(ta2 - tb2) / K0                                   # the force reaches zero there
    assert s.back_x[-1] == pytest.approx(opened, abs=1e-9) and s.back_f[-1] == pytest.approx(0.0, abs=1e-9)
    for u in np.linspace(opened, U, 11):
        assert np.interp(u, s.back_x[::-1], s.back_f[::-1]) == pytest.approx(back(u), abs=1e-9)
    assert opened > 0                                            # friction leaves the block short of its start


def _pair(tension_p, tension_m, d=20.0, zigzag=0.0):
    """A strip with a tendon either side (P at +d, M at -d) through 7 eyelets (alternately ``zigzag``
    further out and in, so that the line turns at each), locked at the given tensions in the
    straight, weightless robot (let go, the strip bends until the two share)."""
    s = np.linspace(0, L, 7)
    lines = []
    for name, z in (("P", d), ("M", -d)):
        pts = np.column_stack([np.zeros_like(s), np.sign(z) * (abs(z) + zigzag * (-1.0) ** np.arange(len(s)))])
        comp = tuple(np.r_[np.diff(s) / 500.0, 0.02])
        lines.append(st.TendonLine(name, name, tuple(s), pts, 1.0 / sum(comp), comp))
    model = st.Model(st.Robot(L, SECTION, tendons=tuple(lines)), 3.0)
    eq = st.solve(model, st.Loads(tendons=st.locked_at(model, {"P": tension_p, "M": tension_m})))
    return model, eq


def test_without_friction_the_push_is_the_tangent_until_a_tendon_slackens_and_retraces_itself():
    """μ = 0: the out stroke's slope is the frictionless tangent until M's tension reaches zero
    (where the tangent's tension rate says), then the tangent without M's spring; back, the same
    path (no friction, no loop) to zero force at the start."""
    model, eq = _pair(5.0, 0.3)
    jac = -model.point_jacobian(eq.q, L, UP)                     # toward -z: M's side turns concave
    b = fr.bounds(eq)
    ln = pu.lines(b, 0.0, jac[None, :])
    (s,), _ = pu.repeat(ln, 0, 40.0, 1)
    assert s.slackened == ("M",)
    k0 = 1.0 / b.compliance(jac, "none")[0]
    rates = b.tension_rates(jac, "none")
    m_rate = rates[[o == "M" for o in b.owner]][0]
    slack_at = eq.tensions["M"] / -m_rate / k0
    assert 0 < slack_at < 40.0
    g = fr.chords(model, eq.q, {"M"})["M"].rows.sum(axis=0)
    k_m = model.robot.tendon("M").stiffness
    H = eq.hessian - k_m * np.outer(g, g)
    k1 = 1.0 / (jac @ np.linalg.solve(H, jac))
    assert np.interp(slack_at / 2, s.out_x, s.out_f) == pytest.approx(k0 * slack_at / 2, rel=1e-6)
    f_slack = k0 * slack_at
    assert np.interp(40.0, s.out_x, s.out_f) == pytest.approx(f_slack + k1 * (40.0 - slack_at), rel=1e-6)
    assert k1 < 0.9 * k0
    back = np.interp(s.out_x, s.back_x[::-1], s.back_f[::-1])
    assert np.allclose(back, s.out_f, atol=1e-9)
    assert s.back_x[-1] == pytest.approx(0.0, abs=1e-9)


def test_eyelets_that_hold_give_the_stuck_bound_and_free_ones_the_frictionless():
    """A push too small to slip anything, with friction far beyond any line's (μ = 50), is the
    stuck Hessian's tangent; with μ = 0 it is the frictionless one (tendons that turn at their
    eyelets: a line running straight through an eyelet slips whatever μ is)."""
    model, eq = _pair(5.0, 5.0, zigzag=5.0)
    jac = model.point_jacobian(eq.q, L, UP)
    b = fr.bounds(eq)
    assert b.turns.min() > 0.1
    for mu, friction in ((50.0, "stuck"), (0.0, "none")):
        ln = pu.lines(b, mu, jac[None, :])
        (s,), _ = pu.repeat(ln, 0, 0.05, 1)
        assert s.out_f[-1] / 0.05 == pytest.approx(1.0 / b.compliance(jac, friction)[0], rel=1e-9)
    assert 1.0 / b.compliance(jac, "stuck")[0] > 1.5 / b.compliance(jac, "none")[0]


def test_eq4_fits_one_slope_and_an_intercept_per_repetition():
    rng = np.random.default_rng(3)
    x = np.tile(np.linspace(0, 10, 50), 3)
    rep = np.repeat(np.arange(3), 50)
    f = 0.3 * x + np.array([0.1, -0.4, 0.7])[rep] + rng.normal(0, 1e-4, len(x))
    assert pu.eq4(x, f, rep) == pytest.approx(0.3, rel=1e-3)


def test_the_fit_takes_the_papers_window_either_side_of_each_peak():
    """400 samples either side of the peak at 30 samples a millimetre: a 20 mm push is fitted over
    its last 13.3 mm out and first 13.3 mm back; a 5 mm push whole."""
    for peak, n in ((20.0, 801), (5.0, 301)):
        x = np.linspace(0, peak, 10)
        stroke = pu.Stroke(x, x, x[::-1], x[::-1], ())
        X, F, R = pu.sampled([stroke], 1 / 30, 400)
        assert len(X) == n and X.max() == pytest.approx(peak)
        assert X.min() == pytest.approx(max(0.0, peak - 400 / 30), abs=1e-9)


# ------------------------------------------------------------------ the prototype

@pytest.fixture(scope="module")
def prototype_plan():
    from hwgen.pipeline import design_plan, load
    return design_plan(load(PARAMS / "prototype.yaml"))


@pytest.mark.slow
def test_the_linear_push_stays_near_the_full_statics(prototype_plan):
    """Without friction the bench's push is the statics linearised about the tensioned state: at the
    experiment's longest push (20 mm at the tip, pushed down) its force is within 5 % of the full
    statics' (solved for the force that moves the tip as far), the softest state furthest off."""
    plan = prototype_plan
    values = {**ex.nominal(plan), ex.FIELDS[2]: 0.0}
    bench = ex.Bench(plan)
    gravity = sf.ORIENTATIONS[plan.experiment.orientation]
    tip = len(plan.stations)
    for state in ("A", "AC1C2H"):
        t = bench.tensioned(values, state)
        r = bench.robot(values, [state])
        eq0 = t.done.equilibrium
        (s,), _ = pu.repeat(t.lines, tip - 2, plan.experiment.max_push_mm, 1)
        z0, q = eq0.at(L)[2], [eq0.q]

        def short(F):
            e = st.solve(r.model, st.Loads(tendons=t.done.locks, gravity=gravity, forces=((L, (0, 0, -F)),)), q[0])
            q[0] = e.q
            return z0 - e.at(L)[2] - plan.experiment.max_push_mm

        full = brentq(short, 0.0, 10.0, xtol=1e-6)
        assert s.out_f[-1] == pytest.approx(full, rel=0.05), state


@pytest.fixture(scope="module")
def prototype_experiment(tmp_path_factory):
    out = tmp_path_factory.mktemp("experiment")
    r = _run("experiment", str(PARAMS / "prototype.yaml"), "--out", str(out), "-q", "--no-cache")
    assert r.returncode == 0, r.stderr
    return out / "prototype" / "experiment", r.stdout


@pytest.mark.slow
def test_the_prototypes_experiment_predicts_every_state_and_disk_within_its_band(prototype_experiment):
    folder, stdout = prototype_experiment
    res = json.loads((folder / "experiment.json").read_text())
    x = res["settings"]
    states = [s.name for s in sf.states(_plan())]
    assert [s["state"] for s in res["states"]] == states and len(states) == 9
    rows = list(csv.DictReader(open(folder / "predicted.csv")))
    assert list(rows[0]) == ["state", "disk", "s_mm", "push_mm", "beta_n_per_mm", "beta_low_n_per_mm",
                             "beta_high_n_per_mm"]
    assert [(r["state"], int(r["disk"])) for r in rows] == [(s, d) for s in states for d in range(3, 14)]
    for r in res["rows"]:
        assert r["beta_low_n_per_mm"] <= r["beta_n_per_mm"] <= r["beta_high_n_per_mm"]
        assert 0 < r["push_mm"] <= x["max_push_mm"] + 1e-9
        assert r["peak_force_high_n"] <= x["load_fraction"] * x["load_cell_range_n"] * 1.001
    ep = res["endpoint_ratio"]
    assert (ep["state"], ep["over"], ep["disk"]) == ("AC1C2H", "A", 13)
    assert ep["low"] <= ep["nominal"] <= ep["high"] and ep["high"] / ep["low"] <= 2.5
    assert ep["paper_inside"] == (ep["low"] <= 4.85 <= ep["high"])
    template = list(csv.reader(open(folder / "template.csv")))
    assert template[0] == ["state", "disk", "repetition", "displacement_mm", "force_n"]
    assert len(template) - 1 == 9 * 11 * x["repetitions"]
    protocol = (folder / "protocol.md").read_text()
    assert all(f"### {s}" in protocol for s in states) and "worm" in protocol
    assert (folder / "experiment.png").stat().st_size > 10_000
    assert "endpoint ratio AC1C2H/A at disk 13" in stdout


def _plan():
    from hwgen.pipeline import design_plan, load
    return design_plan(load(PARAMS / "prototype.yaml"))


# ------------------------------------------------------------------ measurements synthesised, and fitted

STATES = ("A", "AC1", "AC1C2H")
NOISE_N = 0.005            # the load cell's noise, N (a 5 N beam with its amplifier reads to a few mN)


def _measure(plan, path, change: dict, seed: int) -> None:
    """A lab's record of the prototype whose ``change`` differs from the design: the three states
    pushed at disks 3-13 as the experiment sizes them, noise on the force and an offset of the arm
    per repetition (eq. (4)'s η)."""
    strokes = {(s, d): min(20.0, 1.2 * (d - 2) ** 1.5) for s in STATES for d in range(3, 14)}
    rng = np.random.default_rng(seed)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["state", "disk", "repetition", "displacement_mm", "force_n"])
        for s, d, k, xs, fs in ex.recording(plan, {**ex.nominal(plan), **change}, strokes, list(STATES)):
            off = rng.normal(0, 2.0)
            for a, b in zip(xs + off, fs + rng.normal(0, NOISE_N, len(fs))):
                w.writerow([s, d, k, f"{a:.4f}", f"{b:.5f}"])


@pytest.mark.slow
@pytest.mark.parametrize("field, value", [("tendon_material.axial_stiffness_n", 1500.0),
                                          ("tendon_material.eyelet_friction", 0.25)])
def test_compare_finds_the_line_and_the_eyelets_a_lab_measured(tmp_path, prototype_plan, field, value):
    """Measurements synthesised from the prototype with another line (EA 1500 N for the design's
    2000) or other eyelets (μ 0.25 for 0.15), with noise: hwgen compare's fit finds that value
    within 20 %, and calibrated.yaml is a design with it."""
    path = tmp_path / "measured.csv"
    _measure(prototype_plan, path, {field: value}, seed=7)
    r = _run("compare", str(PARAMS / "prototype.yaml"), str(path), "--out", str(tmp_path), "-q")
    assert r.returncode == 0, r.stderr
    folder = tmp_path / "prototype" / "experiment"
    res = json.loads((folder / "compare.json").read_text())
    fitted = res["fitted"][field]
    assert fitted["value"] == pytest.approx(value, rel=0.2)
    assert fitted["low"] <= fitted["value"] <= fitted["high"]
    assert len(res["rows"]) == 33 and all(r["within"] for r in res["rows"])
    design = params.read(folder / "calibrated.yaml").design
    section, key = field.split(".")
    assert getattr(getattr(design, section), key) == pytest.approx(fitted["value"], rel=1e-5)
    assert design.design == "prototype-calibrated"
    assert "fitted by hwgen compare" in (folder / "calibrated.yaml").read_text()


# ------------------------------------------------------------------ bad measurements

GOOD = "state,disk,repetition,displacement_mm,force_n\n" + "".join(
    f"A,13,1,{x:.2f},{0.05 * x:.4f}\n" for x in np.linspace(0, 10, 20))


@pytest.mark.parametrize("text, where, what", [
    ("state,disk,repetition,displacement_mm\nA,13,1,1\n", "header", "missing column force_n"),
    ("state,disk,repetition,displacement_mm,force_lbf\nA,13,1,1,0.1\n", "header", "as force_n"),
    (GOOD.replace("A,13,1,5.79", "AC9,13,1,5.79"), "row 13: state", "not a state of this design"),
    (GOOD.replace("A,13,1,5.79", "A,14,1,5.79"), "row 13: disk", "2 to 13"),
    (GOOD.replace("A,13,1,5.79", "A,13,0,5.79"), "row 13: repetition", "count from 1"),
    (GOOD.replace("A,13,1,5.79,0.2895", "A,13,1,5.79,289.5"), "row 13: force_n", "newtons?"),
    (GOOD.replace("A,13,1,5.79", "A,13,1,5.7x9"), "row 13: displacement_mm", "not a number"),
    (GOOD.replace("A,13,1,5.79,0.2895", "A,13,1,,0.2895"), "row 13: displacement_mm", "not a number"),
    ("state,disk,repetition,displacement_mm,force_n\n" + "".join(
        f"A,13,1,{x:.5f},{x:.4f}\n" for x in np.linspace(0, 0.002, 20)), "row 2: displacement_mm", "millimetres?"),
    ("state,disk,repetition,displacement_mm,force_n\nA,13,1,1,0.1\nA,13,1,2,0.2\n", "row 2: displacement_mm",
     "2 samples"),
    ("state,disk,repetition,displacement_mm,force_n\nA,13,1,,\n", "<document>", "no samples"),
])
def test_a_bad_measurement_is_refused_naming_the_row(prototype_plan, text, where, what):
    from hwgen.errors import InputError
    from hwgen.model import calibration as cal
    with pytest.raises(InputError) as e:
        cal.read_measured("measured.csv", text.encode(), prototype_plan)
    assert e.value.path == where and what in e.value.message, str(e.value)


def test_hwgen_compare_refuses_a_bad_measurement_in_one_line_and_writes_nothing(tmp_path):
    path = tmp_path / "measured.csv"
    path.write_text(GOOD.replace("A,13,1,5.79", "AC9,13,1,5.79"))
    r = _run("compare", str(PARAMS / "prototype.yaml"), str(path), "--out", str(tmp_path / "out"), "-q")
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == (f"error: {path}: row 13: state: 'AC9' is not a state of this design (its states: "
                                "N, A, AC2, AH, AC2H, AC1, AC1C2, AC1H, AC1C2H)")
    assert not (tmp_path / "out").exists()


def test_experiment_settings_that_describe_no_experiment_are_refused(tmp_path, prototype_plan):
    import dataclasses

    from hwgen.errors import DesignError, InputError
    path = tmp_path / "design.yaml"
    path.write_text((PARAMS / "prototype.yaml").read_text().replace("    axial_stiffness_n: [1500, 2500]",
                                                                    "    axial_stiffness_n: [2500, 1500]"))
    with pytest.raises(InputError) as e:
        params.read(path)
    assert e.value.path == "experiment.ranges.axial_stiffness_n" and "low end 2500" in e.value.message
    past = dataclasses.replace(prototype_plan, experiment=dataclasses.replace(prototype_plan.experiment, first_disk=14))
    with pytest.raises(DesignError) as e:
        ex.disks_pushed(past)
    assert e.value.path == "experiment.first_disk"
