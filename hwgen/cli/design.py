"""The commands on one design: build, routing, check, render, coupon, plates, stiffness, sim, schema."""
from __future__ import annotations

import json
import sys
from contextlib import nullcontext
from pathlib import Path

import typer
from rich.table import Table
from rich.text import Text

from ..checks.base import failing
from ..errors import InputError, printable
from ..sim import limits
from .common import (CACHE_DIR, CACHE_SIZE, EXIT_FINDINGS, NO_CACHE, OUT, PARAMS, _cache, _command, _load, _options,
                     _mm, _on_outputs, _write_side_file, err, out, say)


@_command
def build(params: Path = PARAMS, out_dir: Path = OUT,
          quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
          cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE, cache_size: str = CACHE_SIZE,
          parts: str = typer.Option(None, "--parts", show_default=False,
                                    help="write only the parts whose names match this pattern ('disk_*'); "
                                         "no assembly, checks or pictures"),
          jobs: int | None = typer.Option(None, "--jobs", "-j", min=0, envvar="HWGEN_JOBS", show_default=False,
                                   help="worker processes that build the parts not in the cache and the assembly "
                                        "(default: one per core, at most 4, no more than there are parts to "
                                        "build; 0: in this process, which then holds the CAD kernel's memory "
                                        "through the checks)")
          ) -> None:
    """Build every part (STL, STEP), assembly.step, the backbone DXF and manifest.json."""
    if jobs != 0 and not _built_before(params, out_dir):
        from ..engine import start_server
        start_server()              # the workers' server imports CadQuery while the design is read and planned
    loaded = _load(params)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from ..pipeline import build as run_build, default_jobs

    with Progress(TextColumn("{task.description}", markup=False), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=err, disable=quiet, transient=True) as bar:
        task = bar.add_task(f"building {loaded.name}", total=None)

        def progress(name: str, done: int, total: int) -> None:
            bar.update(task, total=total, completed=done, description=f"built {name}")

        options = _options(cache_size, default_jobs() if jobs is None else jobs)
        result = run_build(loaded, out_dir, progress, cache_dir=_cache(cache_dir, no_cache), parts=parts,
                           options=options)
    n = len(result.manifest.parts)
    for note in result.notes:
        say("warning:", "yellow", note)
    if parts is not None:
        written = result.manifest.parts_written["names"]
        out.print(f"{loaded.name}: {len(written)} of {n} parts written to {printable(result.folder)} "
                  f"({n - len(result.built)} from the part cache); no assembly, checks or pictures")
        return
    reused = f" ({n - len(result.built)} from the part cache)" if len(result.built) < n else ""
    out.print(f"{loaded.name}: {n} parts written to {printable(result.folder)}{reused}")
    failed = failing(result.manifest.checks)
    for f in result.plan.findings:
        say("finding:", "yellow", f)
    if (result.manifest.render or {}).get("status") in ("unavailable", "failed"):
        say("warning:", "yellow", result.manifest.render["message"])
    _view_notes(result.manifest.view)
    if result.report is not None:
        _verdict(result.report, result.folder, loaded)
    if failed:
        raise typer.Exit(EXIT_FINDINGS)


def _view_notes(view: dict | None) -> None:
    """What view.html could not show (no viewer, a part drawn as its box), as warnings."""
    for message in (view or {}).get("messages", []):
        say("warning:", "yellow", f"view.html: {message}")


def _built_before(params: Path, out_dir: Path) -> bool:
    """Whether a design folder under ``out_dir`` was built from these very bytes of ``params`` by
    this hwgen (a rebuild then likely finds every part in the cache and needs no worker); read
    from the manifests alone, before the design is."""
    from .. import __version__
    from ..designfile import read_layers
    try:
        sha = read_layers(params).sha256           # of the file and the bases it builds on
        manifests = list(Path(out_dir).glob("*/manifest.json"))
    except (OSError, InputError):
        return True                 # the load says what is wrong; no worker for that
    for path in manifests:
        try:
            m = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(m, dict) and m.get("params_sha256") == sha and m.get("hwgen_version") == __version__:
            return True
    return False


