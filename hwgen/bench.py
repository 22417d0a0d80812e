"""`make bench`: what the commands cost, printed as one table. Nothing here is asserted.

Run: python -m hwgen.bench [PARAMS]          each command as a whole process: wall time, CPU, peak memory
     python -m hwgen.bench --steps [PARAMS]  where one process's build goes, step by step
     python -m hwgen.bench --sweep-build     the build level of hwgen sweep: 2 designs on 2 workers
                                             against the same 2 built one after the other (minutes)
     python -m hwgen.bench --fix             hwgen fix on the FDM lab robot of tests/labs/ alone
     python -m hwgen.bench --tune            hwgen tune's stiffness example on a small budget alone, and the
                                             tune's search against random on a known answer and on the
                                             prototype's derived stiffness space, three seeds each
     python -m hwgen.bench --view [PARAMS]   view.html's stage on a fresh build, step by step
     python -m hwgen.bench --sim [PARAMS]    hwgen sim alone, on a build made first (not timed)
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rich.console import Console
from rich.table import Table

from .cli.search import RUN_JSON
from .outputs.view import BACKEND_ENV

ROWS: list[tuple[str, float, str]] = []


def timed(label: str, note: str = ""):
    class _T:
        def __enter__(self):
            self.t = time.perf_counter()
            return self

        def __exit__(self, *exc):
            ROWS.append((label, time.perf_counter() - self.t, note))
    return _T()


def _cut_one_by_one(spec):
    """The slow way, for comparison: the same blank and tools, one boolean per tool."""
    from hwgen.cad.disk import blank_and_tools
    body, tools = blank_and_tools(spec)
    for tool in tools:
        body = body.cut(tool)
    return body


def _monte_carlo(report: dict) -> None:
    """The as-built Monte Carlo alone, on the measured robot the build's report holds: the taut
    path of every tendon over the whole sweep, per sample (CPU µs per chain: one tendon, one angle)."""
    import os

    import numba
    import numpy as np

    from hwgen.checks.taut import from_report
    from hwgen.model import scatter as mc
    rb, sc = from_report(report)
    tb = report["as_built"]["taut"]
    ang = np.asarray(tb["angles_deg"], float)
    with timed("taut path: load the compiled kernels", "numba, cached on disk (a fresh machine compiles, ~20 s)"):
        mc.run(rb, sc, ang, 1, 0)
    for n in (1_000, 10_000):
        cpu = time.process_time()
        with timed(f"as-built Monte Carlo: {n} samples", f"× {len(ang)} angles × {len(rb.chain)} tendons, "
                                                         f"{numba.get_num_threads()} threads"):
            mc.run(rb, sc, ang, n, tb["seed"])
        cpu = time.process_time() - cpu
        ROWS[-1] = (*ROWS[-1][:2], ROWS[-1][2] + f"; {cpu:.1f} s CPU, {1e6 * cpu / (n * len(ang) * len(rb.chain)):.2f} "
                                                f"µs per chain; load {os.getloadavg()[0]:.1f}")


# ---------------------------------------------------------------- whole processes

EDIT_FROM, EDIT_TO = "function: {kind: cosine, a: 25, k: 3, axis: z}", "function: {kind: cosine, a: 24.5, k: 3, axis: z}"
EDIT_TO_BARE = "function: {kind: cosine, a: 24, k: 3, axis: z}"      # the same edit, measured without pictures
# the same tendon's wave count: cos(5π) = cos(3π), so its tip eyelet (and the tensioner) stays where it was
EDIT_KEEPS_TIP = "function: {kind: cosine, a: 25, k: 5, axis: z}"


def _process(label: str, args: list[str], env: dict, note: str = "") -> tuple[str, float, float, float, str, str]:
    """Run ``hwgen ARGS`` as its own process: (label, wall s, CPU s, peak MB, note, stdout). The
    wall time runs until the process exits (its shell prompt back); the CPU and the peak are of
    the process and every process it started, however started (the part workers are forks of a
    server it starts, not its children: :func:`_adopting_orphans`), each waited for to its end."""
    return _run(label, [sys.executable, "-m", "hwgen.cli", *args], env, note)


def _adopting_orphans() -> None:
    """This process becomes the reaper of every process its children leave behind (Linux's
    PR_SET_CHILD_SUBREAPER), so their CPU and peak count in its children's usage once reaped."""
    import ctypes
    with contextlib.suppress(OSError, AttributeError):     # not Linux: the orphans' usage is not counted
        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)     # PR_SET_CHILD_SUBREAPER


