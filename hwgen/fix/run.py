"""The rounds of `hwgen fix`: apply the failing checks' fixes, build and check again, keep what helped.

Round 0 builds the design as written (renamed ``<design>-fixed``, so that its build never replaces
the design's own) and reads its report. Each round then takes every failing error's first option
left (:func:`hwgen.fix.choose.pick`), applies them together (a fix of one check computed on the
design the others of its round change is the check's own business: h43's ``tried``), builds the
design so changed (``hwgen build`` and its checks, the part cache doing most of it) and keeps the
round when fewer errors fail, or as many failing by less (relative to their limits, as the tune
engine counts them); else it goes back to the design before the round, and the options of the
checks that still fail are not applied again, while those that passed their checks are tried
again alone in the next round (one of the others broke it; when every one passed, the first half
of them; undone again, they are not applied again either). Two options that set one path to different values
are searched with the tune engine (:func:`search`: free over the values they name, goal pass) and
the round applies what it finds. It stops when every check passes, when no option is left, or when
``budget`` designs have been built.

What it leaves in ``OUT/fixes/<design>/``: ``fixed.yaml`` (:func:`write_fixed`: the user's file with
its comments and its ``base``, each changed value with a comment naming the check it fixes and the
old value), ``summary.md`` (each change and why, the checks before and after, what is left), and
the fixed design built in ``<design>-fixed/``.
"""
from __future__ import annotations

import copy
import math
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import designfile, pipeline
from ..checks.base import failing
from ..atomic import write_text
from ..errors import InputError, echo, nearest
from ..params import Design, LoadedDesign
from ..sweep import spec as sweep_spec
from . import choose

FIXED, SUMMARY = "fixed.yaml", "summary.md"
SEARCH_TRIALS = 16          # a conflict's search: trials at the coupling level (no CAD), then the round builds it
EXCESS_CAP = 10.0


@dataclass
class Change:
    path: str
    value: Any
    old: Any
    checks: list[str]            # the checks whose fixes set it ("tendon.taut C1")
    note: str
    relax: bool
    round: int


@dataclass
class Round:
    index: int
    applied: dict[str, Any]
    before: list[str]            # the errors failing before it
    after: list[str]             # after it
    kept: bool
    searched: list[str] = field(default_factory=list)
    alone: bool = False          # the fixes that passed their checks in the round before, undone, again alone


@dataclass
class Fixed:
    folder: Path
    changes: list[Change]
    before: list[dict]           # the design's failing checks as written (errors and warnings)
    after: list[dict]            # the fixed design's
    passed: bool
    build_folder: Path | None
    left: dict[str, list[str]]   # per error still failing, why no option of it was applied
    rounds: list[Round]
    builds: int
    seconds: float
    files: list[Path]
    stiffening: dict = field(default_factory=dict)   # stiffening.tip and .torsion: (before, after, floor)


def check_paths(given: tuple[str, ...], option: str, source) -> None:
    """``--keep`` and ``--allow-relax`` paths: each must parse and start at a section of the design."""
    for text in given:
        try:
            keys = designfile.parse_path(text)
        except ValueError as e:
            raise InputError("command line", option, str(e)) from None
        if keys[0] not in Design.model_fields:
            close = nearest(str(keys[0]), list(Design.model_fields))
            raise InputError("command line", option, f"{echo(text)} is not a field of the design {source}"
                                                     + (f"; did you mean {close}?" if close else ""))


def _errors(report: dict) -> list[dict]:
    return failing(report.get("checks", []))


def _failing(report: dict) -> list[dict]:
    return [c for c in report.get("checks", []) if not c["passed"]]


def _score(report: dict) -> tuple[int, float]:
    """How far a design is from passing: its failing errors, then how far past their limits (the
    tune engine's relative measure, each at most :data:`EXCESS_CAP`)."""
    total = 0.0
    for c in _errors(report):
        m, lim = c.get("measured"), c.get("limit")
        if isinstance(m, (int, float)) and isinstance(lim, (int, float)) and math.isfinite(m):
            total += min(abs(m - lim) / max(abs(lim), 1e-9), EXCESS_CAP)
        else:
            total += 1.0
    return len(_errors(report)), total


