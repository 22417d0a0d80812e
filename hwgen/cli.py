"""The `hwgen` command line: build, check, render, routing, schema.

Exit codes: 0 success, 1 design findings that fail, 2 bad input or usage.
"""
from __future__ import annotations

import json
import sys
from contextlib import contextmanager, nullcontext
from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

from .errors import DesignError, InputError

EXIT_OK, EXIT_FINDINGS, EXIT_BAD_INPUT = 0, 1, 2

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Print files, checks and pictures for tendon-driven continuum robots.")
# piped output (CI logs, files) gets a page wide enough that tables do not wrap
out = Console(width=None if sys.stdout.isatty() else 160)
err = Console(stderr=True, width=None if sys.stderr.isatty() else 160)


def _mm(v: float) -> str:
    return f"{v + 0.0:.3f}"  # + 0.0 turns -0.0 into 0.0

PARAMS = typer.Argument(..., help="design parameter YAML", show_default=False)
OUT = typer.Option(Path("out"), "--out", help="output root; the design goes to OUT/<design>/")


def _bad_input(file, path: str, message: str) -> typer.Exit:
    err.print(f"[bold red]error:[/] {file}: [bold]{path or '<document>'}[/]: {message}",
              highlight=False, soft_wrap=True)
    return typer.Exit(EXIT_BAD_INPUT)


def _load(path: Path):
    from .pipeline import load
    try:
        loaded = load(path)
    except InputError as e:
        raise _bad_input(e.file, e.path, e.message) from None
    for w in loaded.warnings:
        err.print(f"[yellow]warning:[/] {w}", highlight=False, soft_wrap=True)
    return loaded


@contextmanager
def _design_errors(params: Path):
    """Parameters that pass the schema but make no buildable part are bad input too."""
    try:
        yield
    except DesignError as e:
        raise _bad_input(params, e.path, e.message) from None


@app.command()
def build(params: Path = PARAMS, out_dir: Path = OUT,
          quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar")) -> None:
    """Build every part (STL, STEP), assembly.step, the backbone DXF and manifest.json."""
    loaded = _load(params)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from .pipeline import build as run_build

    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=err, disable=quiet, transient=True) as bar:
        task = bar.add_task(f"building {loaded.design.design}", total=None)

        def progress(name: str, done: int, total: int) -> None:
            bar.update(task, total=total, completed=done, description=f"built {name}")

        with _design_errors(params):
            result = run_build(loaded, out_dir, progress)
    n = len(result.manifest["parts"])
    out.print(f"{loaded.design.design}: {n} parts written to {result.folder}", highlight=False)
    failed = [c for c in result.manifest.get("checks", []) if not c.get("passed", True)
              and c.get("severity") == "error"]
    if result.plan.findings:
        for f in result.plan.findings:
            err.print(f"[yellow]finding:[/] {f}", highlight=False)
    if result.manifest.get("render", {}).get("status") in ("unavailable", "failed"):
        err.print(f"[yellow]warning:[/] {result.manifest['render']['message']}", highlight=False)
    if failed:
        err.print(f"[red]{len(failed)} check(s) failed[/]; see {result.folder}")
        raise typer.Exit(EXIT_FINDINGS)