def _run(label: str, argv: list[str], env: dict, note: str = "") -> tuple[str, float, float, float, str, str]:
    """Run ``argv`` as its own process, measured as :func:`_process` says."""
    import resource
    _adopting_orphans()
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryFile() as out:
        t = time.perf_counter()
        p = subprocess.Popen(argv, env=env, stdout=out, stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t
        out.seek(0)
        stdout = out.read().decode(errors="replace")
    peak = usage.ru_maxrss
    while True:                     # the processes it left behind (the fork server and its workers)
        try:
            _, _, u = os.wait4(-1, 0)
        except ChildProcessError:
            break
        peak = max(peak, u.ru_maxrss)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    code = os.waitstatus_to_exitcode(status)
    note = f"{note}; exit {code}" if code else note
    return label, wall, cpu, peak / 1024, note, stdout


def _from_cache(stdout: str) -> str:
    line = next((ln for ln in stdout.splitlines() if " parts written" in ln), "")
    m = re.search(r"(\d+) parts written.*?(?:\((\d+) from the part cache\))?$", line.strip())
    if not m:
        return ""
    return f"{int(m.group(1)) - int(m.group(2) or 0)} of {m.group(1)} parts built"


def _sim_note(sim: dict) -> str:
    """How much faster than real time the model of sim.json steps (its slowest keyframe), and where
    `hwgen sim`'s time goes (sim.json's ``seconds``)."""
    rates = [d["real_time_factor"] for d in sim.get("dynamics", []) if d.get("real_time_factor")]
    secs = sim.get("seconds") or {}
    return "; ".join(x for x in (
        f"the model steps {min(rates):.0f}× real time on one core" if rates else "",
        f"in sim.json: statics {secs['statics']:.1f} s, written and damped by {secs['written']:.1f}, measured by "
        f"{secs['measured']:.1f}" if {"statics", "written", "measured"} <= set(secs) else "") if x)


def sim_rows(params: Path, out: Path, store: Path, env: dict) -> list[tuple]:
    """`hwgen sim` on the built outputs in ``out`` (the issue's limit: 30 s wall on 2 cores), and
    where its time goes (sim.json's ``seconds``)."""
    r = _process("hwgen sim", ["sim", str(params), "--out", str(out), "--cache-dir", str(store), "-q"], env,
                 "on the built outputs: robot.xml written twice (its damping from state N's mode), 3 states and "
                 "the bent robot solved, the Cosserat reference, 3 modes with ring-downs, the drive, 3 × 2 s stepped")
    sim = _written_json(out, "sim/sim.json")
    return [(*r[:4], "; ".join(x for x in (r[4], _sim_note(sim) if sim else "no sim.json") if x))]


def _written_json(out: Path, name: str) -> dict | None:
    """The JSON file ``name`` a command wrote into its design's folder under ``out`` (None: none, or unreadable)."""
    return _first_json(sorted(Path(out).glob(f"*/{name}")))


def _first_json(paths) -> dict | None:
    """The first of ``paths`` that holds a JSON object (None: none does)."""
    for path in paths:
        try:
            doc = json.loads(path.read_text())
        except (OSError, ValueError):
            continue
        if isinstance(doc, dict):
            return doc
    return None


def processes(params_path: Path) -> None:
    """Cold build (empty part cache), the same build again, one tendon edited, hwgen check on the
    built outputs, hwgen routing: each a fresh process with the shipped Monte Carlo sample count."""
    env = {k: v for k, v in os.environ.items() if k not in ("HWGEN_CHECK_SAMPLES", "HWGEN_CACHE_DIR")}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        out, store = tmp / "out", tmp / "cache"
        params = tmp / params_path.name
        shutil.copy(params_path, params)
        build = ["build", str(params), "--out", str(out), "--cache-dir", str(store), "-q"]
        for label, note in (("cold build", "empty part cache"), ("no-op rebuild", "nothing changed")):
            r = _process(label, build, env, note)
            rows.append((*r[:4], "; ".join(x for x in (r[4], _from_cache(r[5])) if x)))
        rows.append(_process("cold build, --no-cache", [*build, "--no-cache"], env,
                             "every part and stage afresh")[:5])
        rows.append(_process("cold build, --no-cache --jobs 1", [*build, "--no-cache", "--jobs", "1"], env,
                             "parts in 1 worker process")[:5])
        rows.append(_process("cold build, --no-cache --jobs 0", [*build, "--no-cache", "--jobs", "0"], env,
                             "parts in the process that runs the checks")[:5])
        # the issue's own first measurement was of a build without pictures: the same, for comparison
        bare = {**env, BACKEND_ENV: "none"}
        rows.append(_process("cold build, --no-cache, no pictures", [*build, "--no-cache"], bare,
                             f"{BACKEND_ENV}=none")[:5])
        rows.append(_process("cold build, no pictures", [*build[:-3], "--cache-dir", str(tmp / "bare-cache"), "-q"],
                             bare, f"empty part cache; {BACKEND_ENV}=none")[:5])
        text = params.read_text()
        if EDIT_FROM in text:
            params.write_text(text.replace(EDIT_FROM, EDIT_TO))
            r = _process("one-tendon edit", build, env, "C2: a 25 → 24.5 mm (its tip eyelet moves)")
            rows.append((*r[:4], "; ".join(x for x in (r[4], _from_cache(r[5])) if x)))
            params.write_text(text.replace(EDIT_FROM, EDIT_TO_BARE))
            r = _process("one-tendon edit, no pictures", build, bare, f"C2: a 25 → 24 mm; {BACKEND_ENV}=none")
            rows.append((*r[:4], "; ".join(x for x in (r[4], _from_cache(r[5])) if x)))
            params.write_text(text.replace(EDIT_FROM, EDIT_TO))
            _process("the edit's pictures", build, env)      # the outputs of the edit above, whole, for the checks
        check = ["check", str(params), "--out", str(out), "--cache-dir", str(store), "-q"]
        rows.append(_process("hwgen check", check, env,
                             "on the built outputs")[:5])
        rows.append(_process("hwgen check, empty cache", [*check[:-3], "--cache-dir", str(tmp / "empty"), "-q"], env,
                             "nothing remembered: Monte Carlo, statics, gears measured")[:5])
        rows += sim_rows(params, out, store, env)
        rows += experiment_rows(params, tmp, env)
        if EDIT_FROM in text:
            params.write_text(text.replace(EDIT_FROM, EDIT_KEEPS_TIP))
            r = _process("one-tendon edit, tip kept", build, env, "C2: k 3 → 5 from the prototype")
            rows.append((*r[:4], "; ".join(x for x in (r[4], _from_cache(r[5])) if x)))
        rows.append(_process("hwgen routing", ["routing", str(params)], env)[:5])
        rows += disk_rows(params, tmp, env)
        rows += bench_hardware_rows(params, tmp, env)
        rows += sweep_rows(params, tmp)
        rows += tune_rows(tmp)
        rows += fix_rows(tmp)
        rows += sampler_rows(tmp)
        rows += derived_rows(tmp)
    t = Table(title=f"hwgen benchmark: {params_path} (whole processes, {os.cpu_count()} cores, "
                    f"load {os.getloadavg()[0]:.1f})")
    for col, right in (("command", False), ("wall s", True), ("CPU s", True), ("peak MB", True), ("note", False)):
        t.add_column(col, justify="right" if right else "left")
    for label, wall, cpu, peak, note in rows:
        t.add_row(label, f"{wall:.2f}", f"{cpu:.2f}", f"{peak:.0f}", note)
    Console().print(t)


# ---------------------------------------------------------------- the push test

def _endpoint_note(experiment: dict | None) -> str:
    """The predicted endpoint ratio and its band, from experiment.json."""
    ep = (experiment or {}).get("endpoint_ratio")
    if not ep:
        return ""
    band = f" ({ep['low']:.2f}–{ep['high']:.2f}×)" if ep.get("corners") else ""
    return f"{ep['state']}/{ep['over']} {ep['nominal']:.2f}×{band}"


def experiment_rows(params: Path, tmp: Path, env: dict) -> list[tuple]:
    """`hwgen experiment` from the parameters, the statics afresh (--no-cache): on a machine whose
    numba cache has not the push's loop yet (it compiles), then with it."""
    numba_env = {**env, "NUMBA_CACHE_DIR": str(tmp / "numba")}
    argv = ["experiment", str(params), "--out", str(tmp / "experiment"), "--no-cache", "-q"]
    rows = []
    for label, note in (("hwgen experiment, first on a machine", "numba compiles the push's loop"),
                        ("hwgen experiment", "every state tensioned and pushed on every robot of the band "
                                             "(issue 47: at most 30 s CPU)")):
        r = _process(label, argv, numba_env, note)
        ep = _endpoint_note(_written_json(tmp / "experiment", "experiment/experiment.json"))
        rows.append((*r[:4], "; ".join(x for x in (r[4], ep) if x)))
    return rows


# ---------------------------------------------------------------- the disks against OpenSCAD

# OpenSCAD's facets near the STL export's (cad/export.py: 0.01 mm chord, 0.2 rad): the Ø72 mm
# outline in 133 segments (2.7°), a Ø1.2 mm eyelet in 38 (0.1 mm edges)
SCAD_RESOLUTION = "$fa = 2.7; $fs = 0.1;"


def _v(p) -> str:
    return "[" + ", ".join(f"{float(c):.6f}" for c in p) + "]"


def _onto(axis) -> list[list[float]]:
    """4x4 rotation taking +Z onto ``axis`` (Rodrigues), as OpenSCAD's multmatrix wants it."""
    import numpy as np
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    v, c = np.cross([0.0, 0.0, 1.0], a), float(a[2])
    if np.linalg.norm(v) < 1e-12:
        r = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])     # along +Z, or a half turn about X
    else:
        k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        r = np.eye(3) + k + k @ k / (1 + c)
    m = np.eye(4)
    m[:3, :3] = r
    return m.tolist()


