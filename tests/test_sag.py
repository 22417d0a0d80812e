"""The own-weight (state N) model against closed forms, the elastica, statics and an independent
solver. Written with the model as a standalone prototype; the loads here are the prototype's
(Table I stations, 11 cm³ inner and 13 cm³ end disks of 1.15 g/cm³ resin, 1.40 g/cm³ strip)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from hwgen.model import sag

L = 270.0
EI = 5.0e4          # N mm^2
G = 9.81
KG = 1e-3 * G       # N per g
WIDTH, T = 60.0, 0.59
I_STRIP = sag.second_moment(WIDTH, T)
E_LAMINATE = 50.0e3                      # MPa
STRIP_LAMBDA = 1.40e-3 * WIDTH * T       # g/mm
STATIONS = 22.5 * np.arange(13)
DISKS = np.r_[14.95, np.full(11, 12.65), 14.95]   # g


def solve(L, stations, masses, *, EI=None, strip_lin_density=STRIP_LAMBDA, tip_mass=0.0, tip_offset=(0.0, 0.0),
          **kw):
    E = E_LAMINATE if EI is None else EI / I_STRIP
    return sag.solve_sag(L, stations, masses, sag.Strip(E, I_STRIP, T, strip_lin_density),
                         tip=sag.Tip(tip_mass, tip_offset), **kw)


def tip_mass_for_force(P):
    return P / KG


# ------------------------------------------------------------------ reference solutions

def elastica_tip_load(alpha):
    """Cantilever elastica under a dead tip force, alpha = P L^2 / EI (Bisshopp & Drucker 1945).

    With theta0 the tip angle, k^2 = (1 + sin theta0)/2, sin phi1 = 1/(k sqrt 2):
        sqrt(alpha) = K(k) - F(phi1, k)
        delta_v / L = 1 - 2 (E(k) - E(phi1, k)) / sqrt(alpha)
        x_tip / L   = sqrt(2 sin theta0 / alpha)
    evaluated with scipy.special to ~1e-13.  Returns (delta_v/L, x_tip/L, theta0).
    """
    def parts(theta0):
        m = (1 + math.sin(theta0)) / 2
        phi1 = math.asin(min(1.0, 1 / math.sqrt(2 * m)))
        return m, phi1

    def resid(theta0):
        m, phi1 = parts(theta0)
        return ellipk(m) - ellipkinc(phi1, m) - math.sqrt(alpha)

    theta0 = brentq(resid, 1e-12, math.pi / 2 - 1e-12, xtol=1e-15)
    m, phi1 = parts(theta0)
    dv = 1 - 2 * (ellipe(m) - ellipeinc(phi1, m)) / math.sqrt(alpha)
    xt = math.sqrt(2 * math.sin(theta0) / alpha)
    return dv, xt, theta0


# Bisshopp & Drucker's values (as tabulated by Bathe & Bolourchi 1979): alpha -> (w/L, u/L)
BISSHOPP_DRUCKER = {1.0: (0.30172, -0.05643), 2.0: (0.49346, -0.16064)}


# ------------------------------------------------------------------ small-deflection limits

def test_small_tip_point_mass_matches_PL3_3EI():
    P = 0.01 * EI / L**2                       # alpha = 0.01: deep in the linear range
    r = solve(L, [L], [tip_mass_for_force(P)], EI=EI, strip_lin_density=0.0)
    ref = P * L**3 / (3 * EI)
    assert r.tip_sag == pytest.approx(ref, rel=1e-2)
    assert r.tip_sag == pytest.approx(ref, rel=1e-3)   # actually much better than 1 %
    assert r.linear.tip_sag == pytest.approx(ref, rel=1e-12)
    assert -r.tip_angle == pytest.approx(P * L**2 / (2 * EI), rel=1e-3)


def test_same_via_tip_assembly_without_offset():
    P = 0.01 * EI / L**2
    r1 = solve(L, [L], [tip_mass_for_force(P)], EI=EI, strip_lin_density=0.0)
    r2 = solve(L, [], [], EI=EI, strip_lin_density=0.0, tip_mass=tip_mass_for_force(P))
    assert r2.tip_sag == pytest.approx(r1.tip_sag, rel=1e-12)


def test_small_uniform_load_matches_wL4_8EI():
    w = 0.01 * EI / L**3                       # wL^3/EI = 0.01
    lam = w / KG                               # g/mm
    r = solve(L, [], [], EI=EI, strip_lin_density=lam)
    ref = w * L**4 / (8 * EI)
    assert r.tip_sag == pytest.approx(ref, rel=1e-2)
    assert r.tip_sag == pytest.approx(ref, rel=2e-3)
    assert r.linear.tip_sag == pytest.approx(ref, rel=1e-12)
    assert -r.tip_angle == pytest.approx(w * L**3 / (6 * EI), rel=2e-3)
    assert abs(r.base_moment) == pytest.approx(w * L**2 / 2, rel=1e-3)
    assert r.base_moment == pytest.approx(sag.base_moment_from_statics(r), rel=1e-9)


def test_small_midspan_point_mass():
    P, a = 0.01 * EI / L**2, 100.0
    r = solve(L, [a], [tip_mass_for_force(P)], EI=EI, strip_lin_density=0.0)
    ref = P * a**2 * (3 * L - a) / (6 * EI)
    assert r.tip_sag == pytest.approx(ref, rel=1e-3)
    assert r.linear.tip_sag == pytest.approx(ref, rel=1e-12)


# ------------------------------------------------------------------ large deflection

@pytest.mark.parametrize("alpha", sorted(BISSHOPP_DRUCKER))
def test_large_tip_load_vs_bisshopp_drucker_table(alpha):
    P = alpha * EI / L**2
    r = solve(L, [], [], EI=EI, strip_lin_density=0.0, tip_mass=tip_mass_for_force(P))
    wl, ul = BISSHOPP_DRUCKER[alpha]
    assert r.tip_sag / L == pytest.approx(wl, abs=1e-5)          # table has 5 decimals
    assert (r.tip_y - L) / L == pytest.approx(ul, abs=1e-5)


@pytest.mark.parametrize("alpha", [0.25, 1.0, 2.0, 5.0, 10.0, 50.0])
def test_large_tip_load_vs_elliptic_solution(alpha):
    P = alpha * EI / L**2
    r = solve(L, [], [], EI=EI, strip_lin_density=0.0, tip_mass=tip_mass_for_force(P))
    dv, xt, th0 = elastica_tip_load(alpha)
    assert r.tip_sag / L == pytest.approx(dv, rel=1e-7)
    assert r.tip_y / L == pytest.approx(xt, rel=1e-7)
    assert -r.tip_angle == pytest.approx(th0, rel=1e-7)
    # the linear estimate is far off here (alpha/3), which is why the elastica is needed
    assert r.linear.tip_sag / L == pytest.approx(alpha / 3, rel=1e-12)


def test_elliptic_reference_itself_matches_table():
    for alpha, (wl, ul) in BISSHOPP_DRUCKER.items():
        dv, xt, _ = elastica_tip_load(alpha)
        assert dv == pytest.approx(wl, abs=1e-5)
        assert xt - 1 == pytest.approx(ul, abs=1e-5)


# ------------------------------------------------------------------ monotonicity and statics

def proto(**kw):
    return solve(L, STATIONS, DISKS, **kw)


def test_disks_increase_sag():
    bare = solve(L, [], [])
    with_disks = proto()
    heavier = solve(L, STATIONS, 1.3 * DISKS)
    assert bare.tip_sag > 0
    assert with_disks.tip_sag > 3 * bare.tip_sag
    assert heavier.tip_sag > with_disks.tip_sag
    assert abs(heavier.base_moment) > abs(with_disks.base_moment) > abs(bare.base_moment)


def test_tip_offset_increases_sag_and_base_moment():
    r0 = proto(tip_mass=115.0, tip_offset=(0.0, 0.0))
    r1 = proto(tip_mass=115.0, tip_offset=(40.0, 0.0))
    r2 = proto(tip_mass=115.0, tip_offset=(80.0, 0.0))
    assert r0.tip_sag < r1.tip_sag < r2.tip_sag
    assert abs(r0.base_moment) < abs(r1.base_moment) < abs(r2.base_moment)
    assert abs(r0.tip_angle) < abs(r1.tip_angle) < abs(r2.tip_angle)
    # tip moment = weight x deformed horizontal lever arm of the CoM
    for r in (r1, r2):
        tip_M = r.moment[-1]
        arm = r.tip_com[0] - r.tip_y
        assert tip_M == pytest.approx(-r.loads.tip.mass * KG * arm, rel=1e-12)


@pytest.mark.parametrize("tip", [(0.0, (0, 0)), (260.0, (60.0, 0.0)), (115.0, (40.0, 0.0)),
                                 (200.0, (50.0, 25.0)), (200.0, (50.0, -25.0))])
def test_base_moment_equals_statics_of_deformed_shape(tip):
    m, off = tip
    r = proto(tip_mass=m, tip_offset=off)
    Ms = sag.base_moment_from_statics(r)
    assert r.base_moment == pytest.approx(Ms, rel=1e-7)
    # deformed lever arms are shorter than undeformed ones
    assert abs(r.base_moment) < abs(r.linear.base_moment)


def test_moment_jumps_in_slope_at_stations_and_force_balance():
    r = proto(tip_mass=260.0, tip_offset=(60.0, 0.0))
    total = (r.loads.strip.lin_density * L + r.loads.point_masses[r.loads.stations > 0].sum() + r.loads.tip.mass) * KG
    assert r.weight_beyond[0] == pytest.approx(total, rel=1e-12)
    # dM/ds = W cos psi holds on each side of a station (shear jump = disk weight)
    j = 6
    sj = r.loads.stations[j]
    k = int(np.argmin(np.abs(r.s - sj)))
    assert r.s[k] == pytest.approx(sj, abs=1e-9)          # every station is a mesh node
    h = r.s[k + 1] - r.s[k]
    M = r.moment
    left = (3 * M[k] - 4 * M[k - 1] + M[k - 2]) / (2 * h)   # 2nd-order one-sided slopes
    right = (-3 * M[k] + 4 * M[k + 1] - M[k + 2]) / (2 * h)
    c = math.cos(r.psi[k])
    W_left = r.weight_beyond[k - 1]
    W_right = r.weight_beyond[k + 1]
    w = r.loads.strip.lin_density * KG
    assert W_left - W_right == pytest.approx(r.loads.point_masses[j] * KG + 2 * h * w, rel=1e-9)
    W_left, W_right = W_left - h * w, W_right + h * w     # W just either side of s_j
    assert left == pytest.approx(W_left * c, rel=1e-3)
    assert right == pytest.approx(W_right * c, rel=1e-3)
    assert left - right == pytest.approx(r.loads.point_masses[j] * KG * c, rel=2e-2)


def test_stress_formula_and_location():
    r = proto(tip_mass=260.0, tip_offset=(60.0, 0.0))
    I = 60 * 0.59**3 / 12
    assert r.loads.strip.I == pytest.approx(I)
    assert r.base_stress == pytest.approx(abs(r.base_moment) * 0.295 / I, rel=1e-12)
    assert r.max_stress >= r.base_stress
    assert r.s_max_stress == pytest.approx(0.0, abs=1e-9)


def test_zero_load_is_straight():
    r = solve(L, [0.0], [0.0], strip_lin_density=0.0)
    assert r.tip_sag == 0.0 and r.tip_angle == 0.0 and r.tip_y == pytest.approx(L)


def test_base_disk_mass_does_not_matter():
    a = solve(L, [0.0, L], [0.0, 10.0])
    b = solve(L, [0.0, L], [50.0, 10.0])
    assert a.tip_sag == pytest.approx(b.tip_sag, rel=1e-14)


def test_inputs_validated():
    with pytest.raises(ValueError):
        solve(L, [300.0], [1.0])
    with pytest.raises(ValueError):
        solve(L, [10.0, 20.0], [1.0])


# ------------------------------------------------------------------ accuracy, independence, speed

@pytest.mark.parametrize("tip", [(0.0, (0, 0)), (260.0, (60.0, 0.0))])
def test_step_convergence(tip):
    m, off = tip
    coarse = proto(tip_mass=m, tip_offset=off, h_max=2.0)
    fine = proto(tip_mass=m, tip_offset=off, h_max=0.5)
    finest = proto(tip_mass=m, tip_offset=off, h_max=0.125)
    assert fine.tip_sag == pytest.approx(finest.tip_sag, rel=1e-9)
    assert fine.base_moment == pytest.approx(finest.base_moment, rel=1e-9)
    assert coarse.tip_sag == pytest.approx(finest.tip_sag, rel=1e-6)


def test_independent_solve_bvp_agrees():
    """scipy's collocation solver (solve_bvp) on the same equations (psi, M, y, z), no
    shooting.  The load jumps are handled as a multipoint problem: each of the 12
    inter-disk segments is mapped onto tau in [0, 1] and the states are stacked, with
    continuity conditions at the stations."""
    r = proto(tip_mass=260.0, tip_offset=(60.0, 0.0))
    w = r.loads.strip.lin_density * KG
    st, P = r.loads.stations, r.loads.point_masses * KG
    Pc, (a, b) = r.loads.tip.mass * KG, r.loads.tip.offset
    edges = np.unique(np.concatenate([[0.0, L], st[(st > 0) & (st < L)]]))
    lo, dl = edges[:-1], np.diff(edges)
    nseg = len(dl)
    C = np.array([Pc + P[st >= hi - 1e-9].sum() for hi in edges[1:]])

    def f(tau, U):
        out = np.empty_like(U)
        for k in range(nseg):
            psi, M = U[4 * k], U[4 * k + 1]
            s = lo[k] + tau * dl[k]
            Wk = C[k] + w * (L - s)
            out[4 * k] = dl[k] * M / r.loads.EI
            out[4 * k + 1] = dl[k] * Wk * np.cos(psi)
            out[4 * k + 2] = dl[k] * np.cos(psi)
            out[4 * k + 3] = dl[k] * np.sin(psi)
        return out

    def bc(Ua, Ub):
        res = [Ua[0], Ua[2], Ua[3]]
        for k in range(nseg - 1):
            res += list(Ub[4 * k:4 * k + 4] - Ua[4 * (k + 1):4 * (k + 1) + 4])
        psiL = Ub[4 * (nseg - 1)]
        res.append(Ub[4 * (nseg - 1) + 1] + Pc * (a * np.cos(psiL) - b * np.sin(psiL)))
        return np.array(res)

    tau = np.linspace(0, 1, 11)
    U0 = np.zeros((4 * nseg, tau.size))
    for k in range(nseg):   # crude initial guess: the small-deflection shape, scaled down
        s = lo[k] + tau * dl[k]
        U0[4 * k] = -0.8 * s / L
        U0[4 * k + 1] = np.interp(s, r.s, r.moment) * 0.5
        U0[4 * k + 2] = s
    sol = solve_bvp(f, bc, tau, U0, tol=1e-9, max_nodes=100000)
    assert sol.success, sol.message
    end = sol.sol(1.0)[4 * (nseg - 1):]
    start = sol.sol(0.0)[:4]
    assert -end[3] == pytest.approx(r.tip_sag, rel=1e-6)
    assert end[2] == pytest.approx(r.tip_y, rel=1e-6)
    assert end[0] == pytest.approx(r.tip_angle, rel=1e-6)
    assert start[1] == pytest.approx(r.base_moment, rel=1e-6)


@pytest.mark.parametrize("tip_offset, m_max", [((60.0, 0.0), 260.0), ((0.0, 0.0), 5000.0),
                                               ((0.0, 150.0), 500.0)])
def test_equilibrium_is_on_the_loading_branch(tip_offset, m_max):
    """Ramp the tip assembly up from zero: the tip angle must change continuously and
    monotonically into the solution the solver picks at full load (no jump to another
    equilibrium), also where heavy loads admit several equilibria."""
    ramp = np.concatenate([np.linspace(0, 0.1 * m_max, 26), np.linspace(0.1 * m_max, m_max, 26)[1:]])
    rs = [proto(tip_mass=m, tip_offset=tip_offset) for m in ramp]
    angles = np.array([r.tip_angle for r in rs])
    assert np.all(np.diff(angles) < 0)
    assert np.abs(np.diff(angles)).max() < 0.3
    assert all(r.solver.residual < 1e-10 for r in rs)


def test_heavy_tip_load_hangs_down_although_other_equilibria_exist():
    r = proto(tip_mass=5000.0)
    assert r.solver.n_roots_in_scan >= 2          # looping equilibria exist ...
    assert -90.0 < r.tip_angle_deg < -85.0  # ... but the strip hangs down
    assert r.tip_sag > 0.9 * L


def test_stiff_spans_stiffen_and_carry_the_moment():
    """Spans over the disks (a hub glued to the strip) make the sag smaller; where a span is
    stiffer the strip carries only its share of the moment, and none where it is held straight."""
    r0 = proto()
    glued = [sag.Span(s, s + 11.5, 7 * E_LAMINATE * I_STRIP) for s in STATIONS[:-1]]
    r1 = proto(spans=glued)
    rigid = [sag.Span(s, s + 11.5, math.inf) for s in STATIONS[:-1]]
    r2 = proto(spans=rigid)
    assert r2.tip_sag < r1.tip_sag < r0.tip_sag
    inside = (r1.s > 30) & (r1.s < 30 + 1.0)      # within the span at station 1 (22.5 to 34)
    assert np.allclose(r1.stress[inside], np.abs(r1.moment[inside]) * T / 2 / I_STRIP / 7)
    assert np.all(r2.stress[(r2.s > 23) & (r2.s < 33)] == 0)
    assert r2.base_moment == pytest.approx(sag.base_moment_from_statics(r2), rel=1e-7)


def test_uniform_moment_bending_stress():
    """A bare strip bent to θ by a uniform moment: σ = E (t/2) θ / L; spans held straight put all
    of the bend on what is left of it."""
    s, k = sag.bending_stress_under_uniform_moment(L, math.pi / 2, E_LAMINATE, I_STRIP, T)
    assert k == pytest.approx(math.pi / 2 / L) and s == pytest.approx(E_LAMINATE * T / 2 * math.pi / 2 / L)
    s2, _ = sag.bending_stress_under_uniform_moment(L, math.pi / 2, E_LAMINATE, I_STRIP, T,
                                                     [sag.Span(0, L / 2, math.inf)])
    assert s2 == pytest.approx(2 * s)
