"""The independent reference's rod (hwgen.sim.cosserat) against textbook closed forms, before it is
trusted with the robot: a cantilever's 3EI/L³, the large-deflection cantilever of Bisshopp &
Drucker, a straight tendon's constant curvature τd/EI, and the clamp's reaction balancing the
loads. No build, no MuJoCo."""
from __future__ import annotations

import math

import numpy as np
import pytest

from hwgen.model.gravity import Gravity, StripWeight, TipWeight
from hwgen.sim import cosserat as co
from hwgen.sim import independent

E, G, H, T, L = 50000.0, 4000.0, 60.0, 0.59, 270.0
EI = E * H * T ** 3 / 12
SECTION = Gravity(model="", E_mpa=E, height_mm=H, thickness_mm=T, length_mm=L, disks=(), spans=(), cases={},
                  strip=StripWeight(part="strip", mass_g=0.05 * L, y_mm=(0.0, L), lambda_g_mm=0.05),
                  tip=TipWeight(mass_g=0.0, a_mm=0.0, z_mm=0.0), document={})
# Bisshopp & Drucker (1945), as tabulated by Bathe & Bolourchi (1979): α = PL²/EI -> (w/L, u/L)
BISSHOPP_DRUCKER = {1.0: (0.30172, -0.05643), 2.0: (0.49346, -0.16064)}


def _strip(weight: float = 0.0):
    bending, shear, _ = independent._sections(SECTION, G)
    return co.Flexible(0.0, L, bending, shear, weight)


def _tip_load(newtons: float) -> co.Rod:
    """The bare strip with a weight at its tip that gravity turns into a dead load of ``newtons``."""
    return co.Rod((_strip(), co.Rigid(L, L, ((newtons / (co.G_ACC * 1e-3), (0.0, 0.0, 0.0)),))))


def _straight_tendon(tau: float, d: float = 30.0, step: float = 5.0) -> co.Solution:
    """The bare, weightless strip with a tendon ``d`` off its axis on weightless eyelets every
    ``step`` mm, pulled with ``tau``."""
    bending, shear, _ = independent._sections(SECTION, G)
    pieces, at = [], 0.0
    for s in np.arange(step, L + 1e-9, step):
        pieces += [co.Flexible(at, float(s), bending, shear, 0.0), co.Rigid(float(s), float(s), (), {"T": (0.0, 0.0, d)})]
        at = float(s)
    return co.solve(co.Rod(tuple(pieces), {"T": [(0.0, 0.0, d)]}), co.Loads(tensions={"T": tau}))


def test_the_textbook_limits_of_the_rod_hold():
    """A 1 mN tip load: tip stiffness within 0.01 % of 3EI/L³ (shear adds 1.5e-5); a straight
    tendon pulled with 1 N: the tip's angle within 0.05 % of τdL/EI (its chords cut the corners
    between eyelets)."""
    P = 1e-3
    tip = co.solve(_tip_load(P), co.Loads(gravity=(0.0, 0.0, -1.0)), steps=(1.0,)).point(1, (0.0, 0.0, 0.0))
    ratio = P / -tip[2] / (3 * EI / L ** 3)
    assert ratio == pytest.approx(1.0, abs=1e-4) and ratio < 1.0          # shear only softens it
    R = _straight_tendon(1.0).starts[-1][1]
    assert math.atan2(R[2, 1], R[1, 1]) / (1.0 * 30.0 * L / EI) == pytest.approx(1.0, abs=5e-4)


@pytest.mark.parametrize("alpha", sorted(BISSHOPP_DRUCKER))
def test_a_large_tip_load_bends_the_rod_as_the_elastica(alpha):
    sol = co.solve(_tip_load(alpha * EI / L ** 2), co.Loads(gravity=(0.0, 0.0, -1.0)))
    tip = sol.point(1, (0.0, 0.0, 0.0))
    w, u = BISSHOPP_DRUCKER[alpha]
    assert -tip[2] / L == pytest.approx(w, abs=2e-5)             # the table's five decimals
    assert (tip[1] - L) / L == pytest.approx(u, abs=2e-5)


def test_a_straight_tendon_bends_the_strip_to_a_circle():
    """A tendon 30 mm off the axis on weightless eyelets every 5 mm, pulled with 5 N: the centre line
    lies on a circle of radius EI/(τd) about (0, 0, EI/(τd)) to 1e-4 of its radius (the chords cut the
    corners between eyelets, 0.009 mm deep: the moment arm falls short by about that)."""
    d, tau = 30.0, 5.0
    sol = _straight_tendon(tau, d)
    rho = EI / (tau * d)
    r = np.hypot(sol.p[:, 1], sol.p[:, 2] - rho)
    assert np.abs(r - rho).max() < 1e-4 * rho
    assert math.degrees(L / rho) > 40                           # a large bend, not a linear one


def test_the_clamp_carries_every_load():
    """The force at the clamp is the weight of everything beyond it, and under a tendon alone none
    (the tendon's pull on the eyelets and its reaction at the ground cancel only with the ground's)."""
    m = 25.0
    rod = co.Rod((_strip(0.05), co.Rigid(L, L + 10.0, ((m, (3.0, 20.0, -2.0)),))))
    sol = co.solve(rod, co.Loads(gravity=(0.0, 0.0, -1.0)))
    weight = (m + 0.05 * L) * co.G_ACC * 1e-3
    assert sol.n0 == pytest.approx([0.0, 0.0, -weight], abs=1e-9)
    assert sol.residual < 1e-8