def disk_scad(spec) -> str:
    """One disk as OpenSCAD source, from the same plan and the same tool profiles as
    :func:`hwgen.cad.disk.blank_and_tools`: the plate with its slot, straight eyelets and screw holes
    extruded, the hub with its tendon windows, then every slanted bore and chamfer cone (revolved
    from :func:`hwgen.cad.disk.eyelet_profiles`, each eyelet chamfered or drilled plain as hwgen's disk
    has it: :func:`hwgen.cad.disk.eyelet_edges`), seat, seat chamber and glue port cut at once. Left
    out: turning the tip disk over for printing (orientation only). OpenSCAD writes meshes only:
    no STEP or exact BREP, which hwgen's disks also write."""
    from hwgen.cad.disk import NORMAL_AXIS_TOL, TOOL_OVERRUN, eyelet_edges, eyelet_profiles, sketch_xy
    from hwgen.model.fixing import seat_overlap
    T, seated = spec.thickness, bool(spec.seats)
    normal = [h for h in spec.holes if abs(abs(h.axis[1]) - 1) < NORMAL_AXIS_TOL and not seated]
    slanted = [h for h in spec.holes if h not in normal]
    cut2d = [f"square([{spec.slot_width:.6f}, {spec.slot_height:.6f}], center=true);"]
    cut2d += [f"translate({_v(sketch_xy(h.x, h.z))}) circle(d={h.diameter:.6f});" for h in normal]
    cut2d += [f"translate({_v(sketch_xy(x, z))}) circle(d={d:.6f});" for x, z, d in spec.mount_holes]
    body = [f"linear_extrude({T:.6f}) difference() {{ circle(d={spec.outer_diameter:.6f}); {' '.join(cut2d)} }}"]
    hub = spec.hub
    if hub is not None:
        w, h = spec.slot_width + 2 * hub.wall, spec.slot_height + 2 * hub.wall
        win = " ".join(f"translate([{(a + b) / 2:.6f}, 0]) square([{b - a:.6f}, {h + 2 * TOOL_OVERRUN:.6f}], center=true);"
                       for a, b in hub.windows)
        z0 = T if hub.side > 0 else -hub.length
        body.append(f"translate([0, 0, {z0:.6f}]) linear_extrude({hub.length:.6f}) difference() {{ "
                    f"square([{w:.6f}, {h:.6f}], center=true); square([{spec.slot_width:.6f}, {spec.slot_height:.6f}], "
                    f"center=true); {win} }}")

    edge = {id(h): e for h, e in zip(spec.holes, eyelet_edges(spec))}

    def revolved(h, with_bore):
        origin, ax, profiles = eyelet_profiles(h, T, edge[id(h)], not seated, True, with_bore)
        m = _onto(ax)
        for r in range(3):
            m[r][3] = origin[r]
        return [f"multmatrix({m}) rotate_extrude() polygon({[list(p) for p in prof]});" for prof in profiles]

    big = spec.outer_diameter + 4 * TOOL_OVERRUN
    tools = []
    for h in slanted:
        (tool,) = revolved(h, True)
        if seated and not h.in_slot:    # the bore stops at the seat plate
            tool = (f"intersection() {{ {tool} translate([{-big / 2:.6f}, {-big / 2:.6f}, {spec.seat_plate:.6f}]) "
                    f"cube([{big:.6f}, {big:.6f}, {T + 2 * TOOL_OVERRUN - spec.seat_plate:.6f}]); }}")
        tools.append(tool)
    for h in normal:
        tools += revolved(h, False)
    for st in spec.seats:
        tools.append(f"translate({_v((*sketch_xy(st.x, st.z), -TOOL_OVERRUN))}) "
                     f"cylinder(d={st.diameter:.6f}, h={spec.seat_plate + seat_overlap(T, spec.seat_plate) + TOOL_OVERRUN:.6f});")
    for x, z, dia, height in spec.seat_chambers:
        tools.append(f"translate({_v((*sketch_xy(x, z), spec.seat_plate))}) cylinder(d={dia:.6f}, h={height:.6f});")
    if hub is not None and hub.port is not None:
        x, off, dia = hub.port
        z = T + off if hub.side > 0 else -off
        tools.append(f"translate({_v((x, 0, z))}) rotate([90, 0, 0]) "
                     f"cylinder(d={dia:.6f}, h={spec.slot_height / 2 + hub.wall + TOOL_OVERRUN:.6f});")
    nl = "\n  "
    return (f"// {spec.name}: written by hwgen.bench from the plan, for timing against hwgen's own disk\n"
            f"{SCAD_RESOLUTION}\ndifference() {{\n  union() {{\n  {nl.join(body)}\n  }}\n  {nl.join(tools)}\n}}\n")


