"""A tune whole: run it, write its results, build the best (``hwgen build`` and ``hwgen check``)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .. import pipeline
from ..checks.base import failing
from . import report, results, run as tune_run
from .spec import Loaded


@dataclass
class Tuned:
    outcome: tune_run.Outcome
    best: dict | None
    front: list
    files: list
    build_ok: bool | None         # the best's build passes its checks (None: nothing built)
    build_folder: Path | None
    failed_checks: list


def _stiffness(loaded: Loaded, best_design) -> dict | None:
    """Every tendon state's figures of the base and the best (the plans' masses), when the goal reads the statics."""
    if not loaded.states:
        return None
    from ..sweep.spec import resolve_doc
    base = resolve_doc(loaded.base, -1, (), "base").design
    out = {}
    for key, d in (("base", base), ("best", best_design)):
        plan = pipeline.design_plan(_loaded(d, key))
        g = loaded.spec.goal
        out[key] = results.figures(plan, None, g.orientation, g.friction)
    return out


def _loaded(design, source: str):
    from ..params import LoadedDesign
    return LoadedDesign(design=design, source=source, sha256="")


BUILD_TRIES = 3        # the best feasible designs built, in order, until one passes hwgen check


def tune(loaded: Loaded, out_root: Path, scheduler: str | None = None, workers: int | None = None,
         budget: int | None = None, cache=True, build: bool = True, on_trial=None) -> Tuned:
    """Run the tune, write its results, and build the best whole (``hwgen build`` and its checks)
    into ``OUT/tunes/<name>/build/<design>/``. A best whose build fails a check the tune's level
    does not screen for is set aside (kept in the study, said in summary.md) and the next best
    built, up to :data:`BUILD_TRIES` designs; the best named (best.yaml, summary.md) is always the
    last one built: when that one fails too, it stays the best named and the tune says it fails."""
    outcome, study = tune_run.run(loaded, out_root, scheduler, workers, budget, cache, on_trial)
    folder = outcome.folder
    written = report.write(loaded, study, folder, outcome)
    best = written["best"]
    if best is None or not build:
        return Tuned(outcome, best, written["front"], written["files"], None, None, [])
    lines: list[str] = []
    for attempt in range(BUILD_TRIES):
        best_loaded = pipeline.load(folder / "best.yaml")
        result = pipeline.build(best_loaded, folder / "build", cache_dir=cache, jobs=pipeline.default_jobs())
        checks = (result.report or {}).get("checks", [])
        failed = failing(checks)
        lines.append(f"Trial {best['trial']}: `hwgen build best.yaml`: {len(result.manifest.parts)} parts in "
                     f"`build/{best_loaded.name}/`; `hwgen check`: {len(checks)} checks, {len(failed)} failed"
                     + (": " + "; ".join(f"{c['id']}: {c['message']}" for c in failed[:5]) if failed else "") + ".")
        if not failed or attempt + 1 == BUILD_TRIES:
            break          # the best named is the last one built, passing or not
        rejected = {**study.user_attrs.get("rejected", {}), best["hash"]: sorted({c["id"] for c in failed})}
        if report.best(loaded, [written["base"], *written["rows"]], rejected)[0] is None:
            break          # nothing left to build: the failing one stays the best named
        study.set_user_attr("rejected", rejected)
        written = report.write(loaded, study, folder, outcome)
        best = written["best"]
        lines[-1] += " Set aside: the next best is built."
    stiff = _stiffness(loaded, best_loaded.design)
    written = report.write(loaded, study, folder, outcome, {"text": "\n\n".join(lines)}, stiff)
    return Tuned(outcome, written["best"], written["front"], written["files"], not failed, result.folder, failed)
