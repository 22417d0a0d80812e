"""The one record every check produces, whatever it measures."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal

Severity = Literal["error", "warning", "info"]


@dataclass(frozen=True)
class Screen:
    """A check's failure foreseen on the plan alone, before any file is written (the plan's circles
    for the measured sections): what a sweep's deeper levels and a tune read of a check without
    building. ``id`` is the check's (or its family's: ``eyelet.wall``); each screen lives beside
    the check that owns its id, and :mod:`hwgen.checks.screens` lists them."""

    id: str
    message: str
    severity: str = "error"
    measured: float | None = None
    limit: float | None = None
    tendon: str | None = None            # the tendon it is about, where it is about one


@dataclass(frozen=True)
class Fix:
    """One change to the design that fixes a failing check, tried: applied to the design and the
    check evaluated again by the model that failed it (issue 43). Printed as a fix only where
    ``then["passed"]``; otherwise it records what the best change within the schema's bounds reaches."""

    set: dict[str, Any]           # dotted paths of the user's file ("tendons[2].pretension_n") -> new value
    then: dict[str, Any]          # the re-evaluation: "measured", "passed", and what it does to the stiffening
    breaks: tuple[str, ...] = ()  # ids of checks that passed before and fail with this change
    note: str = ""                # why, in words; names the user's key that drives a derived value
    relax: bool = False           # passes by relaxing a requirement (a severity, a budget, a limit), not the design


@dataclass(frozen=True)
class Check:
    """One finding. ``passed`` False with severity "error" fails the design (exit code 1)."""

    id: str                       # stable, dotted: "eyelet.wall.edge", "gear.self_locking"
    severity: Severity
    passed: bool
    message: str                  # a sentence a person can act on, naming the place
    measured: float | None = None
    limit: float | None = None
    where: dict[str, Any] = field(default_factory=dict)   # part, station, tendon, channel, ...
    # what to change when it fails: the parameter(s), which way and, where the model computes it,
    # how far (and what the change costs another check); empty when it passes
    fix: str = ""
    # the design setting that states this failure as a warning rather than an error
    # ("check.robust_severity"); empty when the severity is the check's own
    lowered_by: str = ""
    # the tried fixes, best first (design changes before relaxations); ``fix`` is written from them
    fixes: tuple[Fix, ...] = ()

    def to_json(self) -> dict:
        out = asdict(self)
        if not self.fixes:
            del out["fixes"]          # until a check tries its fixes, its record is as it was
        return out


def _failed_as(check) -> str | None:
    """The severity ``check`` (a record with ``passed`` and ``severity``: a :class:`Check`, a sweep
    row's failure record; or a check's JSON) failed with; None when it passed."""
    if not isinstance(check, dict):
        return None if check.passed else check.severity
    return None if check.get("passed", True) else check.get("severity")


def fails(check) -> bool:
    """Whether ``check`` (a record or its JSON) fails the design: not passed, and an error (a failing
    warning is reported and does not). The one statement of the rule: every verdict, exit code,
    summary, sweep row and tune trial asks it here."""
    return _failed_as(check) == "error"


def failing(checks) -> list:
    """The checks among ``checks`` that fail the design (:func:`fails`), in their order."""
    return [c for c in checks or () if fails(c)]


def warned(checks) -> list:
    """The checks among ``checks`` that fail as warnings: reported, the design still passes."""
    return [c for c in checks or () if _failed_as(c) == "warning"]


# the fix of a check that finds hwgen's own files wrong (a part that is not where the design puts
# it, a file missing or unreadable): nothing in the design to change
REBUILD = ("rebuild (hwgen build); if it fails again, hwgen made this wrong: please report it with the "
           "parameter file")


def _value(v) -> str:
    if isinstance(v, float):
        return f"{v:.0f}" if abs(v) >= 1000 else f"{v:.4g}"
    return str(v)


def fix_words(f: Fix) -> str:
    """One tried fix in words: what to set, why, and what the check then measured."""
    change = ", ".join(f"{k}: {_value(v)}" for k, v in f.set.items())
    then = f.then
    got = then.get("measured")
    out = f"{change}" + (f" ({f.note})" if f.note else "")
    if got is not None:
        out += f": tried, the check then measures {_value(float(got))}" + (
            " and passes" if then.get("passed") else " and still fails")
    if then.get("stiffening") is not None:
        out += f"; stiffening then {then['stiffening']:.2f}×"
    if f.breaks:
        out += f"; breaks {', '.join(f.breaks)}"
    if f.relax:
        out += " [relaxes a requirement, not the design]"
    return out


def fix_text(fixes: tuple[Fix, ...] | list[Fix], measured_word: str = "") -> str:
    """The printed ``fix`` of a check, written from its tried ``fixes``: the ones that pass, best
    first, numbered; where none passes, the best within bounds and what it reaches."""
    good = [f for f in fixes if f.then.get("passed")]
    short = [f for f in fixes if not f.then.get("passed") and not f.relax]
    if not good:
        if not fixes:
            return ""
        return (f"no change tried within the schema's bounds passes; the best within bounds: {fix_words(fixes[0])}"
                + (f" ({measured_word})" if measured_word else ""))
    text = " ".join(f"({i}) {fix_words(f)}." for i, f in enumerate(good, start=1))
    if short and all(f.relax for f in good):
        text += f" No change to the design tried passes: the best within bounds, {fix_words(short[0])}."
    return text.rstrip(".")