HWGEN_DISKS = """
import sys
from pathlib import Path
from hwgen import pipeline
from hwgen.cad.disk import build_disk
from hwgen.cad.export import write_step, write_stl
from hwgen.model.plan import make_plan
plan = make_plan(pipeline.load(Path(sys.argv[1])).design)
for spec in plan.disks:
    part = build_disk(spec)
    write_stl(part.solid, Path(sys.argv[2]) / f"{part.name}.stl")
    write_step(part.solid, Path(sys.argv[2]) / f"{part.name}.step")
"""


HWGEN_BENCH_PARTS = """
import sys
from pathlib import Path
from hwgen import pipeline
from hwgen.cad.bench import frame_parts, rig_parts
from hwgen.cad.export import write_step, write_stl
from hwgen.model.plan import make_plan
d = pipeline.load(Path(sys.argv[1])).design
d = d.model_copy(update={"base_frame": d.base_frame.model_copy(update={"enabled": True}),
                         "rig": d.rig.model_copy(update={"enabled": True})})
plan = make_plan(d)
for part in [*frame_parts(plan.frame), *rig_parts(plan.rig)]:
    write_stl(part.solid, Path(sys.argv[2]) / f"{part.name}.stl")
    write_step(part.solid, Path(sys.argv[2]) / f"{part.name}.step")
"""


def bench_hardware_rows(params_path: Path, tmp: Path, env: dict) -> list[tuple]:
    """The paper's bench as printed parts (issue 46): the rotating base frame and the stiffness rig
    built and written (STL and STEP) in one cold process, the worm pair's gear made afresh; a build
    keeps them in the part cache as one unit, beside the tensioner's."""
    (tmp / "bench-hw").mkdir()
    r = _run("base frame (7 parts) and rig (3), hwgen (STL + STEP)",
             [sys.executable, "-c", HWGEN_BENCH_PARTS, str(params_path), str(tmp / "bench-hw")], env,
             "one cold process, CadQuery imported, the worm wheel's gear made afresh")
    return [r[:5]]


