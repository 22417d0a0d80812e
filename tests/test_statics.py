"""The statics in newtons (hwgen.model.statics) against closed forms and independent computations:
the cantilever's 3EI/L³, the large-deflection elastica from elliptic integrals, a routed tendon's
constant curvature τd/EI and its shortening d·θ, the stiffening of a locked pair 4(1+β)/(4+β),
a tendon crossing the strip at mid-length; then the prototype's states (hwgen.model.stiffness),
built from the plan (numpy only, no CAD)."""
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from hwgen.model import statics as st

L = 270.0
SECTION = st.Section(E=50e3, G=4e3, height=60.0, thickness=0.59)
EI = SECTION.ei_flex
UP = (0.0, 0.0, 1.0)


def strip(tendons=(), **kw) -> st.Model:
    return st.Model(st.Robot(L, SECTION, tendons=tuple(tendons), **kw))


def routed(name, zs, k=1.0, n_disks=28):
    """A tendon through n_disks equally spaced disks with z = zs(s) (x = 0)."""
    s = np.linspace(0.0, L, n_disks)
    pts = np.column_stack([np.zeros_like(s), zs(s)])
    return st.TendonLine(name, name, tuple(s), pts, k)


def elastica_tip_load(P):
    """Cantilever under a dead tip force P (Bisshopp & Drucker 1945): tip drop, tip reach, tip angle.
    With α the tip angle, p² = (1 + sin α)/2, sin φ₀ = 1/(p√2): L√(P/EI) = K(p) − F(φ₀, p),
    drop = L − 2√(EI/P)(E(p) − E(φ₀, p)), reach = √(2 EI sin α / P)."""
    lam = L * math.sqrt(P / EI)

    def parts(a):
        m = (1 + math.sin(a)) / 2
        return m, math.asin(min(1.0, 1 / math.sqrt(2 * m)))

    a = brentq(lambda a: ellipk(parts(a)[0]) - ellipkinc(parts(a)[1], parts(a)[0]) - lam, 1e-9, math.pi / 2 - 1e-12,
               xtol=1e-15)
    m, phi = parts(a)
    drop = L - 2 * math.sqrt(EI / P) * (ellipe(m) - ellipeinc(phi, m))
    return drop, math.sqrt(2 * EI * math.sin(a) / P), a


# ------------------------------------------------------------------ the bare strip

def test_tip_stiffness_is_3EI_over_L3():
    eq = st.solve(strip(), st.Loads())
    k = eq.point_stiffness(L, UP)
    assert k == pytest.approx(3 * EI / L ** 3, rel=0.01)
    # the same from a finite push: the Hessian's answer is the small-push limit
    f = 1e-4
    pushed = st.solve(eq.model, st.Loads(forces=((L, (0.0, 0.0, f)),)))
    assert f / pushed.at(L)[2] == pytest.approx(k, rel=1e-3)


@pytest.mark.parametrize("load_factor", [1.0, 3.0, 8.0])
def test_large_deflection_tip_load_matches_the_elastica(load_factor):
    P = load_factor * EI / L ** 2
    eq = st.solve(strip(), st.Loads(forces=((L, (0.0, 0.0, -P)),)))
    drop, reach, angle = elastica_tip_load(P)
    tip = eq.at(L)
    assert -tip[2] == pytest.approx(drop, rel=0.01)
    assert tip[1] == pytest.approx(reach, rel=0.01)
    assert -eq.tip_angle() == pytest.approx(angle, rel=0.01)
    assert angle > math.radians(25)            # large deflection indeed


def test_stiff_direction_and_torsion_follow_the_section():
    eq = st.solve(strip(), st.Loads())
    assert eq.point_stiffness(L, (1.0, 0.0, 0.0)) == pytest.approx(3 * SECTION.ei_stiff / L ** 3, rel=0.01)
    assert eq.twist_stiffness() == pytest.approx(SECTION.gj / L, rel=0.01)