class Fixer:
    """One `hwgen fix` run: the design, its changes so far, and the builds."""

    def __init__(self, loaded: LoadedDesign, out_root: Path, cache=True, jobs: int | None = None):
        self.loaded = loaded
        self.folder = Path(out_root) / "fixes" / loaded.name
        self.name = f"{loaded.name}-fixed" if len(loaded.name) <= 57 else "fixed"
        self.dump = loaded.design.model_dump(mode="json")       # every value, defaults filled in
        self.cache, self.jobs = cache, pipeline.default_jobs() if jobs is None else jobs
        self.builds = 0

    def old(self, path: str):
        try:
            return designfile.value_at(self.dump, designfile.parse_path(path))
        except KeyError:
            return None

    def doc(self, changes: dict[str, Change]) -> dict:
        """The merged design document with the changes applied."""
        doc = self.loaded.layers.doc
        for c in changes.values():
            doc = sweep_spec.set_path(doc, designfile.parse_path(c.path), c.value)
        return doc

    def current(self, changes: dict[str, Change], paths) -> dict[str, Any]:
        """path -> the design's value there now (the changes so far, else as written or defaulted)."""
        return {p: changes[p].value if p in changes else self.old(p) for p in paths}

    def build(self, changes: dict[str, Change]) -> tuple[dict, Path]:
        """fixed.yaml with ``changes`` written, built and checked: (its report, its build's folder)."""
        with pipeline.output_errors(self.folder.parent.parent):          # OUT: bad input naming --out
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text(self.folder / FIXED, fixed_text(self, list(changes.values())))
        loaded = pipeline.load(self.folder / FIXED)
        result = pipeline.build(loaded, self.folder, cache_dir=self.cache, jobs=self.jobs)
        self.builds += 1
        return result.report or {"checks": []}, result.folder


