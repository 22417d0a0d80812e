"""The stability run: robots as a lab writes them (:func:`tests.robots.lab_robot`), each built whole by the CLI in
its own process, classified by exit code with the checks it fails, and a table at the end.

    python -m tests.stability [--robots 100] [--seed 20261125] [--jobs 2] [--keep DIR]

(``make stability`` runs the 100.) Exit 0 builds and passes; 1 builds and fails checks (a finding:
the design breaks a rule); 2 is refused as bad input. What the generator must never do, whatever
the robot, is break its own parts: :data:`SELF_FAULTS` are the checks that say so (parts that
overlap, a mesh that is not closed, an eyelet away from where its routing puts it, a gear that is not
the one the plan made), and a crash
(any other exit, or a traceback) or a time-out is never right either. The run prints the table
and returns non-zero when any robot shows one of those.
"""
from __future__ import annotations

import argparse
import collections
import dataclasses
import functools
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from .robots import lab_robot

SEED = 20261125
ROBOTS = 100
TIME_LIMIT_S = 900          # one robot's whole build and checks (today's slowest: about 2 minutes alone)
# the generator's own faults: parts that overlap, an open mesh, an eyelet off its routing, and the gear
# checks whose only fix is to rebuild (the files are not the gear the plan made, or were measured wrong)
SELF_FAULTS = ("part.interference", "part.mesh", "eyelet.position", "eyelet.unexpected", "gear.parts",
               "gear.center_distance", "gear.shaft_angle", "gear.teeth", "gear.starts")
HWGEN = Path(sys.executable).with_name("hwgen")
CAD_FAILED = "the CAD kernel could not make"     # exit 2 for a part its plan described: the generator's fault


@dataclass
class Outcome:
    index: int
    exit: int | str                  # 0, 1, 2, "crash", "timed out" or "cad failed"
    failed: list[str] = field(default_factory=list)       # ids of the failed error checks
    message: str = ""                # exit 2: the one line; a crash: the last lines of stderr
    seconds: float = 0.0
    robot: str = ""                  # what the robot is, in a few words
    cpu_seconds: float | None = None     # CPU of the build and every process it started (--jobs 1; else None)

    @property
    def self_faults(self) -> list[str]:
        return sorted({f for f in self.failed if f in SELF_FAULTS})

    @property
    def broken(self) -> bool:
        return self.exit in ("crash", "timed out", "cad failed") or bool(self.self_faults)


def describe(doc: dict) -> str:
    """What the robot is, in a few words: disks, strip, its ends, process and tendons."""
    def kind(t: dict) -> str:
        f = t["routing"].get("function")
        k = "table" if f is None or "table" in t["routing"] else (
            f"cosine {f.get('axis', 'z')}" if f["kind"] == "cosine" else f["kind"])
        return k + (" mirrored" if t["routing"].get("mirror") else "")
    kinds = collections.Counter(kind(t) for t in doc["tendons"])
    bb, dk = doc["backbone"], doc["disks"]
    return (f"{dk['count']} disks{' (listed)' if dk.get('stations') else ''} Ø{dk['outer_diameter']:g} × "
            f"{dk.get('thickness', 0):g}/{dk.get('end_thickness', 0):g} over {bb['length']:g} mm, strip "
            f"{bb['height']:g} × {bb['thickness']:g} + {bb.get('extra_base', '-')}/{bb.get('extra_tip', 0):g}, "
            f"slot ±{dk['slot_clearance']:g}, {doc['process']['material']}, tendons "
            + ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
            + f" on {len(doc['tensioner']['channels'])} channel(s)")


