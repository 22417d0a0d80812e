"""The tension checks' fixes (``tendon.taut``, ``tendon.overload``, ``actuation.tension``,
``actuation.coupling``), each tried: the change applied to the design, its plan made and the
weightless bending sweep's statics run again (:func:`hwgen.checks.tension.tension_checks`, on
the as-built taut study the build measured). A pretension that must move is found by a few
secant steps on the check's own measure (the locked tensions move about one for one with it, not
exactly: the one-way springs and the strip's bend share the load)."""
from __future__ import annotations

from ..checks.base import Fix
from .trial import Trial, down, ident, up

STEPS = 6                      # secant steps on a pretension at most (each one sweep, under a second)
MARGIN_N = 0.05                # above the floor, N: a tension that lands on it is not a pass
SHARES = (0.5, 0.25)           # the stiffening tendons' pretensions scaled by these, in turn


def outcome(trial: Trial, changes: dict, target: tuple) -> tuple[dict, tuple[str, ...]] | None:
    """(then, breaks) of the tension checks of the changed design for the check ``target``
    (:func:`hwgen.tried.trial.ident`); None when the changed design is refused."""
    checks = trial.tension(changes)
    if checks is None:
        return None
    by = {ident(c): c for c in checks}
    c = by.get(target)
    then = ({"measured": None, "passed": True} if c is None else
            {"measured": c.measured, "passed": bool(c.passed), "limit": c.limit})
    breaks = tuple(sorted({k[0] for k, x in by.items() if not x.passed and k != target
                           and (trial.base_checks.get(k) or {}).get("passed")}))
    return then, breaks


def _fix(trial: Trial, changes: dict, target: tuple, note: str, relax: bool = False) -> Fix | None:
    got = outcome(trial, changes, target)
    if got is None:
        return None
    return Fix(set=changes, then=got[0], breaks=got[1], note=note, relax=relax)


def _pretension(trial: Trial, tendon: str) -> tuple[str, float] | None:
    """(the path of ``tendon``'s pretension_n, its value: its own, else check.working_tension_n)."""
    i = trial.index(tendon)
    if i is None:
        return None
    path = f"tendons[{i}].pretension_n"
    v = trial.current(path)
    return path, float(trial.plan.check.working_tension_n if v is None else v)


def _stiffening_names(trial: Trial) -> list[str]:
    """The design's tendons that are locked to stiffen (not on the actuating channel)."""
    act = trial.plan.tensioner.actuating_channel
    return [t.name for t in trial.loaded.design.tendons if t.channel != act]