@app.command()
def routing(params: Path = PARAMS,
            as_json: bool = typer.Option(False, "--json", help="print JSON instead of tables")) -> None:
    """The eyelet table per station and tendon, merges, backbone crossings and table deviations."""
    loaded = _load(params)
    from .model.plan import plan as make_plan
    from .model.routing import table_deviations

    plan = make_plan(loaded.design)
    devs = table_deviations(plan.paths)
    if as_json:
        from .cad.manifest import design_report
        rep = design_report(plan)
        rep["deviations"] = [{"tendon": d.tendon, "station": d.station, "table": d.table,
                              "function": d.function, "distance_mm": d.distance} for d in devs]
        out.print_json(json.dumps(rep))
        return
    t = Table(title=f"{loaded.design.design}: eyelets (mm, disk frame at its mid-plane)")
    for col in ("i", "y", "tendons", "x", "z", "Ø", "worst α°", "note"):
        t.add_column(col, justify="right" if col not in ("tendons", "note") else "left")
    for d in plan.disks:
        for h in d.holes:
            note = []
            if len(h.tendons) > 1:
                note.append("shared")
            if h.in_slot:
                note.append("crosses backbone")
            t.add_row(str(d.index), f"{d.y:g}", ",".join(h.tendons), _mm(h.x), _mm(h.z),
                      f"{h.diameter:.3f}", f"{h.worst_angle_deg:.1f}", " ".join(note))
    out.print(t)
    if plan.merges:
        out.print("[bold]merged eyelets[/]")
        for m in plan.merges:
            out.print(f"  station {m.station}: {', '.join(m.tendons)} ({m.kind})", highlight=False)
    if plan.backbone.holes:
        out.print("[bold]backbone holes[/] (tendon crosses the strip)")
        for h in plan.backbone.holes:
            out.print(f"  {h.tendon} at station {h.station:g}: x={_mm(h.x)} y={_mm(h.y)} Ø{h.diameter:.3f}",
                      highlight=False)
    for f in plan.findings:
        out.print(f"[yellow]finding:[/] {f}", highlight=False)
    if plan.tensioner_error:
        out.print(f"[red]tensioner:[/] cannot be laid out: {plan.tensioner_error}", highlight=False)
    if devs:
        dt = Table(title="table versus function (mm)")
        for col in ("tendon", "i", "table x", "table z", "fn x", "fn z", "deviation"):
            dt.add_column(col, justify="right")
        for dv in devs:
            style = "red" if dv.distance > 0.1 else None
            dt.add_row(dv.tendon, str(dv.station), *(_mm(v) for v in (*dv.table, *dv.function, dv.distance)),
                       style=style)
        out.print(dt)


@app.command()
def check(params: Path = PARAMS, out_dir: Path = OUT,
          report: Path = typer.Option(None, "--report", help="also write the JSON report here"),
          junit: Path = typer.Option(None, "--junit", help="also write JUnit XML here (one test case per check)"),
          verbose: bool = typer.Option(False, "--verbose", "-v", help="list every check, not only findings"),
          quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar")) -> None:
    """Measure the built files: eyelets, tendon lengths over the bending sweep, clearances, parts.

    Builds first only when the outputs are missing or made from other parameters; part files edited since the build are measured as they are. Exit 1 when a check fails.
    """
    loaded = _load(params)
    from .atomic import write_json
    from .checks.report import print_report, write_junit
    from .pipeline import check as check_design

    rep, folder = _on_outputs(params, f"checking {loaded.design.design}", quiet,
                              lambda: check_design(loaded, out_dir))
    print_report(rep, out, verbose=verbose)
    if report is not None:
        write_json(report, rep)
    if junit is not None:
        write_junit(rep, junit)
    if not rep["ok"]:
        raise typer.Exit(EXIT_FINDINGS)


@app.command()
def render(params: Path = PARAMS, out_dir: Path = OUT,
           quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner")) -> None:
    """Pictures (exploded, assembled, bent PNG), the exploded SVG drawing and the bill of materials.

    Builds first only when the outputs are missing or made from other parameters. Needs no display or GPU; exit 1 when no offscreen OpenGL backend works (the message says what to install).
    """
    loaded = _load(params)
    from .pipeline import render as render_design

    entry, folder = _on_outputs(params, f"drawing {loaded.design.design}", quiet,
                                lambda: render_design(loaded, out_dir))
    out.print(f"{loaded.design.design}: bom.csv, bom.md written to {folder}", highlight=False)
    if entry.get("status") != "ok":
        err.print(f"[yellow]warning:[/] {entry.get('message', 'pictures not drawn')}", highlight=False)
        raise typer.Exit(EXIT_FINDINGS)
    for name, f in entry["files"].items():
        size = f" ({f['width']} × {f['height']} px)" if "width" in f else ""
        out.print(f"  {folder / name}{size}", highlight=False)


def _on_outputs(params: Path, doing: str, quiet: bool, run):
    """Run a step on a design's outputs (it builds them first when they are missing or stale):
    a spinner while it works, design errors reported as bad input, and a word when it rebuilt.
    ``run()`` returns (result, folder, why it rebuilt or None)."""
    with err.status(doing, spinner="dots") if not quiet else nullcontext(), _design_errors(params):
        result, folder, rebuilt = run()
    if rebuilt:
        err.print(f"built {folder} first ({rebuilt})", highlight=False)
    return result, folder


@app.command()
def schema() -> None:
    """Print the JSON Schema of the parameter YAML (for editors)."""
    from .params import json_schema
    sys.stdout.write(json.dumps(json_schema(), indent=2) + "\n")


def main() -> None:
    # standalone mode: typer.Exit(code) exits with that code, usage errors exit 2
    app()


if __name__ == "__main__":
    main()