def disk_rows(params_path: Path, tmp: Path, env: dict) -> list[tuple]:
    """The plan's disks built and written (STL and STEP) by hwgen in one cold process, against the
    same disks written as .scad and made into STL by OpenSCAD (Debian's ``openscad``), one process
    per disk as a lab would run it."""
    from hwgen import pipeline
    from hwgen.model.plan import make_plan
    specs = make_plan(pipeline.load(params_path).design).disks
    (tmp / "hw").mkdir()
    ours = _run(f"{len(specs)} disks, hwgen (STL + STEP)", [sys.executable, "-c", HWGEN_DISKS, str(params_path),
                                                             str(tmp / "hw")], env, "one cold process, CadQuery imported")
    openscad = shutil.which("openscad")
    if openscad is None:
        return [(*ours[:4], ours[4]), (f"{len(specs)} disks, OpenSCAD", 0.0, 0.0, 0.0,
                                      "not installed (apt-get install openscad)")]
    (tmp / "scad").mkdir()
    wall = cpu = peak = 0.0
    failed = 0
    for spec in specs:
        src = tmp / "scad" / f"{spec.name}.scad"
        src.write_text(disk_scad(spec))
        r = _run(spec.name, [openscad, "-o", str(src.with_suffix(".stl")), str(src)], env)
        wall, cpu, peak = wall + r[1], cpu + r[2], max(peak, r[3])
        failed += bool(r[4])
    note = (f"one process per disk (CGAL), STL only; hwgen took {ours[1] / wall:.2f}× its time"
            + (f"; {failed} failed" if failed else ""))
    return [ours[:5], (f"{len(specs)} disks, OpenSCAD {_version(openscad)}", wall, cpu, peak, note)]


def _version(exe: str) -> str:
    out = subprocess.run([exe, "--version"], capture_output=True, text=True)
    return (out.stdout + out.stderr).strip().split()[-1] if (out.stdout + out.stderr).strip() else ""


# ---------------------------------------------------------------- hwgen sweep

SWEEP_AXES = ("  - path: tendons[1].routing.function.k\n    range: {start: 0.5, stop: 4, step: 0.25}\n"
              "  - path: tendons[1].routing.function.a\n    range: {start: 10, stop: 29, step: 1}\n"
              "  - path: tendons[1].routing.function.phase_deg\n    range: {start: 0, stop: 45, step: 5}\n")


def _run_json(folder: Path) -> dict | None:
    """The run.json a sweep, tune or fix wrote beside its results under ``folder`` (the newest; None: none)."""
    return _first_json(sorted(Path(folder).rglob(RUN_JSON), key=lambda p: p.stat().st_mtime, reverse=True))


def _sweep_note(run: dict | None) -> str:
    """The sweep's throughput from its run.json."""
    if not run or not run.get("evaluated") or not run.get("seconds"):
        return "no run.json with variants evaluated"
    n, sec = run["evaluated"], run["seconds"]
    return (f"{n / sec:,.1f} variants/s over {n} variants on {run['workers']} worker(s) ({sec:.2f} s, "
            f"{1000 * run['cpu_s'] / n:.2f} ms CPU per variant; the whole process includes starting it and the cluster)")


def sweep_rows(params_path: Path, tmp: Path, level: str = "lengths", axes: str = SWEEP_AXES,
               own_cache: bool = False) -> list[tuple]:
    """hwgen sweep over C1's k, amplitude and phase (3 000 variants): on a local cluster of 2
    workers, and inline in one process; the note is the sweep's own throughput line. With
    ``own_cache``, each run starts from an empty part cache of its own."""
    sweep = tmp / f"bench-sweep-{level}.yaml"
    sweep.write_text(f"sweep: bench\nbase: {params_path.resolve()}\nlevel: {level}\nkeep: []\naxes:\n{axes}")
    env = {k: v for k, v in os.environ.items() if k not in ("HWGEN_CHECK_SAMPLES", "HWGEN_CACHE_DIR")}
    rows = []
    for label, args in ((f"hwgen sweep, {level}, local cluster", ["--workers", "2"]),
                        (f"hwgen sweep, {level}, inline", ["--scheduler", "inline"])):
        out = tmp / f"sweep-{level}-{args[-1]}"
        extra = ["--cache-dir", str(tmp / f"cache-{level}-{args[-1]}")] if own_cache else []
        r = _process(label, ["sweep", str(sweep), "--out", str(out), "-q", *args, *extra], env)
        rows.append((*r[:4], "; ".join(x for x in (r[4], _sweep_note(_run_json(out))) if x)))
    return rows




def tune_rows(tmp: Path, budget: int = 60) -> list[tuple]:
    """hwgen tune params/tune-stiffness.yaml on a small budget (the coupling level and the statics
    a trial, no build of the best) on 2 workers: trials per second, CPU a trial, the time to the best."""
    env = {k: v for k, v in os.environ.items() if k not in ("HWGEN_CHECK_SAMPLES", "HWGEN_CACHE_DIR")}
    r = _process(f"hwgen tune, stiffness, {budget} trials", ["tune", "params/tune-stiffness.yaml", "--out",
                                                              str(tmp / "tune"), "--budget", str(budget),
                                                              "--workers", "2", "--no-build", "-q"], env)
    return [(*r[:4], "; ".join(x for x in (r[4], _tune_note(_run_json(tmp / "tune"))) if x))]


def _tune_note(run: dict | None) -> str:
    """The tune's throughput and its best, from its run.json."""
    if not run or not run.get("evaluated") or not run.get("seconds"):
        return "no run.json with trials evaluated"
    n, sec = run["evaluated"], run["seconds"]
    per = run["cpu_s"] / n
    cpu = f"{per:.2f} s" if per >= 0.1 else f"{1000 * per:.2f} ms"
    whole = run.get("whole") or 0
    note = (f"{n / sec:.3g} trials/s over {n} trials on {run['workers']} workers ({sec:.1f} s, {cpu} CPU a trial"
            + (f"; {run['whole_cpu_s'] / whole:.2f} s each of the {whole} through every level" if 0 < whole < n else "")
            + ")")
    best = run.get("best")
    if best:
        objs = ", ".join(f"{k} {v:.4g}" for k, v in best["objectives"].items())
        note += f"; best {objs} at trial {best['trial']}" + (f", {best['found_s']:.1f} s in" if best.get("found_s")
                                                             is not None else "")
    return note