def _children_cpu() -> float:
    """User and system CPU of this process's children that have ended and been waited for."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def _reaping() -> bool:
    """Make this process the reaper of what its children leave behind (Linux's PR_SET_CHILD_SUBREAPER):
    the fork server a build starts, and its part workers, outlive the build's own process, and their CPU
    counts in this one's children once reaped. False where that cannot be done."""
    import ctypes
    try:
        return ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _reap() -> None:
    """Wait for every process a build left behind (one robot at a time: nothing else is a child then)."""
    while True:
        try:
            os.wait4(-1, 0)
        except ChildProcessError:
            return


def build_one(index: int, doc: dict, root: Path, reap: bool = False) -> Outcome:
    """Build one robot with the CLI in a child process and read what it says; ``reap``: this process
    reaps what the build leaves behind (:func:`_reaping`), and the robot's CPU is counted."""
    src = root / f"{doc['design']}.yaml"
    src.write_text(yaml.safe_dump(doc, sort_keys=False))
    env = {**os.environ, "HWGEN_RENDER_BACKEND": "none", "HWGEN_CHECK_SAMPLES": os.environ.get(
        "HWGEN_CHECK_SAMPLES", "64")}
    t0, cpu0 = time.monotonic(), _children_cpu()
    try:
        r = subprocess.run([str(HWGEN), "build", str(src), "--out", str(root / "out"), "-q"], env=env,
                           capture_output=True, text=True, timeout=TIME_LIMIT_S)
    except subprocess.TimeoutExpired:
        if reap:
            _reap()
        return Outcome(index, "timed out", seconds=TIME_LIMIT_S, robot=describe(doc),
                       cpu_seconds=_children_cpu() - cpu0 if reap else None)
    dt = time.monotonic() - t0
    if reap:
        _reap()
    out = Outcome(index, r.returncode, seconds=dt, robot=describe(doc),
                  cpu_seconds=_children_cpu() - cpu0 if reap else None)
    if r.returncode not in (0, 1, 2) or "Traceback" in r.stderr:
        out.exit, out.message = "crash", " | ".join(r.stderr.strip().splitlines()[-3:])
    elif r.returncode == 2:
        out.message = (r.stderr.strip().splitlines() or [""])[-1]
        if CAD_FAILED in r.stderr:          # a plan the CAD kernel could not make: hwgen's, not the lab's
            out.exit = "cad failed"
    else:
        report = root / "out" / doc["design"] / "report.json"
        checks = json.loads(report.read_text())["checks"] if report.exists() else []
        out.failed = sorted({c["id"] for c in checks if not c["passed"] and c["severity"] == "error"})
    return out


def run(robots: int = ROBOTS, seed: int = SEED, jobs: int = 2, keep: Path | None = None,
        echo=functools.partial(print, flush=True), first: int = 0, results: Path | None = None,
        only: set[int] | None = None) -> list[Outcome]:
    """Robots ``first`` to ``robots - 1`` of the seeded draw (the same robots whatever ``first``),
    each outcome appended to ``results`` (JSON lines) as it comes."""
    rng = np.random.default_rng(seed)
    docs = [lab_robot(rng, f"robot{i:03d}") for i in range(robots)]
    with tempfile.TemporaryDirectory() as tmp:
        root = keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        reap = jobs == 1 and _reaping()
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            futures = [pool.submit(build_one, i, d, root, reap) for i, d in enumerate(docs)
                       if i >= first and (only is None or i in only)]
            outcomes = []
            for f in futures:
                o = f.result()
                outcomes.append(o)
                if results:
                    with open(results, "a") as fh:
                        fh.write(json.dumps(dataclasses.asdict(o)) + "\n")
                echo(f"  {o.index:3d}  exit {o.exit!s:9}  {o.seconds:5.0f} s{f' ({o.cpu_seconds:.0f} s CPU)' if o.cpu_seconds is not None else ''}  {o.robot}"
                     + (f"\n        failed: {', '.join(o.failed)}" if o.failed else "")
                     + (f"\n        {o.message}" if o.message else ""))
    return outcomes


def table(outcomes: list[Outcome], seed: int = SEED) -> str:
    """Exit codes, the failed checks by kind, and every robot the generator broke."""
    n = len(outcomes)
    by_exit = collections.Counter(str(o.exit) for o in outcomes)
    lines = [f"{n} robots (seed {seed}): " + ", ".join(f"exit {k}: {v}" for k, v in sorted(by_exit.items())),
             f"built (exit 0 or 1): {by_exit['0'] + by_exit['1']} of {n}", "", "| failed check | robots |", "|---|---:|"]
    kinds = collections.Counter(f for o in outcomes for f in o.failed)
    lines += [f"| {k} | {v} |" for k, v in kinds.most_common()]
    # "error: FILE: FIELD: what is wrong": by the field
    refused = collections.Counter(o.message.split(": ")[2] if o.message.count(": ") >= 2 else o.message
                                  for o in outcomes if o.exit == 2)
    if refused:
        lines += ["", "| refused (exit 2) at | robots |", "|---|---:|"] + [f"| {k} | {v} |" for k, v in
                                                                          refused.most_common()]
    broken = [o for o in outcomes if o.broken]
    lines += ["", f"broken by the generator (crash, time-out, CAD failure, {', '.join(SELF_FAULTS)}): {len(broken)}"]
    lines += [f"  robot {o.index:03d}: {o.exit} {o.self_faults or ''} {o.message}" for o in broken]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=ROBOTS)
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--keep", type=Path, help="build into this folder and keep it")
    ap.add_argument("--first", type=int, default=0, help="start at this robot of the draw (resume a run)")
    ap.add_argument("--only", type=lambda v: {int(i) for i in v.split(",")}, help="just these robots, e.g. 3,17")
    ap.add_argument("--results", type=Path, help="append each outcome to this JSON-lines file; the table "
                                                 "is of every outcome in it")
    a = ap.parse_args()
    outcomes = run(a.robots, a.seed, a.jobs, a.keep, first=a.first, results=a.results, only=a.only)
    if a.results:       # every robot's latest outcome in the file
        latest = {o.index: o for o in (Outcome(**json.loads(line)) for line in a.results.read_text().splitlines()
                                       if line.strip())}
        outcomes = [latest[i] for i in sorted(latest)]
    print()
    print(table(outcomes, a.seed))
    return 1 if any(o.broken for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
