"""The commands over many designs: sweep and tune, on Dask, and fix, which builds design after design."""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import typer
from rich.table import Table

from ..atomic import write_json
from ..checks.base import failing
from ..errors import InputError, printable
from .common import (CACHE_DIR, EXIT_FINDINGS, NO_CACHE, SCHEDULER, WORKERS, _cache, _check_scheduler, _command, _load,
                     err, out, say)


# each command's figures, beside its results, for the bench and for scripts (the terminal's lines are for people)
RUN_JSON = "run.json"


@_command
def sweep(sweep_file: Path = typer.Argument(..., help="sweep YAML: a base design and axes over its parameters",
                                            show_default=False),
          out_dir: Path = typer.Option(Path("out"), "--out", help="output root; results go to OUT/sweeps/<name>/<level>/"),
          scheduler: str = SCHEDULER, workers: int = WORKERS,
          quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
          cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """Evaluate every variant of a design sweep on Dask: Parquet results, a summary and plots.

    Levels: lengths (the plan, eq. (2) and the taut path; no CAD), robust (the as-built Monte Carlo), coupling (tendon tensions and the actuating tension's rise), build (every file and hwgen check). A rerun skips the variants already in the results. Bad or failing variants are rows with their message; exit 2 only for a bad sweep file.
    """
    from ..sweep import run as sweep_run
    from ..sweep import spec, summary

    _check_scheduler(scheduler)
    loaded = spec.load(sweep_file)
    # Dask's progress bar redraws one line: on a terminal only (a log would get a line per redraw)
    try:
        o = sweep_run.run(loaded, out_dir, scheduler, workers, progress=not quiet and sys.stdout.isatty(),
                          cache=_cache(cache_dir, no_cache))
    except KeyboardInterrupt:
        say("interrupted:", "yellow", f"the batches finished so far are kept in "
                                      f"{sweep_run.results_folder(loaded, out_dir)}; the same command goes on from them")
        raise typer.Exit(130) from None
    table = sweep_run.read(o.folder)
    files = summary.write(loaded, table, o.folder.parent / loaded.spec.level) if table is not None else []
    if o.seconds > 0 and o.evaluated:
        per_s = o.evaluated / o.seconds
        rate = f"{per_s:,.1f} variants/s" if per_s >= 10 else f"{per_s:.3g} variants/s ({1 / per_s:.1f} s a variant)"
    else:
        rate = "nothing to evaluate"
    cpu = f", {1000 * o.cpu_s / o.evaluated:.2f} ms CPU per variant" if o.evaluated else ""
    start = f"; local cluster started in {o.start_seconds:.1f} s" if o.start_seconds else ""
    out.print(f"{loaded.spec.sweep} ({loaded.spec.level}): {o.total} variants, {o.done_before} already in the results, "
              f"{o.evaluated} evaluated in {o.seconds:.2f} s on {o.workers} worker(s): {rate}{cpu}{start}")
    write_json(o.folder / RUN_JSON, {
        "command": "sweep", "variants": o.total, "done_before": o.done_before, "evaluated": o.evaluated,
        "seconds": o.seconds, "workers": o.workers, "start_seconds": o.start_seconds, "cpu_s": o.cpu_s,
        "verdicts": o.verdicts})
    files = [o.folder / RUN_JSON, *files]
    if table is not None:
        counts = {}
        for v in table.column("verdict").to_pylist():
            counts[v] = counts.get(v, 0) + 1
        out.print("verdicts: " + ", ".join(f"{k} {n}" for k, n in sorted(counts.items())))
        col, label = summary.figure_column(table)
        figs = [col] + [c for c in ("robust_mm", "centre_mm") if c != col] + ["clearance_mm", "mass_g"]
        t = Table(title=f"best variants (by {label})")
        for c in ("variant", *loaded.names, "verdict", *figs):
            t.add_column(c, justify="left" if c == "verdict" else "right")
        for r in summary.best(loaded, table, min(loaded.spec.summary.best, 10)):
            t.add_row(str(r["variant"]), *(printable(str(r[n])) for n in loaded.names), r["verdict"],
                      *("-" if r.get(c) is None else f"{r[c]:.4g}" for c in figs))
        out.print(t)
    out.print(f"  {printable(o.folder)}/ (Parquet)")
    for f in files:
        out.print(f"  {printable(f)}")


@_command
def tune(tune_file: Path = typer.Argument(..., help="tune YAML (a base design, free parameters with bounds, a goal), "
                                                    "or a design YAML with --goal", show_default=False),
         goal: str = typer.Option(None, "--goal", show_default=False,
                                  help="with a design file: stiffness, torsion or pass, over the space derived from "
                                       "the design (its stiffening tendons' routing, pre-tension and termination)"),
         out_dir: Path = typer.Option(Path("out"), "--out", help="output root; results go to OUT/tunes/<name>/"),
         scheduler: str = SCHEDULER, workers: int = WORKERS,
         budget: int = typer.Option(None, "--budget", min=1, show_default=False,
                                    help="trials in all, those of an earlier run included (default: the tune "
                                         "file's budget)"),
         seed: int = typer.Option(None, "--seed", min=0, max=2**32 - 1, show_default=False,
                                  help="the search's seed (default: the tune file's, 0 for a design file); one seed "
                                       "draws the same trials whatever the workers' timing"),
         no_build: bool = typer.Option(False, "--no-build", help="do not build the best design"),
         quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
         cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """Search a design's parameters for the best one (Optuna on the sweep's Dask workers): trials.parquet, best.yaml, summary.md, convergence.png, and the best built and checked.

    Goals: maximize or minimize results of the statics or the checks subject to every check of the level passing (several: a Pareto front), or pass (the passing design nearest the base). A design file with --goal stiffness|torsion|pass: the space derived from the design (hwgen.tune.derive), the tip's torsion (or stiffness) and least disk stiffness kept at least the design's own. A rerun goes on from the trials already told. Exit 1 when no trial passes or the best's build fails a check; exit 2 for a bad tune file.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from ..tune import best as tune_best
    from ..tune import run as tune_run
    from ..tune import spec as tune_spec

    from ..tune import derive

    _check_scheduler(scheduler)
    if derive.is_design(tune_file):
        if goal is None:
            raise InputError(tune_file, "--goal", f"a design file is tuned toward a goal: give --goal "
                                                  f"{'|'.join(derive.GOALS)} (or write a tune file)")
        loaded = derive.load(tune_file, goal, budget, seed=seed or 0)
    elif goal is not None:
        raise InputError(tune_file, "--goal", "--goal is for a design file; a tune file states its own goal")
    else:
        loaded = tune_spec.load(tune_file)
        if seed is not None:
            loaded = dataclasses.replace(loaded, spec=loaded.spec.model_copy(update={"seed": seed}))
    with Progress(TextColumn("{task.description}", markup=False), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=err, disable=quiet or not err.is_terminal, transient=True) as bar:
        task = bar.add_task(f"tuning {loaded.spec.tune}", total=budget or loaded.spec.budget)
        try:
            t = tune_best.tune(loaded, out_dir, scheduler, workers, budget, _cache(cache_dir, no_cache),
                               build=not no_build, on_trial=lambda done, total: bar.update(task, completed=done,
                                                                                          total=total))
        except KeyboardInterrupt:
            say("interrupted:", "yellow", f"the trials told so far are kept in "
                                          f"{tune_run.folder_of(loaded, out_dir)}; the same command goes on from them")
            raise typer.Exit(130) from None
    o = t.outcome
    rate = f"{o.evaluated / o.seconds:.3g} trials/s" if o.seconds > 0 and o.evaluated else "nothing to evaluate"
    per = o.cpu_s / o.evaluated if o.evaluated else 0.0
    cpu = (f", {per:.2f} s CPU a trial" if per >= 0.1 else f", {1000 * per:.2f} ms CPU a trial") if o.evaluated else ""
    if o.whole and o.whole < o.evaluated:
        cpu += f" ({o.whole_cpu_s / o.whole:.2f} s each of the {o.whole} through every level)"
    start = f"; local cluster started in {o.start_seconds:.1f} s" if o.start_seconds else ""
    out.print(f"{loaded.spec.tune} ({loaded.spec.level}): {o.done_before} trials told before, {o.evaluated} evaluated "
              f"and {o.repeated} told from an earlier trial of the same design in {o.seconds:.1f} s on {o.workers} "
              f"worker(s): {rate}{cpu}{start}", soft_wrap=True)     # one line on a pipe too: the bench reads it
    best = None if t.best is None else {
        "trial": t.best["trial"], "objectives": dict(zip((n for n, _ in loaded.objectives), t.best["objectives"])),
        "found_s": o.first_best_s if t.best["trial"] >= 0 else None}
    write_json(o.folder / RUN_JSON, {
        "command": "tune", "level": loaded.spec.level, "done_before": o.done_before, "evaluated": o.evaluated,
        "repeated": o.repeated, "seconds": o.seconds, "workers": o.workers, "start_seconds": o.start_seconds,
        "cpu_s": o.cpu_s, "whole": o.whole, "whole_cpu_s": o.whole_cpu_s, "best": best,
        "build_ok": t.build_ok})
    if t.best is None:
        say("no trial passes;", "red", f"see {printable(o.folder / 'summary.md')}")
    else:
        objs = ", ".join(f"{n} {v:.4g}" for (n, _), v in zip(loaded.objectives, t.best["objectives"]))
        base = t.best["trial"] < 0
        found = f" (found {o.first_best_s:.1f} s into this run)" if o.first_best_s is not None and not base else ""
        who = "the base itself (trial -1), no trial passes further" if base else f"trial {t.best['trial']}"
        out.print(f"best: {who}: {objs}{found}" + (f"; front of {len(t.front)}" if len(t.front) > 1
                                                                     and len(loaded.objectives) > 1 else ""),
                  soft_wrap=True)
    for f in [*t.files, o.folder / RUN_JSON]:
        out.print(f"  {printable(f)}")
    if t.build_folder is not None:
        out.print(f"  {printable(t.build_folder)}/ (the best, built: "
                  + ("every check passes)" if t.build_ok else f"{len(t.failed_checks)} check(s) fail)"))
    if t.best is None or t.build_ok is False:
        raise typer.Exit(EXIT_FINDINGS)




@_command
def fix(params: Path = typer.Argument(..., help="design parameter YAML that fails its checks", show_default=False),
        keep: list[str] = typer.Option([], "--keep", help="a parameter path never changed (a section, or a field "
                                                          "below it; tendons.pretension_n: every tendon's); repeat",
                                       show_default=False),
        allow_relax: list[str] = typer.Option([], "--allow-relax", help="a relaxation that may be applied, by the "
                                                                        "path it sets (check.robust_severity, "
                                                                        "tendons.budget_mm); repeat",
                                              show_default=False),
        budget: int = typer.Option(8, "--budget", min=1, help="designs built and checked at most, the design as "
                                                              "written included"),
        out_dir: Path = typer.Option(Path("out"), "--out", help="output root; results go to OUT/fixes/<design>/"),
        scheduler: str = SCHEDULER, workers: int = WORKERS,
        quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
        cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """The nearest design that passes every check, from the failing checks' tried fixes: fixed.yaml (your file, its comments and base kept, each change commented), summary.md, and the fixed design built.

    Round by round: every failing check's first fix applied, the design built and checked again, a round that does not help undone. Fixes that set one value two ways are searched with the tune engine (--scheduler, --workers as hwgen tune). A --keep path is never changed; a relaxation (a severity, a budget, a limit) only where --allow-relax names it. Exit 0 when the fixed design passes, 1 when the nearest found still fails (summary.md says what is left), 2 for bad input.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from ..fix import run as fixing

    _check_scheduler(scheduler)
    loaded = _load(params)
    fixing.check_paths(tuple(keep), "--keep", params)
    fixing.check_paths(tuple(allow_relax), "--allow-relax", params)
    with Progress(TextColumn("{task.description}", markup=False), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=err, disable=quiet or not err.is_terminal, transient=True) as bar:
        task = bar.add_task(f"fixing {loaded.name}", total=budget)
        f = fixing.fix(loaded, out_dir, tuple(keep), tuple(allow_relax), budget,
                       {"scheduler": scheduler, "workers": workers}, _cache(cache_dir, no_cache),
                       on_round=lambda done, total, words: bar.update(task, completed=done, total=total,
                                                                      description=words))
    for c in f.changes:
        out.print(f"  {c.path}: {fixing._value(c.old)} -> {fixing._value(c.value)} ({', '.join(dict.fromkeys(c.checks))}"
                  + (", a relaxation" if c.relax else "") + ")", soft_wrap=True, markup=False)
    write_json(f.folder / RUN_JSON, {
        "command": "fix", "passed": f.passed, "changes": len(f.changes), "builds": f.builds, "seconds": f.seconds,
        "failing": [fixing.choose.check_name(c) for c in failing(f.after)]})
    if f.passed:
        out.print(f"{loaded.name}: PASS after {len(f.changes)} change(s), {f.builds} design(s) built in "
                  f"{f.seconds:.0f} s", soft_wrap=True)
    else:
        say("FAIL:", "red", f"{loaded.name}: the nearest design found still fails "
                            f"{', '.join(fixing.choose.check_name(c) for c in failing(f.after))}; "
                            f"see {printable(f.folder / fixing.SUMMARY)}")
    for p in [*f.files, f.folder / RUN_JSON]:
        out.print(f"  {printable(p)}")
    if f.build_folder is not None:
        out.print(f"  {printable(f.build_folder)}/ (the fixed design, built)")
    if not f.passed:
        raise typer.Exit(EXIT_FINDINGS)