def fix(loaded: LoadedDesign, out_root: Path, keep: tuple[str, ...] = (), relax: tuple[str, ...] = (),
        budget: int = 8, search_with: dict | None = None, cache=True, on_round=None) -> Fixed:
    """The rounds (see the module's docstring). ``search_with``: the tune engine's scheduler and
    workers for a conflict's search; ``on_round(done, budget, words)`` follows the builds."""
    start = time.monotonic()
    fx = Fixer(loaded, out_root, cache)
    say = on_round or (lambda *a: None)
    say(0, budget, "building the design as written")
    report, folder = fx.build({})
    before, first = _failing(report), report
    changes: dict[str, Change] = {}
    best = (report, folder, dict(changes))
    rounds: list[Round] = []
    spent: set = set()
    left: dict[str, list[str]] = {}
    retry: list[choose.Option] = []
    while _errors(best[0]) and fx.builds < budget:
        failing = _errors(best[0])
        if retry:                       # after an undone round: what passed its check there, alone
            picked, retrying, retry = choose.combine(retry), True, []
        else:
            paths = {p for c in failing for o in choose.options(c) for p in o.set}
            picked, left = choose.pick(failing, fx.current(changes, paths), keep, relax, spent)
            retrying = False
        if not picked.values:
            break
        searched = []
        if picked.conflicts:
            found = search(fx, changes, picked, len(rounds) + 1, search_with or {})
            picked.values.update(found)
            searched = sorted(picked.conflicts)
        trial = dict(changes)
        for p, v in picked.values.items():
            why = picked.why[p]
            trial[p] = Change(p, v, changes[p].old if p in changes else fx.old(p), [o.check for o in why],
                              "; ".join(dict.fromkeys(o.note for o in why if o.note)), any(o.relax for o in why),
                              len(rounds) + 1)
        say(fx.builds, budget, f"round {len(rounds) + 1}: {len(picked.values)} value(s) for {len(failing)} failing "
                               f"check(s)")
        report, folder = fx.build(trial)
        kept = _score(report) < _score(best[0])
        rounds.append(Round(len(rounds) + 1, picked.values, [choose.check_name(c) for c in failing],
                            [choose.check_name(c) for c in _errors(report)], kept, searched, retrying))
        still = {choose.check_name(c) for c in _errors(report)}
        applied = list({o.key: o for os_ in picked.why.values() for o in os_}.values())
        spent |= {o.key for o in applied if o.check in still or (not kept and retrying)}
        helped = [o for o in applied if o.check not in still]
        if not kept and not retrying and helped and len(applied) > 1:
            # one of the others broke the round: these again alone (every one passed its check: the first
            # half of them, the rest left for later rounds)
            retry = helped if len(helped) < len(applied) else helped[:max(1, len(helped) // 2)]
        elif not kept:
            spent |= {o.key for o in helped}
        if kept:
            changes = trial
            best = (report, folder, dict(changes))
    report, folder, changes = best
    if fx.builds and folder is not None and (fx.folder / FIXED).read_text() != fixed_text(fx, list(changes.values())):
        report, folder = fx.build(changes)          # the last round was undone: the best built again
    if _errors(report):
        failing = _errors(report)
        paths = {p for c in failing for o in choose.options(c) for p in o.set}
        _, left = choose.pick(failing, fx.current(changes, paths), keep, relax, spent)
    out = Fixed(folder=fx.folder, changes=list(changes.values()), before=before, after=_failing(report),
                passed=not _errors(report), build_folder=folder, left=left, rounds=rounds, builds=fx.builds,
                seconds=time.monotonic() - start, files=[fx.folder / FIXED, fx.folder / SUMMARY],
                stiffening=_stiffening(first, report))
    write_text(fx.folder / SUMMARY, summary(fx, out))
    return out


def _stiffening(before: dict, after: dict) -> dict:
    """What the robot is for, before and after: each stiffening check's value and floor."""
    def of(report):
        return {c["id"]: c for c in report.get("checks", []) if c["id"].startswith("stiffening.")}
    b, a = of(before), of(after)
    return {k: (b[k].get("measured") if k in b else None, c.get("measured"), c.get("limit")) for k, c in a.items()}


def search(fx: Fixer, changes: dict[str, Change], picked: choose.Picked, index: int, with_: dict) -> dict[str, Any]:
    """Values for the paths two options set differently: a tune over them (free between the values
    the options name, the others of the round applied, goal pass with the conflicting checks required, the coupling
    level: no CAD), the
    passing design nearest the design before the round; where no trial passes, each path's value farthest from the
    design's (the stronger change). Written under ``search/``."""
    import yaml

    from ..tune import best as tune_best
    from ..tune import spec as tune_spec
    where = fx.folder / "search" / f"round-{index}"
    shutil.rmtree(where, ignore_errors=True)            # an earlier run's: another design, another search
    where.mkdir(parents=True, exist_ok=True)
    base = dict(changes)
    for p, v in picked.values.items():
        if p not in picked.conflicts:                   # a conflict's path: the design's value, searched from
            base[p] = Change(p, v, fx.old(p), [], "", False, index)
    write_text(where / "base.yaml", fixed_text(fx, list(base.values())))
    free = []
    for p, values in picked.conflicts.items():
        nums = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if len(nums) == len(values) and min(nums) < max(nums):
            whole = all(isinstance(v, int) for v in nums)
            free.append({"path": p, "low": min(nums), "high": max(nums), **({"integer": True} if whole else {})})
        else:
            free.append({"path": p, "choices": list(values)})
    spec = {"tune": f"fix-{index}", "base": str((where / "base.yaml").resolve()), "level": "coupling",
            "budget": SEARCH_TRIALS, "robust_samples": 200, "free": free,
            # the checks whose fixes conflict must pass (the round's build judges the rest: at this level
            # eq. (2) through the hole centres counts as a failure, where the build reports it as information)
            "goal": {"pass": True, "checks": "required",
                     "require": sorted({o.check.split()[0] for p in picked.conflicts for o in picked.why[p]})}}
    write_text(where / "tune.yaml", yaml.safe_dump(spec, sort_keys=False, allow_unicode=True))
    loaded = tune_spec.load(where / "tune.yaml")
    t = tune_best.tune(loaded, where, with_.get("scheduler"), with_.get("workers"), None, fx.cache, build=False)
    if t.best is not None:                   # four figures: a value a lab sets (and the tune's own, to 0.1 %)
        return {n: float(f"{v:.4g}") if isinstance(v, float) else v for n, v in zip(loaded.names, t.best["values"])}
    out = {}
    for p, values in picked.conflicts.items():
        now = fx.old(p)
        nums = isinstance(now, (int, float)) and all(isinstance(v, (int, float)) for v in values)
        out[p] = max(values, key=lambda v: abs(v - now)) if nums else values[0]
    return out


# ---------------------------------------------------------------- what it writes

def _comment(c: Change) -> str:
    what = "relaxes a requirement (--allow-relax)" if c.relax else "fixes"
    return f"hwgen fix, round {c.round}: {what} {', '.join(dict.fromkeys(c.checks)) or 'the search'}; was {_value(c.old)}"


def _value(v) -> str:
    if v is None:
        return "unset (hwgen's default)"
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def fixed_text(fx: Fixer, changes: list[Change]) -> str:
    """fixed.yaml: the user's file with each change written and its comment (a list the file leaves
    to its base, such as ``tendons``, written whole: a list replaces the base's)."""
    values: dict[str, tuple[Any, str]] = {}
    own = fx.loaded.layers
    lists: dict[str, list[Change]] = {}
    for c in changes:
        keys = designfile.parse_path(c.path)
        cut = next((i for i, k in enumerate(keys) if isinstance(k, int)), None)
        if cut is not None and own.origin(tuple(keys[:cut])) != 0:
            lists.setdefault(designfile.dotted(keys[:cut]), []).append(c)
        else:
            values[c.path] = (_plain(c.value), _comment(c))
    doc = fx.doc({c.path: c for c in changes})
    for path, cs in lists.items():
        whole = copy.deepcopy(designfile.value_at(doc, designfile.parse_path(path)))
        values[path] = (whole, "; ".join(f"{c.path.removeprefix(path)}: {_comment(c)}" for c in cs))
    head = (f"hwgen fix: {Path(fx.loaded.source).name} with {len(changes)} value(s) changed so that its checks pass "
            f"(summary.md says why each); renamed {fx.name} so that its build does not replace the design's")
    return designfile.rewritten(fx.loaded.source, values, fx.name, head)


def _plain(v):
    return float(v) if hasattr(v, "item") and not isinstance(v, (int, float, bool)) else v


def summary(fx: Fixer, f: Fixed) -> str:
    """summary.md: the verdict, each change and why, the rounds, the checks before and after, what is left."""
    name = fx.loaded.name
    verdict = "every check passes" if f.passed else f"{len(failing(f.after))} error(s) still fail"
    out = [f"# hwgen fix: {name}", "",
           f"**{'PASS' if f.passed else 'FAIL'}**: {verdict} after {len(f.changes)} change(s), {f.builds} design(s) "
           f"built and checked in {f.seconds:.0f} s; `{FIXED}` is the design with them, built in "
           f"`{f.build_folder.name if f.build_folder else '-'}/`.", "", "## Changes", ""]
    if f.changes:
        out += ["| value | was | now | fixes | relaxation | why |", "|---|---|---|---|---|---|"]
        out += [f"| `{c.path}` | {_value(c.old)} | {_value(c.value)} | {', '.join(dict.fromkeys(c.checks))} | "
                f"{'yes (--allow-relax)' if c.relax else 'no'} | {c.note} |" for c in f.changes]
    else:
        out.append("None kept.")
    for cid, (was, now, floor) in f.stiffening.items():
        if isinstance(now, (int, float)) and isinstance(floor, (int, float)):
            first = f"{was:.3g}×" if isinstance(was, (int, float)) else "not measured"
            out += ["", f"{cid}: {first} as written, {now:.3g}× fixed, floor {floor:g}×"
                        + (" (under it: the check fails)" if now < floor else "")]
    out += ["", "## Rounds", ""]
    for r in f.rounds:
        out.append(f"{r.index}. set {', '.join(f'`{p}` {_value(v)}' for p, v in r.applied.items())}"
                   + (f" (searched with the tune engine: {', '.join(r.searched)})" if r.searched else "")
                   + (" (again alone: they passed their checks in the round undone before)" if r.alone else "")
                   + f": {len(r.before)} error(s) failing before, {len(r.after)} after"
                   + ("" if r.kept else " — no better: undone, and these fixes not applied again") + ".")
    out += ["", "## Checks before and after", "", "| check | before | after |", "|---|---|---|"]
    after = {_key(c): c for c in f.after}
    for c in f.before:
        a = after.pop(_key(c), None)
        out.append(f"| {choose.check_name(c)} | {_state(c)} | {_state(a)} |")
    for c in after.values():
        out.append(f"| {choose.check_name(c)} | passes | {_state(c)} |")
    if f.left:
        out += ["", "## What is left", ""]
        for check, why in f.left.items():
            out.append(f"- {check}: " + ("; ".join(why) if why else "no fix left to apply"))
    return "\n".join(out) + "\n"


def _key(c: dict) -> tuple:
    return (c["id"], choose.check_name(c))


def _state(c: dict | None) -> str:
    if c is None:
        return "passes"
    m = c.get("measured")
    got = f"{m:.4g}" if isinstance(m, (int, float)) else "-"
    lim = c.get("limit")
    return f"fails ({c['severity']}): {got} against {lim:.4g}" if isinstance(lim, (int, float)) else \
        f"fails ({c['severity']}): {got}"
