"""What the stiffening tendons are for, as checks: every tendon locked must stiffen the tip over
the actuating pair alone by at least ``check.min_stiffening`` (and its torsion by at least
``check.min_torsion_stiffening``), as the tendon states' statics has it
(:mod:`hwgen.model.stiffness`: the reference orientation, frictionless eyelets, tensioned by the
paper's protocol). A change that passes another check by slackening, unloading or rerouting the
stiffening tendons shows here (issue 43: following untried fixes drove a lab's robot from 2.88× to
1.00× and nothing said so)."""
from __future__ import annotations

from .base import Check

FRICTION = "none"          # the headline's: frictionless eyelets (stuck ones are the upper bound)


def figures(study: dict) -> dict | None:
    """{"states": (all, pair), "tip": ratio, "torsion": ratio} of a statics study (stiffness.json's
    content) in its reference orientation, frictionless; None when it has no pair to compare
    (no stiffening tendons, or the study was skipped)."""
    sec = study.get("stiffening") if isinstance(study, dict) else None
    if not sec:
        return None
    full, act = sec["states"]
    ref = sec["reference"]
    got = {e["state"]: e for e in study.get("states", []) if e.get("orientation") == ref
           and e.get("friction") == FRICTION and "push" not in e}
    if full not in got or act not in got:
        return None
    return ratios(got[full], got[act], (full, act))


def ratios(full: dict, act: dict, states: tuple[str, str]) -> dict:
    """The tip's and the torsion's ratio of two statics entries (all tendons over the pair)."""
    def over(key):
        a = act.get(key)
        return full[key] / a if a else float("inf")
    return {"states": list(states), "tip": over("tip_stiffness_n_per_mm"), "torsion": over("tip_torsion_nmm_per_rad")}


def stiffening_checks(plan, study: dict) -> list[Check]:
    """``stiffening.tip`` and ``stiffening.torsion`` of a plan's statics study (none when the design
    has no stiffening tendons; a warning that says why when the study was skipped)."""
    if isinstance(study, dict) and "skipped" in study:
        return [Check("stiffening.tip", "warning", False, f"the stiffening was not computed ({study['skipped']}): "
                      f"what the stiffening tendons add is not judged", None, None,
                      fix="a robot the statics resolves: fewer disks (disks.count) or a shorter strip (backbone.length)")]
    got = figures(study)
    return [] if got is None else judge(plan, got)


def judge(plan, got: dict) -> list[Check]:
    """The two checks of :func:`stiffening_checks` from the ratios (:func:`figures`)."""
    chk = plan.check
    full, act = got["states"]
    out = []
    for cid, key, floor, what, field in (
            ("stiffening.tip", "tip", chk.min_stiffening, "tip stiffness", "check.min_stiffening"),
            ("stiffening.torsion", "torsion", chk.min_torsion_stiffening, "tip torsional stiffness",
             "check.min_torsion_stiffening")):
        v = got[key]
        ok = v >= floor
        msg = (f"{full} over {act}: {what} {v:.2f}× (gravity -z, frictionless, tensioned by the protocol), "
               f"{'at or over' if ok else 'under'} the {floor:g}× the design states ({field})")
        out.append(Check(cid, "error", ok, msg, v, floor, {"states": [full, act]},
                         fix="" if ok else _fix(key, field)))
    return out


def _fix(key: str, field: str) -> str:
    """Until the trials (hwgen.tried) replace it: which way to go."""
    return (f"route the stiffening tendons farther off the strip's neutral plane, or lock them tighter "
            f"(tendons[].pretension_n), or a stiffer line (tendon_material.axial_stiffness_n); "
            f"or, if the robot needs less, a lower {field} with its reason")
