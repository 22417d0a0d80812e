"""The verdict in newtons: each stiffening tendon's tension over the bending sweep, and what the
locked stiffening tendons cost the actuating pair (:mod:`hwgen.model.stiffness`,
:mod:`hwgen.model.statics`).

Model (:mod:`hwgen.model.bending`). The weightless robot bent from straight to ±check angle by
hauling in the actuating tendon on the inside of the bend (its drum turning), the other actuating
tendons held at their working tension, every stiffening tendon locked where it carries its
working tension in the weightless robot those tensions settle (tensioned on the bench): its
``pretension_n``, else ``check.working_tension_n`` (the paper's tensioning protocol sets the
stiffness states' tensions for the robot under its weight, which a weightless sweep cannot use;
:mod:`hwgen.model.protocol`); tendons as eq. (2) chords through the
eyelet centres, one-way springs of ``tendon_material.axial_stiffness_n`` in series with
``tie_off_compliance_mm_per_n``. Then the same sweep with the stiffening tendons slack: the
actuating tension's rise between the two is the coupling. The statics is of the plan (the
design's eyelet centres, which ``eyelet.position`` finds in the files within its tolerance); what
the files add is the next paragraph's.

As built. The taut path through the measured holes (this report's ``as_built.taut``) changes
length by more than the centres do. Where it does, the least tension is lowered by that
excess (its ``check.robust`` statistic less the centre-line figure) at the tendon's full spring
rate, as if it all went the slack way (and the greatest raised by as much, as if it all went
the taut way): a first-order bound, not a second statics.

Checks: ``tendon.taut`` (least tension as built over ``check.taut_floor_n``; severity
``check.robust_severity``), ``tendon.overload`` (greatest tension under
``tendon_material.break_load`` / ``check.tendon_safety_factor``), ``actuation.coupling`` (the rise
under ``check.max_coupling``) and ``actuation.tension`` (a warning: the actuating tendon's own
tension at the sweep's end against the same allowable).
"""
from __future__ import annotations

import numpy as np

from .. import cache
from ..model import bending as bd
from ..model import statics as st
from ..model import stiffness as sf
from .base import Check

SWEEP_STEP_DEG = 15.0      # the statics sweep's step: tensions are smooth in the angle; 7 solves a side
FREE_STEP_DEG = 30.0       # the sweep without stiffening tendons is needed only at its end


MAX_DOF = 1500             # a longer robot or more disks than this resolves: the statics is skipped (said so)


def sweeps(plan) -> tuple[sf.Described, dict, dict]:
    """The statics of the sweep (the expensive part): the robot, and the sweep with the stiffening
    tendons locked and with them slack. The sweeps are of the described robot and the angle alone:
    what they gave last time for these (and this code) is remembered in the active cache (the same
    values either way)."""
    desc = sf.describe(plan)
    model = st.Model(desc.robot, bd.SWEEP_H_MAX)
    if model.n_dof > MAX_DOF:
        raise ValueError(f"{model.n_dof} joint coordinates, more than the {MAX_DOF} the sweep is run with")
    ang = plan.check.max_angle_deg
    work = working_tensions(desc, plan)
    locked, free = cache.remembered("tension sweeps", (desc, work, ang), lambda: _sweeps(desc, model, work, ang))
    return desc, locked, free


def working_tensions(desc: sf.Described, plan) -> dict:
    """Each tendon's working tension in the sweep: its ``pretension_n``, else ``check.working_tension_n``."""
    return {n: plan.check.working_tension_n if v is None else v for n, v in desc.pretension.items()}


def _sweeps(desc: sf.Described, model: st.Model, work: dict, ang: float) -> tuple[dict, dict]:
    """The sweep with the stiffening tendons locked and with them slack; which tendon each side
    hauls in is the same for both (probed once)."""
    inner = bd.inner_tendons(desc, model)
    return (bd.sweep(desc, model, work, ang, SWEEP_STEP_DEG, locked=True, inner_of=inner),
            bd.sweep(desc, model, work, ang, FREE_STEP_DEG, locked=False, inner_of=inner))