def _verdict(report: dict, folder: Path, loaded) -> None:
    """What `hwgen build` and `hwgen check` end with: a line per failed check with its fix, the
    warnings, then the verdict naming summary.md and any setting of the design (and its file)
    that states a failing check as a warning."""
    from ..checks.report import verdict_lines
    from ..designfile import NOT_INHERITED, dotted
    files = {dotted(k): str(loaded.layers.file_of(dotted(k))) for k in NOT_INHERITED}
    for label, text in verdict_lines(report, Path(folder) / "summary.md", files):
        if label == "verdict":
            word, rest = text.split(":", 1)
            out.print(Text.assemble(f"{report['design']}: ", (word, "bold green" if word == "PASS" else "bold red"),
                                    printable(":" + rest)), soft_wrap=True)
        else:
            say(label, "bold red" if label == "failed:" else "yellow", text, out)


@_command
def routing(params: Path = PARAMS,
            as_json: bool = typer.Option(False, "--json", help="print JSON instead of tables")) -> None:
    """The eyelet table per station and tendon, merges, backbone crossings and table deviations."""
    loaded = _load(params)
    from ..model.routing import table_deviations
    from ..pipeline import design_plan

    plan = design_plan(loaded)
    devs = table_deviations(plan.paths)
    if as_json:
        from ..cad.manifest import design_report
        rep = design_report(plan)
        rep["deviations"] = [{"tendon": d.tendon, "station": d.station, "table": d.table,
                              "function": d.function, "distance_mm": d.distance} for d in devs]
        out.print_json(json.dumps(rep))
        return
    t = Table(title=f"{loaded.name}: eyelets (mm, disk frame at its mid-plane)")
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
        out.print(Text("merged eyelets", style="bold"))
        for m in plan.merges:
            out.print(f"  station {m.station}: {', '.join(m.tendons)} ({m.kind})")
    if plan.backbone.holes:
        out.print(Text.assemble(("backbone holes", "bold"), " (tendon crosses the strip)"))
        for h in plan.backbone.holes:
            out.print(f"  {h.tendon} at station {h.station:g}: x={_mm(h.x)} y={_mm(h.y)} Ø{h.diameter:.3f}")
    for f in plan.findings:
        say("finding:", "yellow", f, out)
    if devs:
        dt = Table(title="table versus function (mm)")
        for col in ("tendon", "i", "table x", "table z", "fn x", "fn z", "deviation"):
            dt.add_column(col, justify="right")
        for dv in devs:
            style = "red" if dv.distance > 0.1 else None
            dt.add_row(dv.tendon, str(dv.station), *(_mm(v) for v in (*dv.table, *dv.function, dv.distance)),
                       style=style)
        out.print(dt)


@_command
def check(params: Path = PARAMS, out_dir: Path = OUT,
          report: Path = typer.Option(None, "--report", help="also write the JSON report here"),
          junit: Path = typer.Option(None, "--junit", help="also write JUnit XML here (one test case per check)"),
          verbose: bool = typer.Option(False, "--verbose", "-v", help="list every check, not only findings"),
          quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
          cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE, cache_size: str = CACHE_SIZE) -> None:
    """Measure the built files: eyelets, tendon lengths over the bending sweep, clearances, parts.

    Builds first only when the outputs are missing or made from other parameters; part files edited since the build are measured as they are. Exit 1 when a check fails.
    """
    loaded = _load(params)
    from ..atomic import write_json
    from ..checks.report import print_report, write_junit
    from ..pipeline import check as check_design

    rep, folder = _on_outputs(f"checking {loaded.name}", quiet,
                              lambda: check_design(loaded, out_dir, cache_dir=_cache(cache_dir, no_cache),
                                                   options=_options(cache_size)))
    print_report(rep, out, verbose=verbose)
    _verdict(rep, folder, loaded)
    if report is not None:
        _write_side_file(report, "--report", lambda: write_json(report, rep))
    if junit is not None:
        _write_side_file(junit, "--junit", lambda: write_junit(rep, junit))
    if not rep["ok"]:
        raise typer.Exit(EXIT_FINDINGS)


@_command
def render(params: Path = PARAMS, out_dir: Path = OUT,
           quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner"),
           cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE, cache_size: str = CACHE_SIZE) -> None:
    """Pictures (exploded, assembled, bent PNG), the exploded SVG drawing, the bill of materials and view.html.

    Builds first only when the outputs are missing or made from other parameters. Needs no display or GPU; exit 1 when no offscreen OpenGL backend works (the message says what to install).
    """
    loaded = _load(params)
    from ..pipeline import render as render_design

    entry, folder = _on_outputs(f"drawing {loaded.name}", quiet,
                                lambda: render_design(loaded, out_dir, cache_dir=_cache(cache_dir, no_cache),
                                                     options=_options(cache_size)))
    out.print(f"{loaded.name}: bom.csv, bom.md written to {printable(folder)}")
    if entry.get("status") != "ok":
        say("warning:", "yellow", entry.get("message", "pictures not drawn"))
        raise typer.Exit(EXIT_FINDINGS)
    for name, f in entry["files"].items():
        size = f" ({f['width']} × {f['height']} px)" if "width" in f else ""
        out.print(f"  {printable(folder / name)}{size}")
    out.print(f"  {printable(folder / 'view.html')} (open it in a browser)")


