"""Every failing check's fixes, tried (:func:`attach`): the check's own (computed by the model that
failed it, in :mod:`hwgen.checks`) or the trials of :mod:`hwgen.tried.tension`, and the
relaxations; each fix's effect on the stiffening (``then["stiffening"]``, and ``breaks`` when it
takes it under its floor); fixes of one round that interact, tried together; then ordered best
first (passing design changes, passing relaxations, what does not pass) and written as the
check's ``fix``."""
from __future__ import annotations

from dataclasses import asdict, replace

from ..checks.base import Fix, fix_text
from . import tension
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


def _purpose(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """The stiffening under its floor: (a relaxation) the floor it reaches."""
    v = check.get("measured")
    if v is None:
        return []
    field = "check.min_stiffening" if check["id"] == "stiffening.tip" else "check.min_torsion_stiffening"
    floor = max(round(int(v * 100) / 100, 2), 0.0)
    return [Fix(set={**base, field: floor}, then={"measured": v, "passed": v >= floor, "limit": floor},
                note=f"state that the robot needs only {floor:g}× from its stiffening tendons, with its reason",
                relax=True)]


TRIERS.update({"tendon.robust": _robust, "stiffening.tip": _purpose, "stiffening.torsion": _purpose})


def fixes_of(trial: Trial, check: dict, base: dict | None = None) -> list[Fix]:
    """The fixes of one failing check: those its check computed, and the trials here."""
    own = [Fix(**{**f, "breaks": tuple(f.get("breaks", ()))}) for f in check.get("fixes", ())]
    trier = TRIERS.get(check["id"])
    return own + (trier(trial, check, base or {}) if trier else [])


def _with_stiffening(trial: Trial, fix: Fix) -> Fix:
    """``then`` with the stiffening of the changed design, and ``breaks`` with the stiffening's
    checks where it falls under their floors (that passed before)."""
    s = trial.stiffening(fix.set)
    if s is None:
        return fix
    breaks = list(fix.breaks)
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
        others = {kk: f for kk, f in first.items() if kk != k and f is not None and not set(f.set) & set(mine.set)}
        if not others:
            continue
        base = {p: v for f in others.values() for p, v in f.set.items()}
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
        after = [replace(f, note=f.note + f" (computed after {names})") for f in TRIERS[c["id"]](trial, c, base)
                 if not f.relax]
        found[k][i + 1:i + 1] = after[:1]


def attach(report: dict, trial: Trial) -> dict:
    """``report`` with every failing check's ``fixes`` (as JSON) and its ``fix`` written from them,
    where any was tried; other checks as they were."""
    failing = [c for c in report["checks"] if not c["passed"]]
    found: dict[tuple, list[Fix]] = {}
    for c in failing:
        got = fixes_of(trial, c)
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
