"""Which fixes a round of `hwgen fix` applies (numbers and paths only: no build, no CAD).

A failing check's options, best first: its tried ``fixes`` (report.json, :class:`hwgen.checks.base.Fix`)
as the check ranked them (design changes that pass, relaxations that pass, what the best within
bounds reaches), then the relaxation that states the check as a warning where the design has one
(:data:`SEVERITY`). An option is left out when it sets a path ``--keep`` holds (the path, or a
field below it), when it is a relaxation ``--allow-relax`` does not name, when it changes nothing
(the design has its values already), or when an earlier round applied it and it did not help.
Each failing error takes its first option left; two that set one path to different values are a
conflict (:func:`combine`), which the rounds search with the tune engine.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from ..checks.base import fails

# checks whose failure a design may state as a warning, by the setting that does so (the prototype
# states it for itself, with its reason): a relaxation like any other, applied only when named
SEVERITY = {"tendon.robust": "check.robust_severity", "tendon.taut": "check.robust_severity",
            "gravity.strip_stress": "check.overstress"}
INDEX = re.compile(r"\[\d+\]")


@dataclass(frozen=True)
class Option:
    """One way to fix one failing check: the values it sets, whether it passed when tried, whether
    it relaxes a requirement, and the words of the check's fix."""

    check: str                    # "tendon.taut C1": the check's id and where
    set: dict[str, Any]
    passed: bool | None           # as tried by the check's model (None: not tried, a relaxation of severity)
    relax: bool
    note: str = ""
    breaks: tuple[str, ...] = ()

    @property
    def key(self) -> tuple:
        return (self.check, tuple(sorted((k, repr(v)) for k, v in self.set.items())))


@dataclass
class Picked:
    """A round's choice: the values it sets (each with the options that set it), and the paths two
    options set to different values."""

    values: dict[str, Any] = field(default_factory=dict)
    why: dict[str, list[Option]] = field(default_factory=dict)
    conflicts: dict[str, list[Any]] = field(default_factory=dict)


def check_name(c: dict) -> str:
    """A check as a person names it: its id and the tendon, part or channel it is about."""
    w = c.get("where") or {}
    at = "+".join(map(str, w["tendons"])) if isinstance(w.get("tendons"), list) else ""
    at = at or next((str(w[k]) for k in ("tendon", "part", "channel", "pair") if w.get(k) not in (None, "")), "")
    return f"{c['id']} {at}".strip()


def plain(path: str) -> str:
    """A path without its list indices: ``tendons[1].budget_mm`` -> ``tendons.budget_mm``."""
    return INDEX.sub("", path)


def covers(given: str, path: str) -> bool:
    """Whether a path named on the command line (``--keep``, ``--allow-relax``) covers ``path``:
    the same path, or one above it (``tendons[1]`` covers ``tendons[1].pretension_n``); written
    without indices, it covers every item (``tendons.budget_mm``)."""
    for a, b in ((given, path), (plain(given), plain(path))) if "[" not in given else ((given, path),):
        if b == a or b.startswith(a + ".") or b.startswith(a + "["):
            return True
    return False


def options(c: dict) -> list[Option]:
    """Every option of one failing check, best first (see the module's docstring)."""
    name = check_name(c)
    out = []
    for f in c.get("fixes") or []:
        then = f.get("then") or {}
        out.append(Option(name, dict(f.get("set") or {}), bool(then.get("passed")), bool(f.get("relax")),
                          f.get("note", ""), tuple(f.get("breaks") or ())))
    setting = SEVERITY.get(c["id"])
    if setting and fails(c):
        out.append(Option(name, {setting: "warning"}, None, True,
                          f"state {c['id']}'s failure as a warning ({setting}), as the prototype does with its reason"))
    return out


def allowed(o: Option, keep: tuple[str, ...], relax: tuple[str, ...]) -> str | None:
    """Why an option may not be applied (None: it may)."""
    for p in o.set:
        held = next((k for k in keep if covers(k, p)), None)
        if held:
            return f"sets {p}, which --keep {held} holds"
    if o.relax and not all(any(covers(r, p) for r in relax) for p in o.set):
        return f"relaxes {', '.join(o.set)}, which --allow-relax does not name"
    return None


def pick(failing: list[dict], current: dict[str, Any], keep: tuple[str, ...], relax: tuple[str, ...],
         spent: set) -> tuple[Picked, dict[str, list[str]]]:
    """A round's options: each failing check's first option left (see the module's docstring);
    ``current``: path -> the design's value now; ``spent``: keys of options that did not help.
    Returns the choice and, per check left without one, why each of its options was left out."""
    chosen: list[Option] = []
    none: dict[str, list[str]] = {}
    for c in failing:
        why = []
        for o in options(c):
            reason = allowed(o, keep, relax)
            if reason is None and o.key in spent:
                reason = "applied before and did not help"
            if reason is None and all(current.get(p, _MISSING) == v for p, v in o.set.items()):
                reason = "the design has these values already"
            if reason is None and o.passed is False and any(x.passed for x in chosen if x.check == o.check):
                reason = "another option passes"
            if reason is None:
                chosen.append(o)
                break
            why.append(f"{_set_words(o.set)}: {reason}")
        else:
            none[check_name(c)] = why or ["no fix tried for it (its fix is in words only)"]
    return combine(chosen), none


_MISSING = object()


def combine(chosen: list[Option]) -> Picked:
    """The options' values together; a path two options set to different values is a conflict
    (its values listed, the first kept until the search decides)."""
    out = Picked()
    for o in chosen:
        for p, v in o.set.items():
            if p in out.values and out.values[p] != v:
                out.conflicts.setdefault(p, [out.values[p]])
                if v not in out.conflicts[p]:
                    out.conflicts[p].append(v)
            else:
                out.values[p] = v
            out.why.setdefault(p, []).append(o)
    return out


def _set_words(s: dict) -> str:
    return ", ".join(f"{p}: {v}" for p, v in s.items())