def tension_checks(plan, taut: dict, centre_mm: dict, swept=None) -> tuple[dict, list[Check]]:
    """(report, checks). ``taut``: this report's as-built taut study; ``centre_mm``: each tendon's
    largest |ΔL| through the hole centres (eq. (2), measured); ``swept``: :func:`sweeps` of this
    plan, if already at hand."""
    chk, tm = plan.check, plan.tendon_material
    if swept is None:
        try:
            swept = sweeps(plan)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
            return ({"skipped": str(e)},
                    [Check("tension.model", "warning", False, f"the tendon tensions were not computed: {e}")])
    desc, locked, free = swept
    work = working_tensions(desc, plan)
    ang = chk.max_angle_deg
    allow = tm.break_load / chk.tendon_safety_factor
    floor = chk.taut_floor_n
    rows = {r["name"]: r for r in taut.get("tendons", [])}
    springs = {t.name: t.stiffness for t in desc.robot.tendons}
    reached = [side["reached_deg"] for side in locked.values() if side["inner"] is not None]
    span = (f"±{ang:g}°" if reached and min(reached) >= ang - 0.5 else
            "the bend the drive reaches (" + ", ".join(f"{k}{v['reached_deg']:.0f}°" for k, v in locked.items()) + ")")
    checks, tendons = [], []
    for name in desc.stiffening:
        values = [v for side in locked.values() for v in side["tensions_n"].get(name, [])]
        if not values:
            continue
        lo, hi = min(values), max(values)
        row = rows.get(name, {})
        robust = row.get("robust_mm", row.get("taut_max_abs_delta_mm"))
        excess = max(0.0, robust - centre_mm.get(name, 0.0)) if robust is not None else 0.0
        lo_built = lo - springs[name] * excess
        hi_built = hi + springs[name] * excess
        tendons.append({"name": name, "spring_n_per_mm": springs[name], "pretension_n": work[name],
                        "least_n": lo, "greatest_n": hi, "as_built_excess_mm": excess, "least_as_built_n": lo_built,
                        "greatest_as_built_n": hi_built})
        ok = lo_built > floor
        sev = "error" if lo <= floor else chk.robust_severity   # slack even through the centres: an error
        msg = (f"{name}: locked at {work[name]:g} N, its tension runs {lo:.2f}-{hi:.2f} N over "
               f"{span} (statics through the eyelet centres, spring {springs[name]:.2f} N/mm); as built "
               f"({chk.robust}) its path shortens {excess:.3f} mm more, so at least {lo_built:.2f} N: "
               + ("taut" if ok else "SLACK") + f" (floor {floor:g} N)")
        checks.append(Check("tendon.taut", sev, ok, msg, lo_built, floor, {"tendon": name}))
        ok = hi_built < allow
        checks.append(Check("tendon.overload", "error", ok,
                            f"{name}: greatest tension over the sweep {hi:.2f} N, {hi_built:.2f} N as built if its "
                            f"excess went the taut way, {'under' if ok else 'over'} "
                            f"{tm.break_load:g} N / {chk.tendon_safety_factor:g} = {allow:.1f} N",
                            hi_built, allow, {"tendon": name}))
    sides = []
    for key, side in locked.items():
        inner = side["inner"]
        if inner is None or free[key]["inner"] != inner:
            continue
        at = min(ang, abs(side["angles_deg"][-1]), abs(free[key]["angles_deg"][-1]))   # the end both reached
        with_ = float(np.interp(at, np.abs(side["angles_deg"]), side["tensions_n"][inner]))
        without = float(np.interp(at, np.abs(free[key]["angles_deg"]), free[key]["tensions_n"][inner]))
        rise = with_ / without - 1.0 if without > 0 else 0.0
        sides.append({"side": key, "inner": inner, "at_deg": at, "with_stiffening_n": with_, "without_n": without,
                      "rise": rise, "reached_deg": side["reached_deg"], "angles_deg": side["angles_deg"],
                      "tensions_n": side["tensions_n"], "without_angles_deg": free[key]["angles_deg"],
                      "without_tensions_n": free[key]["tensions_n"][inner]})
    limit = chk.max_coupling
    if not sides:
        checks.append(Check("actuation.coupling", "info", True, "no actuating tendon bends the robot either way "
                            "when hauled in: no coupling to judge"))
    else:
        worst = max(sides, key=lambda s: s["rise"])
        ok = worst["rise"] <= limit
        short = "" if abs(worst["at_deg"]) >= ang - 0.5 else f" (hauling it in bends the robot only {abs(worst['at_deg']):.1f}°)"
        checks.append(Check("actuation.coupling", "error", ok,
                            f"{worst['inner']} needs {worst['with_stiffening_n']:.2f} N to bend the robot "
                            f"{min(abs(worst['at_deg']), ang):.0f}° with the stiffening tendons locked, "
                            f"{worst['without_n']:.2f} N with them slack: {worst['rise'] * 100:+.1f} % "
                            f"({'within' if ok else 'over'} the {limit * 100:g} % allowed){short}",
                            worst["rise"], limit, {"tendon": worst["inner"]}))
        top = max(sides, key=lambda s: s["with_stiffening_n"])
        ok = top["with_stiffening_n"] < allow
        checks.append(Check("actuation.tension", "warning", ok,
                            f"{top['inner']}: {top['with_stiffening_n']:.1f} N at {min(abs(top['at_deg']), ang):.0f}° "
                            f"of bending "
                            f"({'under' if ok else 'over'} the {allow:.1f} N a tendon may carry: "
                            f"{tm.break_load:g} N / {chk.tendon_safety_factor:g})",
                            top["with_stiffening_n"], allow, {"tendon": top["inner"]}))
    report = {
        "model": "weightless robot bent by hauling in the inner actuating tendon, the others at their working "
                 "tension; stiffening tendons locked at it (pretension_n, else check.working_tension_n; and again "
                 "slack); discrete elastic rod with eq. (2) "
                 "tendons as one-way springs (hwgen.model.statics); as built: the taut path's excess length "
                 "change at the tendon's spring rate, first order",
        "allowable_n": allow, "floor_n": floor, "tendons": tendons, "actuation": sides,
    }
    return report, checks