FIX_LAB = "tests/labs/fdm-ten-fix.yaml"


def fix_rows(tmp: Path) -> list[tuple]:
    """hwgen fix on the lab robot of tests/labs/ (FDM, ten disks) with the relaxation the prototype
    states, from an empty part cache: the rounds, their builds, the values changed."""
    env = {k: v for k, v in os.environ.items() if k not in ("HWGEN_CHECK_SAMPLES", "HWGEN_CACHE_DIR")}
    if not Path(FIX_LAB).is_file():
        return []
    r = _process("hwgen fix, the FDM lab robot", ["fix", FIX_LAB, "--allow-relax", "check.robust_severity", "--out",
                                                  str(tmp / "fix"), "--cache-dir", str(tmp / "fix-cache"), "-q"],
                 env)
    return [(*r[:4], "; ".join(x for x in (r[4], _fix_note(_run_json(tmp / "fix"))) if x))]


def _fix_note(run: dict | None) -> str:
    """The fix's verdict, its changes and builds, from its run.json."""
    if not run or "passed" not in run:
        return "no run.json with a verdict"
    return (f"{'PASS' if run['passed'] else 'FAIL'}: {run['changes']} value(s) changed, {run['builds']} designs "
            f"built, empty cache")
SAMPLER_SEEDS = (0, 1, 2)
# the known answer: three cosine tendons' half waves, free in 0.5-6.5 from k 2.4, 2.6 and 3.5, the worst
# budgeted tendon's eq. (2) change minimised: whole k for all three (a cosine keeps its length only there)
KNOWN_START = ((1, 2.4), (2, 2.6), (3, 3.5))


def sampler_rows(tmp: Path, budget: int = 150) -> list[tuple]:
    """The tune's sampler against random sampling on a problem with a known answer, at the same budget
    and seeds (the lengths level, in this process): the best each finds, seed by seed."""
    import yaml

    from .tune import best as tune_best, spec as tune_spec
    rows = []
    for sampler in ("auto", "random"):
        found = []
        t0, c0 = time.perf_counter(), time.process_time()
        for seed in SAMPLER_SEEDS:
            doc = {"tune": f"known-{sampler}-{seed}", "base": str(Path("params/prototype.yaml").resolve()),
                   "level": "lengths", "budget": budget, "seed": seed, "sampler": sampler,
                   "set": {f"tendons[{i}].routing.function.k": k for i, k in KNOWN_START},
                   "free": [{"path": f"tendons[{i}].routing.function.k", "low": 0.5, "high": 6.5}
                            for i, _ in KNOWN_START],
                   "goal": {"minimize": "centre_mm", "checks": "required"}}
            p = tmp / f"known-{sampler}-{seed}.yaml"
            p.write_text(yaml.safe_dump(doc))
            t = tune_best.tune(tune_spec.load(p), tmp / "known", "inline", build=False)
            found.append(t.best["objectives"][0])
        name = "the tune's search (TPE, moves from the incumbent)" if sampler == "auto" else "random"
        rows.append((f"hwgen tune, known answer, {name}, {budget} trials × {len(SAMPLER_SEEDS)} seeds",
                     time.perf_counter() - t0, time.process_time() - c0,
                     resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,      # this process's peak so far
                     "best worst-tendon eq. (2) change by seed: " + ", ".join(f"{v:.3f}" for v in found)
                     + " mm (whole k: about 0.19 mm)"))
    return rows


DERIVED_BUDGET = 100


def derived_rows(tmp: Path, budget: int = DERIVED_BUDGET) -> list[tuple]:
    """``hwgen tune params/prototype.yaml --goal stiffness`` (the space derived from the design) by the
    tune's search and by random sampling, at the same budget and seeds, on 2 workers: the best tip
    stiffness over the base's (the base itself when nothing else passes) and the trials that pass."""
    from .tune import derive, results, run as tune_run
    rows = []
    for sampler in ("auto", "random"):
        found = []
        t0, c0 = time.perf_counter(), time.process_time()
        cpu = 0.0
        for seed in SAMPLER_SEEDS:
            loaded = derive.load("params/prototype.yaml", "stiffness", budget, seed, sampler)
            out, study = tune_run.run(loaded, tmp / f"derived-{sampler}-{seed}", workers=2)
            cpu += out.cpu_s
            base = results.value("tip_stiffness", study.user_attrs["base_row"], loaded.state)
            passing = [t.values[0] for t in study.get_trials(deepcopy=False) if t.user_attrs.get("feasible")]
            found.append((max(passing, default=base) / base, len(passing)))
        name = "the tune's search (TPE, moves from the incumbent)" if sampler == "auto" else "random"
        rows.append((f"hwgen tune prototype --goal stiffness, {name}, {budget} trials × {len(SAMPLER_SEEDS)} seeds",
                     time.perf_counter() - t0, time.process_time() - c0 + cpu,
                     resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                     "best tip stiffness over the base's by seed (trials that pass): "
                     + ", ".join(f"{x:.2f}× ({n})" for x, n in found)))
    return rows


