"""Every failing check's fixes, tried (:func:`attach`): the check's own (computed by the model that
failed it, in :mod:`hwgen.checks`) or the trials of :mod:`hwgen.tried.tension`, and the
relaxations; each fix's effect on the stiffening (``then["stiffening"]``, and ``breaks`` when it
takes it under its floor); fixes of one round that interact, tried together; then ordered best
first (passing design changes, passing relaxations, what does not pass) and written as the
check's ``fix``."""
from __future__ import annotations

from dataclasses import asdict, replace

from ..checks.base import Fix, fix_text
from . import asbuilt, tension
from .trial import Trial, ident, up

__all__ = ["Trial", "attach"]

TRIERS = dict(tension.TRIERS)


def _robust(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """A tendon over its as-built budget: (a relaxation) the budget its statistic needs; the
    statistic is the build's own Monte Carlo's (the budget moves none of its samples)."""
    robust = check.get("measured")
    i = trial.index(check["where"].get("tendon", ""))
    if robust is None or i is None:
        return []
    budget = up(robust * 1.02 + trial.plan.check.robust_precision_mm, 0.01)
    return [Fix(set={**base, f"tendons[{i}].budget_mm": budget},
                then={"measured": robust, "passed": robust <= budget, "limit": budget},
                note=f"allow {check['where']['tendon']} {budget:g} mm of length change over the sweep as built, "
                     f"if the robot bears the coupling (the statistic of the build's samples against it)",
                relax=True)]


STIFFER = (2.0, 4.0, 8.0)        # the line's EA, and the tie-off's stiffness, times these in turn


def _purpose(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """The stiffening under its floor: a stiffer line, a stiffer tie-off (the tendons' springs are
    what the locked tendons add; their pretension barely moves it), each the least of
    :data:`STIFFER` that passes, by the tendon states' statics; then (a relaxation) the floor it
    reaches."""
    v = check.get("measured")
    if v is None:
        return []
    key = "tip" if check["id"] == "stiffening.tip" else "torsion"
    tm = trial.loaded.design.tendon_material
    out = [_stiffer(trial, check, base, key, "tendon_material.axial_stiffness_n", tm.axial_stiffness_n, 1.0,
                    "a line that stretches less (its EA)"),
           _stiffer(trial, check, base, key, "tendon_material.tie_off_compliance_mm_per_n",
                    tm.tie_off_compliance_mm_per_n, -1.0, "a tie-off and drum that give less (crimp, fewer wraps)")]
    field = "check.min_stiffening" if key == "tip" else "check.min_torsion_stiffening"
    floor = max(round(int(v * 100) / 100, 2), 0.0)
    out.append(Fix(set={**base, field: floor}, then={"measured": v, "passed": v >= floor, "limit": floor},
                   note=f"state that the robot needs only {floor:g}× from its stiffening tendons, with its reason",
                   relax=True))
    return [f for f in out if f]


def _stiffer(trial: Trial, check: dict, base: dict, key: str, path: str, now: float, sign: float,
             words: str) -> Fix | None:
    """``path`` times (``sign`` 1) each of :data:`STIFFER` in turn, or (-1) over its middle one:
    the first that brings the stiffening to its floor, else the last tried."""
    best = None
    if now <= 0:
        return None
    for k in (STIFFER if sign > 0 else STIFFER[1:2]):      # the tie-off: once, a quarter of its give
        value = float(f"{now * k ** sign:.3g}")
        s = trial.stiffening({**base, path: value})
        if s is None:
            return best
        floor = s["min_tip" if key == "tip" else "min_torsion"]
        best = Fix({**base, path: value}, {"measured": s[key], "passed": s[key] >= floor, "limit": floor}, (),
                   f"from {now:g}: {words}")
        if best.then["passed"]:
            break
    return best


TRIERS.update({"tendon.robust": _robust, "stiffening.tip": _purpose, "stiffening.torsion": _purpose})


def fixes_of(trial: Trial, check: dict, base: dict | None = None) -> list[Fix]:
    """The fixes of one failing check: those its check computed, and the trials here."""
    own = [Fix(**{**f, "breaks": tuple(f.get("breaks", ()))}) for f in check.get("fixes", ())]
    trier = TRIERS.get(check["id"])
    return own + (trier(trial, check, base or {}) if trier else [])


def _with_stiffening(trial: Trial, fix: Fix) -> Fix:
    """``then`` with the stiffening of the changed design, and ``breaks`` with the tension checks
    and the stiffening's that passed before and fail with it."""
    if trial.plan_with(fix.set) is None:           # the changed design is refused: not a fix
        return replace(fix, then={**fix.then, "passed": False, "refused": True},
                       note=fix.note + "; the design with this change is refused (hwgen check says why)")
    breaks = list(fix.breaks)
    for c in trial.tension(fix.set) or ():
        if not c.passed and (trial.base_checks.get(ident(c)) or {}).get("passed") and c.id not in breaks:
            breaks.append(c.id)
    fix = replace(fix, breaks=tuple(breaks))
    s = trial.stiffening(fix.set)
    if s is None:
        return fix
    for key, cid, floor in (("tip", "stiffening.tip", "min_tip"), ("torsion", "stiffening.torsion", "min_torsion")):
        was = trial.base_checks.get((cid,))
        if s[key] < s[floor] and (was is None or was.get("passed")) and cid not in breaks:
            breaks.append(cid)
    return replace(fix, then={**fix.then, "stiffening": s["tip"], "torsion_stiffening": s["torsion"]},
                   breaks=tuple(breaks))


def _rank(f: Fix) -> tuple:
    return (not f.then.get("passed"), f.relax, bool(f.breaks))


def _together(trial: Trial, failing: list[dict], found: dict[tuple, list[Fix]]) -> None:
    """Fixes of one round that interact: each tension check's first fix tried with the round's other
    first design fixes applied too; where it no longer passes so, its fix computed again on that
    design (the later after the earlier), added as a fix that sets both, and both notes say so."""
    first = {k: next((f for f in v if f.then.get("passed") and not f.relax), None) for k, v in found.items()}
    for c in failing:
        k = ident(c)
        mine = first.get(k)
        if c["id"] not in tension.TRIERS or mine is None:
            continue
        others, base = {}, {}
        for kk, f in first.items():         # the others' first fixes that set none of the same keys
            if kk != k and f is not None and not set(f.set) & (set(mine.set) | set(base)):
                others[kk] = f
                base.update(f.set)
        if not others:
            continue
        names = ", ".join(sorted({kk[0] for kk in others}))
        got = tension.outcome(trial, {**base, **mine.set}, k)
        if got is None:
            continue
        then, _ = got
        i = found[k].index(mine)
        if then["passed"]:
            found[k][i] = replace(mine, note=mine.note + f"; still passes with this round's other fixes ({names}) "
                                                         f"applied")
            continue
        found[k][i] = replace(mine, note=mine.note + f"; with this round's other fixes ({names}) applied it measures "
                                                     f"{then['measured']:.4g} and fails: apply the fix computed after "
                                                     f"them instead")
        again = {**c, "measured": then["measured"], "limit": then.get("limit", c.get("limit"))}
        after = [replace(f, note=f.note + f" (computed after {names})") for f in TRIERS[c["id"]](trial, again, base)
                 if not f.relax]
        found[k][i + 1:i + 1] = after[:1]


def attach(report: dict, trial: Trial) -> dict:
    """``report`` with every failing check's ``fixes`` (as JSON) and its ``fix`` written from them,
    where any was tried; other checks as they were."""
    failing = [c for c in report["checks"] if not c["passed"]]
    found: dict[tuple, list[Fix]] = {}
    tighter = asbuilt.clearance_fixes(trial, [c for c in failing if c["id"] == "tendon.robust"])
    for c in failing:
        got = ([tighter[ident(c)]] if ident(c) in tighter else []) + fixes_of(trial, c)
        if got:
            found[ident(c)] = got
    _together(trial, failing, found)
    out = []
    for c in report["checks"]:
        fixes = found.get(ident(c)) if not c["passed"] else None
        if fixes:
            fixes = sorted((_with_stiffening(trial, f) for f in fixes), key=_rank)
            c = {**c, "fixes": [{**asdict(f), "breaks": list(f.breaks)} for f in fixes], "fix": fix_text(fixes)}
        out.append(c)
    return {**report, "checks": out}
