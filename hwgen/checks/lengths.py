"""Tendon lengths over the bending sweep, eq. (1)-(2) (:mod:`hwgen.model.kinematics`) applied to
the eyelet positions measured in the exported disks, against each tendon's budget."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import kinematics as kin
from .base import Check
from .eyelets import EyeletMap


@dataclass
class TendonLengths:
    name: str
    channel: str
    angles_deg: np.ndarray
    lengths: np.ndarray               # (K,) at each angle
    rest: float
    budget: float | None

    @property
    def delta(self) -> np.ndarray:
        return self.lengths - self.rest

    @property
    def max_abs_delta(self) -> float:
        return float(np.abs(self.delta).max())

    @property
    def passed(self) -> bool:
        return self.budget is None or self.max_abs_delta <= self.budget


def sweep_angles(max_deg: float, step_deg: float) -> np.ndarray:
    """-max .. +max in steps of ``step``, always including 0 and both ends."""
    k = int(np.floor(max_deg / step_deg + 1e-9))
    half = np.arange(1, k + 1) * step_deg
    if half.size == 0 or half[-1] < max_deg - 1e-9:
        half = np.append(half, max_deg)
    return np.concatenate([-half[::-1], [0.0], half])


def tendon_lengths(emap: EyeletMap, report: dict, angles: np.ndarray, length: float) -> list[TendonLengths]:
    kappa = kin.kappas_for_angles(angles, length)
    i0 = int(np.flatnonzero(angles == 0)[0])
    out = []
    for t in report["tendons"]:
        L = kin.tendon_lengths(emap.stations_y, emap.positions[t["name"]], kappa)
        out.append(TendonLengths(t["name"], t["channel"], angles, L, float(L[i0]), t["budget_mm"]))
    return out


def pair_take_up(tls: list[TendonLengths], channel: str) -> dict | None:
    """Slack an antagonistic pair on one channel develops: -(ΔL1 + ΔL2), worst over the sweep."""
    pair = [t for t in tls if t.channel == channel]
    if len(pair) != 2:
        return None
    s = pair[0].delta + pair[1].delta
    k = int(np.argmax(np.abs(s)))
    return {"channel": channel, "tendons": [pair[0].name, pair[1].name], "take_up_mm": float(-s[k]),
            "at_angle_deg": float(pair[0].angles_deg[k]),
            "sum_delta_at_max_mm": float(s[-1]), "sum_delta_at_min_mm": float(s[0])}


def length_checks(tls: list[TendonLengths], emap: EyeletMap, deviations: dict[str, list],
                  function_deltas: dict[str, float]) -> list[Check]:
    """Budget per tendon; a failing tendon whose table departs from its named function says so.

    ``deviations``: tendon -> [(station, distance mm)] where its table departs from the eq. (3)
    function it names; ``function_deltas``: tendon -> max |ΔL| if its eyelets sampled that function.
    """
    out = []
    for t in tls:
        k = int(np.argmax(np.abs(t.delta)))
        ang = float(t.angles_deg[k])
        where = {"tendon": t.name, "channel": t.channel, "angle_deg": ang}
        src = ""
        if emap.unmeasured.get(t.name):
            src = f" (stations {emap.unmeasured[t.name]} not found in the geometry: design positions used)"
        if t.budget is None:
            out.append(Check("tendon.length", "info", True,
                             f"{t.name} (actuating, channel {t.channel}): rest length {t.rest:.3f} mm, changes by "
                             f"{t.delta[-1]:+.3f} mm at {t.angles_deg[-1]:+g}° and {t.delta[0]:+.3f} mm at "
                             f"{t.angles_deg[0]:+g}°{src}", t.max_abs_delta, None, where))
            continue
        verdict = "exceeds its coupling budget: its" if not t.passed else ":"
        msg = (f"{t.name} (channel {t.channel}) {verdict} length changes by up to {t.max_abs_delta:.4f} mm "
               f"(at {ang:+g}°) over ±{t.angles_deg[-1]:g}°, budget {t.budget:g} mm{src}").replace(") :", "):")
        if not t.passed:
            devs = [(j, d) for j, d in deviations.get(t.name, []) if d > 1e-3]
            if devs:
                big = max(d for _, d in devs)
                at = [j for j, d in devs if d > 0.5 * big]
                msg += (f". Its eyelet table does not sample the eq. (3) function it names: it departs by up to "
                        f"{big:.2f} mm at stations {at}")
                if t.name in function_deltas:
                    fd = function_deltas[t.name]
                    msg += (f"; eyelets on the named function would change by {fd:.4f} mm, "
                            f"{'within' if fd <= t.budget else 'also over'} the budget")
        # through the hole centres: reported; the verdict is on the taut path as built (tendon.robust)
        fix = "" if t.passed else (f"route {t.name} so its length changes less over the bend (tendons[].routing: "
                                   f"eq. (3) with a smaller amplitude or more half waves), or a larger budget_mm")
        out.append(Check("tendon.length", "info", t.passed, msg, t.max_abs_delta, t.budget, where, fix=fix))
    return out