def sweep_build() -> None:
    """The build level: two designs (C1's amplitude 24 and 26 mm) on 2 workers, and inline one after
    the other, each run from an empty part cache of its own: the variants of one run share the
    parts they have in common (the throated wheels' gears among them), as a sweep on a user's
    cache does, and the locks keep two workers from making one part twice. The target: the local
    cluster within 20 % of the inline run's time per design (the same work, one variant after the
    other) divided by the workers. Beside them, one cold build of the prototype alone (no
    pictures, as the sweep builds)."""
    axes = "  - path: tendons[1].routing.function.a\n    values: [24, 26]\n"
    env = {k: v for k, v in os.environ.items() if k not in ("HWGEN_CHECK_SAMPLES", "HWGEN_CACHE_DIR")}
    with tempfile.TemporaryDirectory() as tmp:
        one = _process("one cold build alone, empty cache (no pictures)",
                       ["build", "params/prototype.yaml", "--out", str(Path(tmp) / "one"), "-q",
                        "--cache-dir", str(Path(tmp) / "cache-one")], {**env, BACKEND_ENV: "none"})
        rows = [one[:5], *sweep_rows(Path("params/prototype.yaml"), Path(tmp), "build", axes, own_cache=True)]
    t = Table(title=f"hwgen sweep, build level ({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f})")
    for col, right in (("command", False), ("wall s", True), ("CPU s", True), ("peak MB", True), ("note", False)):
        t.add_column(col, justify="right" if right else "left")
    for label, wall, cpu, peak, note in rows:
        t.add_row(label, f"{wall:.2f}", f"{cpu:.2f}", f"{peak:.0f}", note)
    Console().print(t)
    # the sweep's own seconds (its start and the cluster's excluded): the inline run is the serial
    # per-design time of the same work (the robust and coupling levels, the build, the check)
    cluster, inline = (float(re.search(r"\(([\d.]+) s, ", r[4]).group(1)) for r in rows[1:3])
    target = 1.2 * (inline / 2) * 2 / 2
    print(f"target: serial {inline / 2:.1f} s a design (inline) x 2 designs / 2 workers x 1.2 = {target:.1f} s; "
          f"the local cluster took {cluster:.1f} s ({'met' if cluster <= target else 'missed'}; "
          f"{inline / cluster:.2f}x the inline run); one cold build alone {one[1]:.1f} s")


# ---------------------------------------------------------------- steps of one build

def _statics(plan) -> None:
    """The statics in newtons: the nine tendon states (`hwgen stiffness`) and the bending sweep of
    `hwgen check`'s tension checks, from the plan."""
    import os

    from hwgen.checks.tension import sweeps
    from hwgen.model import stiffness as sf
    n = len(sf.states(plan))
    cpu = time.process_time()
    with timed(f"statics: {n} tendon states × {len(sf.ORIENTATIONS)} orientations",
               "the tensioning protocol, stiffness at every disk frictionless and stuck, the capstan push, torsion"):
        rep = sf.study(plan)
    ROWS[-1] = (*ROWS[-1][:2], ROWS[-1][2] + f"; {rep['dof']} DOF, {time.process_time() - cpu:.1f} s CPU, "
                                            f"load {os.getloadavg()[0]:.1f}")
    with timed("statics: bending sweep ±, stiffening tendons locked and slack", "the tension checks' statics"):
        sweeps(plan)


def view_rows(folder: Path, plan) -> None:
    """view.html's stage on a built design as a build runs it (the meshes' arrays from the store the
    build keeps them in: here the first run's), then its steps: the meshes read, the poses (the
    exploded offsets, the bent placements, the strip cut and bent), the GLB export, the page."""
    import json

    import numpy as np

    from hwgen import cache
    from hwgen.cad.manifest import read_manifest
    from hwgen.checks.report import read_report
    from hwgen.outputs import scene, webview
    manifest, report = read_manifest(folder), read_report(folder)
    study = json.loads((folder / "stiffness.json").read_text())
    args = (report, study, plan.render.explode_mm, plan.check.max_angle_deg)
    with tempfile.TemporaryDirectory() as tmp, cache.using(cache.Store(Path(tmp))):
        webview.write_view(folder, manifest, *args)             # the meshes' arrays kept, as the checks keep them
        cpu = time.process_time()
        with timed("view.html: the stage", f"{(folder / webview.PAGE).stat().st_size / 1e6:.1f} MB page"):
            webview.write_view(folder, manifest, *args)
        ROWS[-1] = (*ROWS[-1][:2], ROWS[-1][2] + f"; {time.process_time() - cpu:.2f} s CPU, load {os.getloadavg()[0]:.1f}")
        with timed("view.html: the meshes read"):
            pairs, _, _ = webview.read_meshes(folder, manifest)
        parts = scene.scene_parts(pairs)
        st = np.asarray(manifest.design_report["stations_mm"], float)
        with timed("view.html: the poses", "exploded offsets, bent placements, the strip cut and bent twice"):
            scene.exploded_placements(parts, st, plan.render.explode_mm, webview.ISOMETRIC.toward_camera)
            webview._bent_poses(parts, st, plan.check.max_angle_deg)
        triangles = sum(len(f) for f in {id(p.drawn): p.faces for p in parts}.values())
        with timed("view.html: GLB export", f"trimesh, {len(parts)} nodes, {triangles:,} distinct triangles"):
            data = webview.glb(parts)
        ROWS[-1] = (*ROWS[-1][:2], ROWS[-1][2] + f", {len(data) / 1e6:.1f} MB")