@_command
def coupon(params: Path = PARAMS, out_dir: Path = OUT,
           quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner")) -> None:
    """The calibration coupon: the design's eyelet hole and strip slot in steps around their values, each labelled.

    Writes OUT/<design>/coupon/coupon.stl, coupon.step and coupon.json (added to what is there; a rebuild that writes the same files keeps them, one whose files changed drops them). Print it first; the README says how to read it.
    """
    loaded = _load(params)
    from ..pipeline import coupon as make_coupon

    with err.status(Text(f"building the coupon of {loaded.name}"), spinner="dots") if not quiet \
            else nullcontext():
        info, folder = make_coupon(loaded, out_dir)
    holes = [f["label"] for f in info["features"] if f["kind"] == "hole"]
    slots = [f["label"] for f in info["features"] if f["kind"] == "slot"]
    out.print(f"{loaded.name}: coupon {' × '.join(f'{v:g}' for v in info['size_mm'])} mm; holes Ø "
              f"{', '.join(holes)} mm (design {info['design_hole_mm']:g}); slots {', '.join(slots)} mm a side "
              f"(design {info['design_slot_clearance_mm']:g})")
    for name in ("coupon.stl", "coupon.step", "coupon.json"):
        out.print(f"  {printable(folder / 'coupon' / name)}")


@_command
def plates(params: Path = PARAMS, out_dir: Path = OUT,
           quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner"),
           cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """Print plates: every printed part oriented for the process and packed onto the printer's plates, a 3MF per plate.

    Writes OUT/<design>/plates/plate_NN.3mf (one named object per part) and plates.md (parts per plate, resin or filament, the tallest part, each part's orientation and why). Builds first when the outputs are missing or made from other parameters.
    """
    loaded = _load(params)
    from ..pipeline import plates as lay_out

    summary, folder = _on_outputs(f"laying out {loaded.name}", quiet,
                                  lambda: lay_out(loaded, out_dir, cache_dir=_cache(cache_dir, no_cache)))
    what = "resin" if summary["technology"] == "SLA" else "filament"
    t = Table(title=f"{loaded.name}: {len(summary['plates'])} plate(s) on {printable(summary['printer'])}")
    for col in ("plate", "parts", f"{what}, ml", "tallest part", "height, mm"):
        t.add_column(col, justify="right" if col.endswith(("ml", "mm")) else "left")
    for p in summary["plates"]:
        t.add_row(p["file"], str(len(p["parts"])), f"{p['volume_ml']:.2f}", p["tallest"]["part"],
                  f"{p['tallest']['height_mm']:.1f}")
    out.print(t)
    out.print(f"  {printable(folder / 'plates' / 'plates.md')}")
    if summary["not_placed"]:
        say("warning:", "yellow", f"too large for the printer, on no plate: {', '.join(summary['not_placed'])}")
        raise typer.Exit(EXIT_FINDINGS)


@_command
def stiffness(params: Path = PARAMS, out_dir: Path = OUT,
              states: str = typer.Option(None, "--states", help="comma-separated tendon states (default: all, "
                                                                 "the nine of the paper's Fig. 8 for the prototype)"),
              quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner"),
              cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """Stiffness in newtons per tendon state and orientation: at every disk and in torsion at the tip, between the eyelet-friction bounds, and the shape under gravity.

    From the parameters (no CAD; the weights from a current build's files when OUT/<design>/ holds one): stiffness.json, stiffness.png (Fig. 8 style) and gravity.png (Fig. 7 style) in OUT/<design>/, which `hwgen build` writes too.
    """
    loaded = _load(params)
    from ..pipeline import stiffness as run_stiffness

    which = [s.strip() for s in states.split(",") if s.strip()] if states else None
    with err.status(Text(f"solving {loaded.name}"), spinner="dots") if not quiet else nullcontext():
        rep, folder = run_stiffness(loaded, out_dir, which, cache_dir=_cache(cache_dir, no_cache))
    for table in _stiffness_tables(loaded.name, rep):
        out.print(table)
    r = rep["endpoint_ratio"]
    if r.get("ratio") is not None:
        each = ", ".join(f"{v:.2f}× {k}" for k, v in r["by_friction"].items())
        out.print(Text(f"endpoint stiffness {r['states'][0]}/{r['states'][1]} ({r['orientation']}) at the tip: {each}. "
                       f"{r['note']} The paper measured {r['paper']:g}× on its prototype: `hwgen experiment` predicts "
                       "what its bench would, with a band."))
    out.print(Text(f"tensions: {rep['protocol']}; * a tendon's own pretension_n"))
    out.print(Text(f"friction: {rep['frictions']['capstan']}; † a tendon went slack before the push was whole "
                   "(the secant up to there); ▲ toward +z, ▼ toward −z"))
    for note in rep["notes"]:
        out.print(Text(f"note: {note}"))
    out.print(Text(f"model: {rep['model']}"))
    for name in ("stiffness.json", "stiffness.png", "gravity.png"):
        out.print(f"  {printable(folder / name)}")


def _stiffness_tables(design: str, rep: dict) -> list:
    """One table per orientation: each state's locked tensions and stiffness between the friction bounds."""
    tip = {(e["state"], e["orientation"], e["friction"] + (" " + e["push"] if "push" in e else "")): e
           for e in rep["states"]}
    ref = rep["endpoint_ratio"]["states"][1] if rep["endpoint_ratio"].get("states") else None
    tables = []
    for o in rep["orientations"]:
        t = Table(title=f"{design}: {o}, tensioned by the protocol (N/mm; frictionless–stuck)")
        cols = ("state", "locked tensions N", "tip N/mm", "× " + (ref or "-"), "capstan ▲/▼", "least disk",
                "torsion N·mm/rad", "tip z mm", "slack at push ▲/▼ N")
        for col in cols:
            t.add_column(col, justify="left" if col in ("state", "locked tensions N") else "right")
        for e in rep["states"]:
            if e["orientation"] != o or e["friction"] != "none":
                continue
            stuck = tip[(e["state"], o, "stuck")]
            a, b = e["tip_stiffness_n_per_mm"], stuck["tip_stiffness_n_per_mm"]
            base = (tip.get((ref, o, "none")), tip.get((ref, o, "stuck")))
            times = (f"{a / base[0]['tip_stiffness_n_per_mm']:.2f}–{b / base[1]['tip_stiffness_n_per_mm']:.2f}"
                     if all(base) else "-")
            caps = [tip.get((e["state"], o, f"capstan {k}")) for k in ("+z", "-z")]
            cap = "/".join(f"{c['tip_stiffness_n_per_mm']:.3f}" + ("†" if c["slack_within_push"] else "")
                           for c in caps if c) or "-"
            tens = " ".join(f"{n} {v:.2f}" + ("*" if e["tension_from"][n] == "pretension_n" else "")
                            for n, v in e["tensions_n"].items()) or "-"
            least = min(d["stiffness_n_per_mm"] for d in e["disks"])
            slack = "/".join("-" if v is None else f"{v:.2f}" for v in e["slack_at_tip_push_n"].values())
            t.add_row(e["state"], tens, f"{a:.4f}–{b:.4f}", times, cap, f"{least:.4f}",
                      f"{e['tip_torsion_nmm_per_rad']:.0f}–{stuck['tip_torsion_nmm_per_rad']:.0f}",
                      f"{e['tip_z_mm']:+.1f}", slack)
        tables.append(t)
    return tables


@_command
def sim(params: Path = PARAMS, out_dir: Path = OUT,
        quiet: bool = typer.Option(False, "--quiet", "-q", help="no spinner"),
        cache_dir: Path = CACHE_DIR, no_cache: bool = NO_CACHE) -> None:
    """A MuJoCo model of the robot as printed, checked against hwgen's own statics and an independent Cosserat rod.

    Reads the built files (builds first when the outputs are missing or made from other parameters) and writes OUT/<design>/sim/: robot.xml with its meshes (a keyframe per tendon state, a table, the actuating pair's drive), sim.json and sim.png. Open it with `python -m mujoco.viewer --mjcf OUT/<design>/sim/robot.xml`. Exit 1 when MuJoCo's tip stiffness and the statics' differ by more than {statics}, MuJoCo's tip and the Cosserat rod's by more than {reference} of the robot's length, a ring-down misses a mode's frequency or damping by more than {ring_down}, the model does not stay finite, or an eyelet site is off its measured eyelet.
    """
    loaded = _load(params)
    from ..pipeline import sim as run_sim

    res, folder = _on_outputs(f"simulating {loaded.name}", quiet,
                              lambda: run_sim(loaded, out_dir, cache_dir=_cache(cache_dir, no_cache)))
    t = Table(title=f"{loaded.name}: MuJoCo against the statics ({res['orientation']['words']})")
    for col in ("state", "MuJoCo tip N/mm", "statics tip N/mm", "ratio", "MuJoCo sag mm", "statics sag mm"):
        t.add_column(col, justify="right" if col != "state" else "left")
    for s in res["states"]:
        t.add_row(s["state"], f"{s['mujoco_tip_n_per_mm']:.4f}", f"{s['statics_tip_n_per_mm']:.4f}",
                  f"{s['ratio']:.3f}", f"{s['mujoco_tip_sag_mm']:.1f}", f"{s['statics_tip_sag_mm']:.1f}")
    out.print(t)
    if res["sag"].get("sag_model_tip_sag_mm") is not None:
        out.print(f"state N sags {res['sag']['mujoco_tip_sag_mm']:.1f} mm in MuJoCo, "
                  f"{res['sag']['sag_model_tip_sag_mm']:.1f} mm by the own-weight model of the checks")
    b = res["bent"]
    if b:
        out.print(f"{b['tendon']} pulled with {b['tension_n']:.1f} N: tip at ({', '.join(_mm(v) for v in b['mujoco_tip_mm'])}) "
                  f"mm in MuJoCo, ({', '.join(_mm(v) for v in b['statics_tip_mm'])}) by the statics")
    _print_twin(res)
    for d in res["dynamics"]:
        rtf = f"{d['real_time_factor']:.0f}× real time on one core" if d["real_time_factor"] else ""
        out.print(f"keyframe {d['state']}: {d['seconds']:g} s under gravity, "
                  f"{'finite' if d['finite'] else 'NOT FINITE'}, {rtf}")
    for f in res["findings"]:
        say("finding:", "yellow", f)
    for name in ("robot.xml", "sim.json", "sim.png"):
        out.print(f"  {printable(folder / 'sim' / name)}")
    if not res["ok"]:
        raise typer.Exit(EXIT_FINDINGS)


sim.__doc__ = sim.__doc__.format(**limits.words())


def _print_twin(res: dict) -> None:
    """`hwgen sim`'s lines on what the statics cannot say: the independent rod, the modes, the drive."""
    ref = res.get("reference") or {}
    for key, r in ref.items():
        if isinstance(r, dict) and "cosserat_tip_mm" in r:
            out.print(f"{key}: tip at ({', '.join(_mm(v) for v in r['mujoco_tip_mm'])}) mm in MuJoCo, "
                      f"({', '.join(_mm(v) for v in r['cosserat_tip_mm'])}) by the Cosserat rod: "
                      f"{r['distance_mm']:.2f} mm apart, {r['share_of_length']:.2%} of the length "
                      f"(limit {ref['limit_share_of_length']:.0%})")
    for state, m in res.get("modes", {}).items():
        ring = m["ring_down"]
        if ring["frequency_hz"] is None:
            check = "the ring-down found no decaying cosine"
        else:
            check = f"ring-down {ring['frequency_hz']:.3f} Hz, {ring['damping_ratio']:.2%}" + (
                "" if m["agree"] else f": more than {limits.words()['ring_down']} off")
        out.print(f"state {state}: first bending mode {m['frequency_hz']:.3f} Hz, {m['damping_ratio']:.2%} of "
                  f"critical ({check})")
    d = res.get("driven") or {}
    if d:
        change = ", ".join(f"{t} {v:+.2f} N" for t, v in d["locked_tension_change_n"].items())
        out.print(f"{d['tendon']} driven {d['haul_mm']:.1f} mm ({d['target_deg']:g}° by eq. (2)): the tip turns to "
                  f"{d['locked_angle_deg']:.1f}° with the stiffening tendons locked, {d['unlocked_angle_deg']:.1f}° "
                  f"with them slack; the locked tendons change by {change}")


@_command
def schema() -> None:
    """Print the JSON Schema of the parameter YAML (for editors)."""
    from ..params import json_schema
    sys.stdout.write(json.dumps(json_schema(), indent=2) + "\n")


