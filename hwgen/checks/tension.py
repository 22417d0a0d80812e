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
under ``check.max_coupling``) and ``actuation.tension`` (the actuating tendon's own tension at
the sweep's end: a warning over the same allowable, an error at or above the break load).
"""
from __future__ import annotations

import hashlib
import pickle
from dataclasses import replace

import numpy as np

from .. import cache
from ..model import bending as bd
from ..model import statics as st
from ..model import stiffness as sf
from .base import REBUILD, Check

STATICS_STEP_DEG = 15.0    # the statics sweep's step (eyelets are sized at 1°, model/plan.py): tensions are smooth in it
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
    inner, free = _slack_sweep(desc, model, work, ang)
    return bd.sweep(desc, model, work, ang, STATICS_STEP_DEG, locked=True, inner_of=inner), free


_SLACK: dict[bytes, tuple[dict, dict]] = {}    # a process's last slack sweeps (a tune's worker meets one robot's many times)
_SLACK_KEEP = 8


def _slack_sweep(desc: sf.Described, model: st.Model, work: dict, ang: float) -> tuple[dict, dict]:
    """(which actuating tendon each side hauls in, the sweep with the stiffening tendons slack).
    Neither depends on where the stiffening tendons run, only on the stations they pass (which set
    the model's joints): a tune that varies their routing and tensions meets the same slack sweep
    in every trial, and this process computes it once (the same values: the model is the robot's)."""
    unloaded = tuple(t if t.name in desc.actuating else
                     replace(t, points=np.zeros_like(np.asarray(t.points, float)), stiffness=0.0, compliances=(),
                             exit=None) for t in desc.robot.tendons)
    key = hashlib.sha256(pickle.dumps((replace(desc.robot, tendons=unloaded), desc.actuating,
                                       {n: work[n] for n in desc.actuating}, ang, FREE_STEP_DEG,
                                       bd.SWEEP_H_MAX, model.n_dof))).digest()
    if key not in _SLACK:
        inner = bd.inner_tendons(desc, model)
        _SLACK[key] = inner, bd.sweep(desc, model, work, ang, FREE_STEP_DEG, locked=False, inner_of=inner)
        while len(_SLACK) > _SLACK_KEEP:
            _SLACK.pop(next(iter(_SLACK)))
    return _SLACK[key]


def tension_checks(plan, taut: dict, centre_mm: dict, swept=None) -> tuple[dict, list[Check]]:
    """(report, checks). ``taut``: this report's as-built taut study; ``centre_mm``: each tendon's
    largest |ΔL| through the hole centres (eq. (2), measured); ``swept``: :func:`sweeps` of this
    plan, if already at hand."""
    chk, tm = plan.check, plan.tendon_material
    if swept is None:
        try:
            swept = sweeps(plan)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
            fix = ("a robot the statics resolves: fewer disks (disks.count) or a shorter strip (backbone.length)"
                   if "joint coordinates" in str(e) else REBUILD)
            return ({"skipped": str(e)},
                    [Check("tension.model", "warning", False, f"the tendon tensions were not computed: {e}; "
                           f"tendon.taut, tendon.overload and actuation.* are not judged", fix=fix)])
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
        span_n = (work[name], lo_built, hi_built, floor, allow)
        checks.append(Check("tendon.taut", sev, ok, msg, lo_built, floor, {"tendon": name},
                            fix="" if ok else _slack_fix(name, span_n, excess),
                            lowered_by="check.robust_severity" if not ok and sev == "warning" else ""))
        ok = hi_built < allow
        fix = "" if ok else _overload_fix(name, span_n, chk.tendon_safety_factor)
        checks.append(Check("tendon.overload", "error", ok,
                            f"{name}: greatest tension over the sweep {hi:.2f} N, {hi_built:.2f} N as built if its "
                            f"excess went the taut way, {'under' if ok else 'over'} "
                            f"{tm.break_load:g} N / {chk.tendon_safety_factor:g} = {allow:.1f} N",
                            hi_built, allow, {"tendon": name}, fix=fix))
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
        fix = "" if ok else (
            f"lower the locked stiffening tendons' pretension_n ({', '.join(sorted(desc.stiffening))}: "
            f"tendons[].pretension_n), or route them so their length changes less as the robot bends (tendon.length): "
            f"each pulls against the bend as much as its path lengthens times its spring; or a more compliant line or "
            f"tie-off (tendon_material.axial_stiffness_n, tie_off_compliance_mm_per_n); or, if a "
            f"{worst['rise'] * 100:.0f} % rise is acceptable, check.max_coupling")
        checks.append(Check("actuation.coupling", "error", ok,
                            f"{worst['inner']} needs {worst['with_stiffening_n']:.2f} N to bend the robot "
                            f"{min(abs(worst['at_deg']), ang):.0f}° with the stiffening tendons locked, "
                            f"{worst['without_n']:.2f} N with them slack: {worst['rise'] * 100:+.1f} % "
                            f"({'within' if ok else 'over'} the {limit * 100:g} % allowed){short}",
                            worst["rise"], limit, {"tendon": worst["inner"]}, fix=fix))
        checks.append(_actuation_tension(max(sides, key=lambda s: s["with_stiffening_n"]), tm, chk, ang))
    report = {
        "model": "weightless robot bent by hauling in the inner actuating tendon, the others at their working "
                 "tension; stiffening tendons locked at it (pretension_n, else check.working_tension_n; and again "
                 "slack); discrete elastic rod with eq. (2) "
                 "tendons as one-way springs (hwgen.model.statics); as built: the taut path's excess length "
                 "change at the tendon's spring rate, first order",
        "allowable_n": allow, "floor_n": floor, "tendons": tendons, "actuation": sides,
    }
    return report, checks


def _slack_fix(name: str, span_n: tuple, excess: float) -> str:
    """A stiffening tendon that goes slack: the pretension that keeps it taut (its locked tensions
    move with the pretension one for one: its spring changes by the same lengths), and what that
    costs its greatest tension. ``span_n``: (pretension, least and greatest as built, floor, allowed)."""
    pre, lo, hi, floor, allow = span_n
    up = floor - lo
    return (f"raise {name}'s pretension_n (tendons[].pretension_n) from {pre:g} to at least {pre + up + 0.05:.1f} N"
            + (f", which takes its greatest tension to {hi + up:.1f} N, over the {allow:.1f} N allowed "
               f"(tendon.overload): a stronger line too (tendon_material.break_load)" if hi + up >= allow else "")
            + f"; or route it so its path changes less over the bend ({excess:.3f} mm as built beyond the centres: "
              f"tendon.robust)")


def _overload_fix(name: str, span_n: tuple, safety: float) -> str:
    """A stiffening tendon pulled over its allowed load: the line that carries it, or the pretension
    that keeps it under, and what that costs its least tension (as :func:`_slack_fix`)."""
    pre, lo, hi, floor, allow = span_n
    down = hi - allow
    return (f"a stronger line: tendon_material.break_load of at least {hi * safety:.0f} N (check.tendon_safety_factor "
            f"{safety:g}); or lower {name}'s pretension_n from {pre:g} to at most {max(pre - down - 0.05, 0.0):.1f} N"
            + (f", though it then goes slack (tendon.taut: at least {lo - down:.2f} N against {floor:g} N)"
               if lo - down <= floor else ""))


def _actuation_tension(top: dict, tm, chk, ang: float) -> Check:
    """The actuating tendon's own tension at the sweep's end: a warning over the safety-factored
    load it may carry, an error at or above its break load (it breaks)."""
    pull, allow = top["with_stiffening_n"], tm.break_load / chk.tendon_safety_factor
    ok, breaks = pull < allow, pull >= tm.break_load
    at = min(abs(top["at_deg"]), ang)
    word = (f"at or above its {tm.break_load:g} N break load: the line breaks" if breaks else
            f"{'under' if ok else 'over'} the {allow:.1f} N a tendon may carry: {tm.break_load:g} N / "
            f"{chk.tendon_safety_factor:g}")
    fix = "" if ok else (
        f"a stronger line: tendon_material.break_load of at least {pull * chk.tendon_safety_factor:.0f} N "
        f"(check.tendon_safety_factor {chk.tendon_safety_factor:g}); or bend it less (the pull grows with the angle: "
        f"disks.eyelets.sweep_deg, check.max_angle_deg); or lower the stiffening tendons' pretension_n "
        f"(with them slack it pulls {top['without_n']:.1f} N)")
    return Check("actuation.tension", "error" if breaks else "warning", ok,
                 f"{top['inner']}: {pull:.1f} N at {at:.0f}° of bending ({word})",
                 pull, tm.break_load if breaks else allow, {"tendon": top["inner"]}, fix=fix)