def _print_rows(title: str, rows: list[tuple]) -> None:
    t = Table(title=f"{title} ({os.cpu_count()} cores, load {os.getloadavg()[0]:.1f})")
    for col in ("command", "wall s", "CPU s", "peak MB", "note"):
        t.add_column(col)
    for label, wall, cpu, peak, note in rows:
        t.add_row(label, f"{wall:.2f}", f"{cpu:.2f}", f"{peak:.0f}", note)
    Console().print(t)


def main(argv: list[str]) -> None:
    if "--tune" in argv:
        with tempfile.TemporaryDirectory(prefix="hwgen-bench-") as tmp:
            rows = tune_rows(Path(tmp)) + sampler_rows(Path(tmp)) + derived_rows(Path(tmp))
        _print_rows("hwgen tune", rows)
        return
    if "--fix" in argv:
        with tempfile.TemporaryDirectory(prefix="hwgen-bench-") as tmp:
            rows = fix_rows(Path(tmp))
        _print_rows("hwgen fix", rows)
        return
    if "--sweep-build" in argv:
        sweep_build()
        return
    if "--view" in argv:
        from hwgen import pipeline
        argv = [a for a in argv if a != "--view"]
        loaded = pipeline.load(Path(argv[0]) if argv else Path("params/prototype.yaml"))
        with tempfile.TemporaryDirectory(prefix="hwgen-bench-") as tmp:
            res = pipeline.build(loaded, Path(tmp))
            view_rows(res.folder, res.plan)
        _print_steps(f"view.html of {loaded.name} (load {os.getloadavg()[0]:.1f})")
        return
    if "--sim" in argv:
        params_path = Path(next((a for a in argv if a != "--sim"), "params/prototype.yaml"))
        env = {k: v for k, v in os.environ.items() if k != "HWGEN_CACHE_DIR"}
        with tempfile.TemporaryDirectory(prefix="hwgen-bench-") as tmp:
            out, store = Path(tmp) / "out", Path(tmp) / "cache"
            subprocess.run([sys.executable, "-m", "hwgen.cli", "build", str(params_path), "--out", str(out),
                            "--cache-dir", str(store), "-q"], env=env, check=True, stdout=subprocess.DEVNULL)
            rows = sim_rows(params_path, out, store, env)
        _print_rows("hwgen sim", rows)
        return
    if "--steps" not in argv:
        processes(Path(argv[0]) if argv else Path("params/prototype.yaml"))
        return
    argv = [a for a in argv if a != "--steps"]
    params_path = Path(argv[0]) if argv else Path("params/prototype.yaml")
    with timed("import numpy, pydantic, yaml (schema, model)"):
        from hwgen import pipeline
        from hwgen.model.plan import make_plan
    with timed("import cadquery", "a command that builds no solid skips this"):
        import cadquery  # noqa: F401
    with timed("load + validate YAML"):
        loaded = pipeline.load(params_path)
    with timed("plan: eyelets sized over the sweep", "numpy, all tendons and stations"):
        plan = make_plan(loaded.design)
    _statics(plan)
    from hwgen.cad.disk import build_disk
    from hwgen.cad.export import write_step, write_stl
    disks = []
    with timed(f"build {len(plan.disks)} disks", "one face extruded once + one cut"):
        for s in plan.disks:
            disks.append(build_disk(s))
    with timed(f"same {len(plan.disks)} disks, tools cut one by one", "for comparison"):
        for s in plan.disks:
            _cut_one_by_one(s)
    from hwgen.cad.wheel import gear_solid
    from hwgen.model.gearing import worm_pair
    pair = worm_pair(loaded.design.tensioner, loaded.design.process.min_wall)
    with timed("build the throated wheel's gear", "one tooth's sector cut, turned round and glued; "
                                                 "built once per distinct pair"):
        gear_solid.__wrapped__(pair)
    with tempfile.TemporaryDirectory() as tmp:
        with timed(f"export {len(disks)} disks STL"):
            for p in disks:
                write_stl(p.solid, Path(tmp) / f"{p.name}.stl")
        with timed(f"export {len(disks)} disks STEP"):
            for p in disks:
                write_step(p.solid, Path(tmp) / f"{p.name}.step")
        build = pipeline.build
        with timed("hwgen build, parts and files only", "no post-build steps, no part cache"):
            build(loaded, Path(tmp) / "a", post_build=False, cache_dir=None)
        with timed("hwgen build, everything", "with checks, bill of materials and pictures, no part cache"):
            res = build(loaded, Path(tmp) / "b", cache_dir=None)
        from hwgen.checks.gear_mesh import gear_checks
        from hwgen.cad.manifest import read_manifest
        with timed("gear checks from the meshes", "axes, counts and sweeps per distinct worm and wheel; "
                                                  "backlash, loaded face and Lewis Y on one pair"):
            gear_checks(res.folder, read_manifest(res.folder).parts, plan)
        if res.report is not None:
            _monte_carlo(res.report)
            view_rows(res.folder, res.plan)
    _print_steps(f"hwgen benchmark: {params_path}")


def _print_steps(title: str) -> None:
    """The rows :func:`timed` took, as one table."""
    t = Table(title=title)
    t.add_column("step")
    t.add_column("seconds", justify="right")
    t.add_column("note")
    for label, sec, note in ROWS:
        t.add_row(label, f"{sec:.3f}", note)
    Console().print(t)


if __name__ == "__main__":
    main(sys.argv[1:])