def taut(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """A locked tendon that goes slack: its pretension raised until its least tension as built
    clears the floor (secant steps on the swept tension; doubled while it stays slack), within the
    schema's bound."""
    name, floor, m0 = check["where"]["tendon"], check["limit"], check["measured"]
    got = _pretension(trial, name)
    if got is None or floor is None or m0 is None:
        return []
    path, pre0 = got
    pre0 = float(base.get(path, pre0))
    target = ident(check)
    p_prev, m_prev = pre0, m0
    p = up(pre0 + floor - m0 + MARGIN_N)
    best = None
    for _ in range(STEPS):
        if p > 10_000:
            break
        fix = _fix(trial, {**base, path: p}, target, f"lock {name} at {p:g} N instead of {pre0:g} N: its least "
                                                     f"tension as built then stays over the {floor:g} N floor")
        if fix is None:
            break
        best = fix
        m = fix.then["measured"]
        if fix.then["passed"] or m is None:
            break
        slope = (m - m_prev) / (p - p_prev) if p != p_prev else 0.0
        p_prev, m_prev = p, m
        # slack throughout (no slope to follow): double it; else a secant step on the least tension
        p = up(p * 2) if m <= 0 or slope <= 0.05 else up(p + (floor - m) / slope + MARGIN_N)
    if best is not None and best.then["passed"] and m_prev is not None and p_prev < p_of(best):
        # passed from a doubling step: one secant step back between the last slack and it
        hi_p, hi_m = p_of(best), best.then["measured"]
        if hi_m > m_prev:
            q = up(p_prev + (floor + MARGIN_N - m_prev) * (hi_p - p_prev) / (hi_m - m_prev))
            if p_prev < q < hi_p:
                fix = _fix(trial, {**base, path: q}, target, best.note.replace(f"at {hi_p:g} N", f"at {q:g} N"))
                best = fix if fix is not None and fix.then["passed"] else best
    return [best] if best else []


def p_of(fix: Fix) -> float:
    """The one pretension a fix of :func:`taut` sets."""
    return next(v for k, v in fix.set.items() if k.endswith(".pretension_n"))


def overload(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """A locked tendon pulled over its allowed load: a line that carries it; or less pretension."""
    name, hi, allow = check["where"]["tendon"], check["measured"], check["limit"]
    if hi is None or allow is None:
        return []
    safety = trial.plan.check.tendon_safety_factor
    target, out = ident(check), []
    need = up(hi * safety + 0.5, 1.0)
    out.append(_fix(trial, {**base, "tendon_material.break_load": need}, target,
                    f"a line of at least {need:g} N break load carries {hi:.1f} N with the safety factor {safety:g}"))
    got = _pretension(trial, name)
    if got is not None:
        path, pre0 = got
        p = down(float(base.get(path, pre0)) - (hi - allow) - MARGIN_N)
        if p >= 0:
            out.append(_fix(trial, {**base, path: p}, target, f"lock {name} at {p:g} N instead of {pre0:g} N"))
    return [f for f in out if f]


def actuation_tension(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """The actuating tendon's pull at the sweep's end over what its line may carry: a stronger
    line; or (a relaxation) a smaller safety factor. (Locking the stiffening tendons lower barely
    moves it where the coupling passes: it is actuation.coupling's fix.)"""
    pull = check["measured"]
    if pull is None:
        return []
    chk, target, out = trial.plan.check, ident(check), []
    need = up(pull * chk.tendon_safety_factor + 0.5, 1.0)
    out.append(_fix(trial, {**base, "tendon_material.break_load": need}, target,
                    f"a line of at least {need:g} N break load carries the {pull:.1f} N pull with the safety factor "
                    f"{chk.tendon_safety_factor:g}"))
    brk = float(base.get("tendon_material.break_load", trial.plan.tendon_material.break_load))
    factor = down(0.99 * brk / pull, 0.1)
    if 1.0 <= factor < chk.tendon_safety_factor:
        out.append(_fix(trial, {**base, "check.tendon_safety_factor": factor}, target,
                        f"accept a safety factor of {factor:g} on the {brk:g} N break load", relax=True))
    return [f for f in out if f]


def coupling(trial: Trial, check: dict, base: dict) -> list[Fix]:
    """The locked stiffening tendons raise the actuating pull too much: lock them lower; or (a
    relaxation) allow the rise."""
    rise = check["measured"]
    out = [_lower_stiffening(trial, check, base)]
    if rise is not None:
        allow = up(rise + 0.01, 0.01)
        out.append(_fix(trial, {**base, "check.max_coupling": allow}, ident(check),
                        f"accept a {allow * 100:g} % rise of the actuating pull", relax=True))
    return [f for f in out if f]


def _lower_stiffening(trial: Trial, check: dict, base: dict) -> Fix | None:
    """Every stiffening tendon locked at a share of its tension (:data:`SHARES`, in turn): the
    first that passes, else the last tried."""
    best = None
    for share in SHARES:
        changes = dict(base)
        for name in _stiffening_names(trial):
            got = _pretension(trial, name)
            if got is not None:
                changes[got[0]] = up(float(base.get(got[0], got[1])) * share)
        if changes == base:
            return None
        best = _fix(trial, changes, ident(check), f"lock the stiffening tendons at {share:g} of their tension")
        if best is None or best.then["passed"]:
            break
    return best


TRIERS = {"tendon.taut": taut, "tendon.overload": overload, "actuation.tension": actuation_tension,
          "actuation.coupling": coupling}