def test_a_rigid_span_shortens_the_bending_length():
    """Holding [100, 150] straight: the tip compliance is the bare one less ∫ over the span of (L−s)²/EI."""
    from hwgen.model.sag import Span
    held = st.Stiffening(flex=(Span(100.0, 150.0, math.inf),), torsion=(Span(100.0, 150.0, math.inf),),
                         stiff=(Span(100.0, 150.0, math.inf),))
    eq = st.solve(strip(stiffening=held), st.Loads())
    c = (L ** 3 - ((L - 100) ** 3 - (L - 150) ** 3)) / (3 * EI)
    assert eq.point_stiffness(L, UP) == pytest.approx(1 / c, rel=0.01)


# ------------------------------------------------------------------ tendons

def test_one_straight_tendon_bends_to_constant_curvature():
    d, tau = 10.0, 2.0
    model = strip([routed("T", lambda s: np.full_like(s, d))])
    straight = st.straight_lengths(model)["T"]
    eq = st.solve(model, st.Loads(tendons={"T": ("tension", tau)}))
    kappa = tau * d / EI
    # the tangent turns at the same rate everywhere: angle(s) = κ s
    n = len(eq.s)
    for k in (n // 4, n // 2, 3 * n // 4, n - 1):
        t = eq.frames[k][:, 1]
        assert math.atan2(t[2], t[1]) == pytest.approx(kappa * eq.s[k], rel=0.01)
    theta = eq.tip_angle()
    assert straight - eq.lengths["T"] == pytest.approx(d * theta, rel=0.01)


def test_a_locked_pair_stiffens_by_4_1_plus_beta_over_4_plus_beta():
    d, EA = 10.0, 510.0
    beta = 2 * EA * d ** 2 / EI                       # ≈ 2; each tendon a spring of EA/L
    k = EA / L
    model = strip([routed("P", lambda s: np.full_like(s, d), k), routed("M", lambda s: np.full_like(s, -d), k)])
    eq = st.solve(model, st.Loads(tendons=st.locked_at(model, {"P": 2.0, "M": 2.0})))
    ratio = eq.point_stiffness(L, UP) / (3 * EI / L ** 3)
    assert ratio == pytest.approx(4 * (1 + beta) / (4 + beta), rel=0.02)
    assert ratio > 1.5                                # the pair does stiffen


def test_a_tendon_crossing_at_mid_length_keeps_its_length_and_tension():
    d, tau, k = 10.0, 3.0, 5.0
    act = routed("A", lambda s: np.full_like(s, 30.0))
    cross = routed("X", lambda s: d * (1 - 2 * s / L), k)
    model = strip([act, cross])
    lock = st.locked_at(model, {"X": 2.0})
    free = st.solve(model, st.Loads(tendons={"A": ("tension", tau)}))
    rest = st.solve(model, st.Loads(tendons=lock))          # locked, the actuator idle (X's own S-bend)
    held = st.solve(model, st.Loads(tendons={"A": ("tension", tau), **lock}))
    theta = free.tip_angle()
    assert theta > math.radians(20)
    straight = st.straight_lengths(model)["X"]
    # a straight tendon at offset d would change by d·θ; the crossing one by a small part of it
    assert abs(free.lengths["X"] - straight) < 0.02 * d * theta
    assert abs(held.tensions["X"] - rest.tensions["X"]) < 0.02 * k * d * theta
    assert held.tip_angle() - rest.tip_angle() == pytest.approx(theta, rel=0.02)   # no coupling through the holes


def test_a_routed_tendon_does_not_buckle_the_strip_where_an_end_load_would():
    """3 × the Euler load π²EI/4L² pulled through the disks on the centre line leaves the strip
    straight and stiff; the same force as a dead end load leaves it unstable (FIELD-NOTES)."""
    P = 3 * math.pi ** 2 * EI / (4 * L ** 2)
    routed_ = st.solve(strip([routed("T", np.zeros_like)]), st.Loads(tendons={"T": ("tension", P)}))
    assert routed_.point_stiffness(L, UP) > 0.9 * 3 * EI / L ** 3
    dead = st.solve(strip(), st.Loads(forces=((L, (0.0, -P, 0.0)),)))
    assert dead.point_stiffness(L, UP) == 0.0                  # H not positive definite: it buckles


def test_a_locked_tendon_never_pushes():
    model = strip([routed("T", lambda s: np.full_like(s, 10.0), 5.0)])
    # locked 1 mm longer than the straight path: slack, so the strip is as bare
    lock = {"T": ("locked", st.straight_lengths(model)["T"] + 1.0)}
    eq = st.solve(model, st.Loads(tendons=lock))
    assert eq.tensions["T"] == 0.0
    assert eq.point_stiffness(L, UP) == pytest.approx(3 * EI / L ** 3, rel=0.01)


# ------------------------------------------------------------------ the derivatives against differences

def _shipped_model(name):
    from hwgen import params
    from hwgen.model import stiffness as sf
    from hwgen.model.bending import SWEEP_H_MAX
    from hwgen.model.plan import make_plan
    desc = sf.describe(make_plan(params.read(f"params/{name}.yaml").design))
    return st.Model(desc.robot, SWEEP_H_MAX)


def _lengths(model, q):
    P, R, _, _, _ = model.forward(q[None])
    return {k: float(v[0]) for k, v in model._point_forces(P, R, st.Loads())[3].items()}


def _load_cases(model, q):
    """Every tendon mode (locked ones 0.4 mm into stretch or short of it at q), alone and together
    with the weights (tip mass included) and forces."""
    names = [t.name for t in model.robot.tendons]
    length = _lengths(model, q)
    L_ = model.robot.length
    forces = ((L_, (0.4, -0.3, 0.6)), (float(model.nodes_s[len(model.nodes_s) // 3]), (-1.0, 0.2, 0.1)))
    return {
        "slack": st.Loads(),
        "tension": st.Loads(tendons={n: ("tension", 2.0 + i) for i, n in enumerate(names)}),
        "locked, stretched": st.Loads(tendons={n: ("locked", length[n] - 0.4) for n in names}),
        "locked, not stretched": st.Loads(tendons={n: ("locked", length[n] + 0.4) for n in names}),
        "gravity": st.Loads(gravity=(0.2, -0.3, -0.93)),
        "forces": st.Loads(forces=forces),
        "all": st.Loads(tendons={names[0]: ("tension", 4.0), names[1]: ("locked", length[names[1]] - 0.3),
                                 names[2]: ("locked", length[names[2]] + 0.3)},
                        gravity=(0.0, 0.0, -1.0), forces=forces),
    }


def _configurations(model):
    """The straight robot and two random bends: each joint turned by about what a bend of
    ``scale`` rad per most flexible joint asks of it (its stiffness against the most flexible's)."""
    rng = np.random.default_rng(18)
    soft = model.dof_stiff.min() / model.dof_stiff
    return {"straight": np.zeros(model.n_dof), "slightly bent": 1e-3 * soft * rng.standard_normal(model.n_dof),
            "bent": 0.3 * soft * rng.standard_normal(model.n_dof)}


@pytest.mark.parametrize("design", ["prototype", "paper-table2"])
def test_the_exact_hessian_is_the_central_difference_of_the_gradient(design):
    """Both shipped designs, every tendon mode, the weights with the tip assembly's, point forces,
    straight and bent: the exact Hessian against the central difference it replaced (relative error
    ~1e-9), measured on the part the loads add to the joints' stiffness (the diagonal K is exact in
    both and would hide an error a thousand times over)."""
    model = _shipped_model(design)
    assert model.robot.tip_mass > 0 and model.n_dof > 200
    K = np.diag(model.dof_stiff)
    for cname, q in _configurations(model).items():
        for lname, loads in _load_cases(model, q).items():
            exact = model.hessian(q, loads)
            ref = model.difference_hessian(q, loads)
            scale = np.abs(ref - K).max()
            P, R, _, _, _ = model.forward(q[None])
            tensions = model._point_forces(P, R, loads)[4]
            if lname in ("slack", "locked, not stretched"):                   # no tendon pulls: K alone
                assert all(v[0] == 0.0 for v in tensions.values())
                assert np.abs(exact - K).max() == 0.0 and scale < 1e-5, (cname, lname)
                continue
            if lname == "locked, stretched":
                assert all(v[0] > 0.0 for v in tensions.values())
            assert scale > 10.0, (cname, lname)                       # the loads' part is there to be wrong
            err = np.abs(exact - ref).max()
            assert err < 1e-7 * scale, (cname, lname, err, scale)            # measured: ≤ 5e-9
            assert np.array_equal(exact, exact.T)


def test_the_exact_hessian_holds_for_joints_of_one_two_and_three_axes_and_tendons_on_any_stations():
    """What the shipped designs do not have: spans rigid about some axes only (joints with one or
    two coordinates), tendons through different stations (three sets of eyelets), one that starts
    after the base and ends before the tip."""
    from hwgen.model.sag import Span
    held = st.Stiffening(flex=(Span(100.0, 150.0, math.inf), Span(200.0, 210.0, 3 * EI)),
                         torsion=(Span(30.0, 60.0, math.inf),), stiff=(Span(100.0, 120.0, math.inf),))
    s = np.array([20.0, 95.0, 180.0, 260.0])
    mid = st.TendonLine("C", "C", tuple(s), np.column_stack([10 * np.sin(s / 30), np.full_like(s, -5.0)]), 2.0)
    tendons = (routed("A", lambda s: np.full_like(s, 12.0), 4.0, n_disks=9),
               routed("B", lambda s: 8 * np.cos(s / 40.0), 3.0, n_disks=13), mid)
    model = st.Model(st.Robot(L, SECTION, held, tendons, ((50.0, 3.0), (180.0, 5.0)), 40.0, (20.0, -3.0)), 3.0)
    axes = np.bincount(np.bincount(model.dof_joint))
    assert axes[1] > 0 and axes[2] > 0 and axes[3] > 0 and len(model._chord_groups) == 3
    K = np.diag(model.dof_stiff)
    for q in (np.zeros(model.n_dof), 0.3 * model.dof_stiff.min() / model.dof_stiff
              * np.random.default_rng(1).standard_normal(model.n_dof)):
        length = _lengths(model, q)
        loads = st.Loads(tendons={"A": ("tension", 3.0), "B": ("locked", length["B"] - 0.5),
                                  "C": ("locked", length["C"] - 0.2)},
                         gravity=(0.1, 0.2, -0.97), forces=((L, (0.1, 0.2, 0.3)),))
        ref = model.difference_hessian(q, loads)
        scale = np.abs(ref - K).max()
        assert scale > 10.0 and np.abs(model.hessian(q, loads) - ref).max() < 1e-7 * scale


def test_the_gradient_is_the_central_difference_of_the_energy():
    model = _shipped_model("prototype")
    q = _configurations(model)["bent"]
    loads = _load_cases(model, q)["all"]
    h = 1e-7
    dirs = np.random.default_rng(3).standard_normal((4, model.n_dof)) * model.dof_stiff.min() / model.dof_stiff
    V, g = model.energy_and_gradient(np.concatenate([q[None] + h * dirs, q[None] - h * dirs, q[None]]), loads)
    numeric = (V[:4] - V[4:8]) / (2 * h)
    assert np.allclose(dirs @ g[-1], numeric, rtol=1e-6, atol=1e-6 * np.abs(numeric).max())


def test_the_right_jacobians_derivative_is_its_difference_both_sides_of_the_series():
    rng = np.random.default_rng(5)
    axes = rng.standard_normal((7, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    th = axes * np.array([0.0, 1e-9, 1e-4, 0.99 * st.SERIES_ANGLE, 1.01 * st.SERIES_ANGLE, 1.0, 3.0])[:, None]
    exact = st._jr_derivative(th)
    h = 1e-6
    for b in range(3):
        e = np.zeros(3)
        e[b] = h
        ref = (st._exp_and_jr(th + e)[1] - st._exp_and_jr(th - e)[1]) / (2 * h)
        assert np.abs(exact[:, b] - ref).max() < 1e-8, b


def test_the_kinematics_scan_is_the_chain_walked_segment_by_segment():
    """The prefix scan against the plain walk along the rod: a half segment along the frame
    before each joint, the joint, a half segment along the frame after."""
    model = _shipped_model("prototype")
    q = _configurations(model)["bent"]
    P, R, O, W, th = (x[0] for x in model.forward(q[None]))
    E, Jr = st._exp_and_jr(th)
    p, r = np.zeros(3), np.eye(3)
    for m, ln in enumerate(model.seg_len):
        j = model.joint_of_seg[m]
        if j < 0:
            p = p + ln * r[:, 1]
        else:
            p = p + 0.5 * ln * r[:, 1]
            r = r @ E[j]
            assert np.allclose(O[j], p, rtol=0, atol=1e-10) and np.allclose(W[j], r @ Jr[j], rtol=0, atol=1e-13)
            p = p + 0.5 * ln * r[:, 1]
        assert np.allclose(P[m + 1], p, rtol=0, atol=1e-10) and np.allclose(R[m + 1], r, rtol=0, atol=1e-13)


# ------------------------------------------------------------------ the prototype, from its plan

COARSE_MM = 3.0          # segments of the prototype's strip in these tests: the relations, not the figures


@pytest.fixture(scope="module")
def prototype():
    from hwgen import params
    from hwgen.model import stiffness as sf
    from hwgen.model.plan import make_plan
    design = params.read("params/prototype.yaml").design
    desc = sf.describe(make_plan(design))
    model = st.Model(desc.robot, COARSE_MM)
    return sf, design, desc, model


def _result(prototype, channels, friction="none"):
    """The state tensioned by the paper's protocol, flexible direction along gravity (−z)."""
    sf, design, desc, model = prototype
    name = "".join(channels) or "N"
    return next(e for e in sf.evaluate(desc, model, sf.State(name, tuple(channels)), "gravity -z")
                if e["friction"] == friction)


def _state(prototype, channels, friction="none"):
    return np.array([d["stiffness_n_per_mm"] for d in _result(prototype, channels, friction)["disks"]])


def test_state_N_sags_as_the_own_weight_model_shoots_it(prototype):
    """The same loads (disks, strip, tip assembly off its tip) and hubs through hwgen.model.sag's
    shooting elastica, an independent solver: the same tip."""
    from hwgen.model import sag
    _, _, desc, model = prototype
    r = desc.robot
    eq = st.solve(model, st.Loads(gravity=(0.0, 0.0, -1.0)))
    sec = r.section
    shot = sag.solve_sag(r.length, [s for s, _ in r.point_masses], [m for _, m in r.point_masses],
                         sag.Strip(sec.E, sec.ei_flex / sec.E, sec.thickness, sec.lin_density),
                         tip=sag.Tip(r.tip_mass, r.tip_offset), spans=r.stiffening.flex)
    tip = eq.at(r.length)
    assert shot.tip_sag > 100                          # a large deflection
    assert tip[1] == pytest.approx(shot.tip_y, rel=1e-3) and tip[2] == pytest.approx(shot.tip_z, rel=1e-3)
    assert math.degrees(eq.tip_angle()) == pytest.approx(shot.tip_angle_deg, rel=1e-3)


def test_measured_weights_replace_the_plans_estimate(prototype):
    sf, design, desc, _ = prototype
    from hwgen.model.gravity import Gravity, PointWeight, StripWeight, TipWeight
    from hwgen.model.plan import make_plan
    # the weights the statics reads; the section's strip figures (modulus, section, spans) are the sim's
    gravity = Gravity(model="", E_mpa=0.0, height_mm=0.0, thickness_mm=0.0, length_mm=0.0, spans=(), cases={},
                      disks=(PointWeight(part="disk_06", s_mm=134.0, mass_g=10.0),),
                      tip=TipWeight(mass_g=100.0, a_mm=60.0, z_mm=-2.0), document={},
                      strip=StripWeight(part="backbone", mass_g=0.0, y_mm=(0.0, 0.0), lambda_g_mm=0.05))
    measured = sf.describe(make_plan(design), gravity)
    r = measured.robot
    assert r.point_masses == ((134.0, 10.0),) and r.tip_mass == 100.0 and r.tip_offset == (60.0, -2.0)
    assert r.section.lin_density == 0.05 and "measured" in measured.masses["how"]
    assert "estimated" in desc.masses["how"] and desc.robot.tip_mass != 100.0


def test_the_nine_states_are_the_papers_and_follow_the_channels(prototype):
    sf, design, _, _ = prototype
    from hwgen.model.plan import make_plan
    assert [s.name for s in sf.states(make_plan(design))] == ["N", "A", "AC2", "AH", "AC2H", "AC1", "AC1C2", "AC1H",
                                                              "AC1C2H"]
    tendons = tuple(t.model_copy(update={"channel": "P"}) if t.channel == "A" else t for t in design.tendons)
    renamed = design.model_copy(update={"tendons": tendons, "tensioner": design.tensioner.model_copy(
        update={"channels": ("P", "Q", "C1", "C2", "H"), "actuating_channel": "P"})})
    names = [s.name for s in sf.states(make_plan(renamed))]
    assert names[:3] == ["N", "P", "PC2"]               # no tendon on Q: no state with it
    assert all("Q" not in n for n in names) and len(names) == 9


@pytest.mark.parametrize("friction", ["none", "stuck"])
def test_every_stiffening_state_is_stiffer_than_A_at_every_disk(prototype, friction):
    a = _state(prototype, ("A",), friction)
    full = _state(prototype, ("A", "C1", "C2", "H"), friction)
    assert np.all(full > a)


@pytest.mark.parametrize("removed", ["C1", "C2"])
def test_removing_a_bending_stiffener_never_raises_tip_stiffness(prototype, removed):
    full = _state(prototype, ("A", "C1", "C2", "H"))
    fewer = _state(prototype, tuple(c for c in ("A", "C1", "C2", "H") if c != removed))
    assert fewer[-1] <= full[-1] * (1 + 1e-6)


def test_the_helix_stiffens_torsion_and_leaves_bending_at_the_tip_as_it_was(prototype):
    """What H is for is torsion; in bending at the tip it changes the frictionless stiffness by
    well under a percent (its tension can soften the strip as much as its path holds it: the
    paper saw such falls at disks 3 and 5, Sect. V)."""
    full = _result(prototype, ("A", "C1", "C2", "H"))
    fewer = _result(prototype, ("A", "C1", "C2"))
    assert fewer["tip_stiffness_n_per_mm"] == pytest.approx(full["tip_stiffness_n_per_mm"], rel=0.01)
    assert full["tip_torsion_nmm_per_rad"] > 3 * fewer["tip_torsion_nmm_per_rad"]


def test_the_hub_section_is_a_closed_tube_until_a_window_cuts_it(prototype):
    sf, _, desc, _ = prototype
    from hwgen.model.plan import make_plan
    p = make_plan(prototype[1])
    uncut = next(d for d in p.disks if d.hub is not None and not d.hub.windows)
    cut = next(d for d in p.disks if d.hub is not None and d.hub.windows)
    wall = prototype[1].disks.hub.wall
    Ix, Iz, J, area = sf._hub_section(uncut, wall)
    w, h = uncut.slot_width, uncut.slot_height
    # the uncut hub: outer rectangle less the slot
    assert Ix == pytest.approx(((w + 2 * wall) * (h + 2 * wall) ** 3 - w * h ** 3) / 12, rel=1e-9)
    assert area == pytest.approx((w + 2 * wall) * (h + 2 * wall) - w * h, rel=1e-9)
    am = (w + wall) * (h + wall)                      # Bredt's closed thin-walled tube
    assert J == pytest.approx(4 * am ** 2 * wall / (2 * (w + wall) + 2 * (h + wall)), rel=1e-9)
    assert sf._hub_section(cut, wall)[2] < J / 5      # an open section twists far more easily


# ------------------------------------------------------------------ the verdict in newtons (checks)

@pytest.fixture(scope="module")
def swept():
    from hwgen import params
    from hwgen.checks.tension import sweeps
    from hwgen.model.plan import make_plan
    design = params.read("params/prototype.yaml").design
    p = make_plan(design)
    return design, p, sweeps(p)


def test_the_prototype_keeps_its_stiffening_tendons_taut_without_coupling(swept):
    from hwgen.checks.tension import tension_checks
    design, p, sw = swept
    rep, checks = tension_checks(p, {"tendons": []}, {}, sw)
    by = {(c.id, c.where.get("tendon")): c for c in checks}
    for name in ("C1", "C2", "H"):
        assert by[("tendon.taut", name)].passed and by[("tendon.overload", name)].passed
    coupling = next(c for c in checks if c.id == "actuation.coupling")
    assert coupling.passed and abs(coupling.measured) < design.check.max_coupling
    # the swing is what locking does: each starts at its pre-tension in the straight robot
    for t in rep["tendons"]:
        assert t["least_n"] <= t["pretension_n"] + 1e-6 <= t["greatest_n"] + 2e-6


def test_the_as_built_excess_lowers_the_least_tension_at_the_spring_rate(swept):
    from hwgen.checks.tension import tension_checks
    design, p, sw = swept
    nominal, _ = tension_checks(p, {"tendons": []}, {}, sw)
    built, checks = tension_checks(p, {"tendons": [{"name": "H", "robust_mm": 0.3}, {"name": "C2", "robust_mm": 9.0}]},
                                   {"H": 0.1}, sw)
    h0 = next(t for t in nominal["tendons"] if t["name"] == "H")
    h1 = next(t for t in built["tendons"] if t["name"] == "H")
    assert h1["least_as_built_n"] == pytest.approx(h0["least_n"] - 0.2 * h0["spring_n_per_mm"], rel=1e-9)
    c2 = next(c for c in checks if c.id == "tendon.taut" and c.where["tendon"] == "C2")
    assert not c2.passed and c2.severity == design.check.robust_severity     # slack only as built


def test_a_stiffening_tendon_locked_too_loose_goes_slack_and_fails():
    from hwgen import params
    from hwgen.checks.tension import tension_checks
    from hwgen.model.plan import make_plan
    design = params.read("params/prototype.yaml").design
    tendons = tuple(t.model_copy(update={"pretension_n": 0.6}) if t.name == "C2" else t for t in design.tendons)
    half = design.check.model_copy(update={"max_angle_deg": 45.0})          # it goes slack before 45°
    _, checks = tension_checks(make_plan(design.model_copy(update={"tendons": tendons, "check": half})), {"tendons": []}, {})
    c2 = next(c for c in checks if c.id == "tendon.taut" and c.where["tendon"] == "C2")
    assert not c2.passed and c2.severity == "error" and "SLACK" in c2.message


# ------------------------------------------------------------------ the command

def test_hwgen_stiffness_writes_its_files_and_refuses_an_unknown_state(tmp_path):
    import json

    from .clirunner import hwgen
    from .conftest import PARAMS
    run = ["stiffness", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path), "-q"]
    r = hwgen(*run, "--states", "A,AC1")
    assert r.returncode == 0, r.stderr
    folder = tmp_path / "prototype"
    rep = json.loads((folder / "stiffness.json").read_text())
    assert [s["state"] for s in rep["states"] if s["friction"] == "none"] == ["A", "AC1"] * 3
    assert rep["endpoint_ratio"]["states"] == ["AC1", "A"] and rep["endpoint_ratio"]["ratio"] > 1
    for png in ("stiffness.png", "gravity.png"):
        assert (folder / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    _assert_stiffness_figures(rep)
    assert "AC1/A (gravity -z)" in r.stdout and "weightless" in r.stdout
    bad = hwgen(*run, "--states", "AX")
    assert bad.returncode == 2 and "--states: unknown state 'AX'" in bad.stderr
    assert "prototype.yaml" in bad.stderr and "Traceback" not in bad.stderr


def _assert_stiffness_figures(rep):
    """stiffness.png and gravity.png as drawn: per orientation a panel; a bar per disk and state at
    the report's frictionless stiffness on a log axis and, on it, the band up to the stuck one;
    the states in the legend; a shape per state along the report's curve."""
    import matplotlib.pyplot as plt

    from hwgen.outputs.stiffness import gravity_figure, stiffness_figure
    fig = stiffness_figure(rep)
    try:
        assert len(fig.axes) == len(rep["orientations"])
        for ax, o in zip(fig.axes, rep["orientations"]):
            none = [e for e in rep["states"] if e["orientation"] == o and e["friction"] == "none"]
            stuck = [e for e in rep["states"] if e["orientation"] == o and e["friction"] == "stuck"]
            solid = [b for b in ax.patches if b.get_gid() != "band"]
            band = [b for b in ax.patches if b.get_gid() == "band"]
            assert [b.get_height() for b in solid] == pytest.approx(
                [d["stiffness_n_per_mm"] for s in none for d in s["disks"]])
            assert [b.get_y() + b.get_height() for b in band] == pytest.approx(
                [max(d["stiffness_n_per_mm"], e["stiffness_n_per_mm"]) for s, t in zip(none, stuck)
                 for d, e in zip(s["disks"], t["disks"])])
            assert ax.get_yscale() == "log" and o in ax.get_title()
            assert [tk.get_text() for tk in ax.get_xticklabels()] == [str(d["disk"] + 1) for d in none[0]["disks"]]
        assert [tx.get_text() for tx in fig.axes[0].get_legend().get_texts()] == \
            [e["state"] for e in rep["states"] if e["orientation"] == rep["endpoint_ratio"]["orientation"]
             and e["friction"] == "none"]
    finally:
        plt.close(fig)
    fig = gravity_figure(rep)
    try:
        for ax, o in zip(fig.axes, rep["orientations"]):
            states = [e for e in rep["states"] if e["orientation"] == o and e["friction"] == "none"]
            lines = [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")]
            assert [ln.get_label() for ln in lines] == [f"{s['state']}: tip at z = {s['tip_z_mm']:+.1f} mm"
                                                        for s in states]
            for ln, s in zip(lines, states):
                assert np.allclose(ln.get_xdata(), s["curve"]["y_mm"]) and np.allclose(ln.get_ydata(), s["curve"]["z_mm"])
    finally:
        plt.close(fig)


def test_the_sim_reads_the_tension_sweep_as_the_check_wrote_it(swept):
    """The sim sets its driven pair beside report.json's tension sweep, read back as
    :class:`hwgen.checks.studies.TensionStudy`: each side names the tendon it hauls in, the worst
    side's rise is what actuation.coupling measured, and the sim's comparison takes the locked
    tendons' change and the rise from the side that hauls in the tendon it drove."""
    from hwgen.checks.studies import TensionStudy
    from hwgen.checks.tension import tension_checks
    from hwgen.sim.drive import against_sweep
    _, p, sw = swept
    rep, checks = tension_checks(p, {"tendons": []}, {}, sw)
    study = TensionStudy.of(rep)
    assert study.actuation and [s.inner for s in study.actuation] == [s["inner"] for s in rep["actuation"]]
    coupling = next(c for c in checks if c.id == "actuation.coupling")
    assert max(s.rise for s in study.actuation) == coupling.measured
    for s in study.actuation:
        assert study.side_hauling(s.inner) is s
        locked = {t: 0.0 for t in s.tensions_n if t != s.inner}
        got = against_sweep({"tendon": s.inner, "locked_tension_change_n": locked}, study)
        assert got["side"] == s.side and got["coupling_rise"] == s.rise and got["without_n"] == s.without_n
        assert got["tension_change_n"] == {t: v[-1] - v[0] for t, v in s.tensions_n.items() if t in locked}
    assert against_sweep({"tendon": "no such tendon", "locked_tension_change_n": {}}, study) == {}
    assert TensionStudy.of({"skipped": "no tensioner"}).actuation == ()
