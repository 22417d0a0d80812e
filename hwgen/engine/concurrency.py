"""What runs beside a build's stages: the worker processes that build the parts (:class:`Workers`),
the checks' work ahead in threads of the build's own process (:class:`Ahead`), the gear checks
in a process of their own, and the stages that read only the parts' files, started in threads
as soon as those are in (:func:`start_beside`).

Everything here hands its results over through the store (the cache, or a build's own): a value
made ahead is the value the stage would make itself, so the outputs are those of the stages run
one after the other."""
from __future__ import annotations

import contextlib
import contextvars
import os
import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

from .. import cache, heap, processes
from ..atomic import side_folder
from ..cad.families import units
from ..cad.manifest import Added, Manifest, ManifestPart
from ..checks.meshes import reading_early
from ..model.plan import Plan
from . import WORKER_PRELOAD
from .context import Build, Hashes, StageInput
from .stagecache import cached_stage

MAX_DEFAULT_JOBS = 4     # workers a build starts unless told: each holds the CAD kernel (0.4-0.8 GB)


def default_jobs() -> int:
    """Worker processes a build uses unless told: one per core this process may run on (at most
    :data:`MAX_DEFAULT_JOBS`); a build starts no more than it has units to build."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores, MAX_DEFAULT_JOBS))


class Workers:
    """Worker processes for the CAD kernel (``jobs`` of them, forks of the server that imported
    CadQuery once: :mod:`hwgen.processes`). This process then never imports CadQuery: its memory
    holds the checks alone, and the workers' memory is returned as they end, while the checks
    start (their exit is not waited for). The work ahead (``ahead``) starts with them: this
    process would only wait for them meanwhile."""

    def __init__(self, jobs: int, ahead: Ahead | None):
        self.pool = processes.pool(jobs, WORKER_PRELOAD)
        self.ahead = ahead

    def __enter__(self) -> Workers:
        if self.ahead is not None:
            self.ahead.start()
        return self

    def __exit__(self, *exc) -> None:
        # not waited for: a worker's exit (the CAD kernel's memory handed back) takes a while, and
        # nothing after needs it; the workers end on their own
        self.pool.shutdown(wait=False, cancel_futures=True)

    def submit(self, job, *args) -> Future:
        return self.pool.submit(job, *args)


class Ahead:
    """What the checks need from the plan alone, or from a few parts' files, worked out in a thread
    of this process while worker processes build the parts: the tension checks' statics sweeps
    (:func:`hwgen.checks.tension.sweeps`), then, as each unit's files come into the folder
    (:meth:`placed`), its STLs read for the checks (:func:`hwgen.checks.meshes.read_early`). Once
    every part's files and the strip's template are in (:meth:`measure`), a second thread measures
    every check that reads them (:func:`hwgen.checks.run.measure`) while a worker writes
    assembly.step, and the gear checks of the tensioner's worms and wheels are made beside it in a
    process of their own (meshes and manifold3d solids that would add to the measurement's memory
    here), which the measurement meets in the store.

    The sweeps and the gear checks are kept in the store as the checks remember them, so the
    checks find them there, or wait for the one being made (:func:`hwgen.cache.remembered` computes
    under the entry's lock): the values are the ones the checks would compute themselves. The
    threads go on beside the stages after the files; the build joins them at its end. A failure
    here is left for the checks to meet and report, and kept in :attr:`failures` (the build says
    what failed ahead, so a defect here does not hide behind the checks' second try)."""

    def __init__(self, store: cache.Store, plan: Plan, taken: threading.Event, hashes: Hashes):
        self.store, self.plan, self.thread, self.hashes = store, plan, None, hashes
        self.taken = taken              # set once the checks took the measurement (:meth:`measured`)
        self.jobs: queue.SimpleQueue = queue.SimpleQueue()
        self.meshes: dict = {}          # the parts' STLs read early, for the checks (checks.meshes.reading_early)
        self.tensioner: dict[int, list] = {}    # the tensioner's units placed so far (their parts), and its parts
        self.tensioner_parts = sum(u.count for f, _, u in units(plan) if f.name == "tensioner")
        self.measuring: threading.Thread | None = None     # the measurement (:meth:`measure`), once asked for
        self.started = threading.Event()                    # ... and started
        self.gears = threading.Event()      # set once the gear checks' process is done, or none is to be started
        self.found: tuple[str, object] | None = None      # (key of the files measured, checks.run.Measured)
        self.failures: list[str] = []   # what failed here ("measure: ValueError: ..."), done again by the checks

    def start(self) -> None:
        if self.thread is None:
            self.thread = threading.Thread(target=self._run, name="hwgen-ahead", daemon=True)
            self.thread.start()

    def placed(self, index: int, family: str, folder: Path, entries: list[dict]) -> None:
        """The ``index``-th unit's files are in ``folder`` (its manifest ``entries``): its STLs read
        for the checks (and a tensioner unit's entries kept for its gear checks, which read the
        worms' and wheels' files and entries alone)."""
        if self.thread is not None:
            self.jobs.put(("meshes", folder, [dict(e) for e in entries]))
            if family == "tensioner":
                self.tensioner[index] = [dict(e) for e in entries]

    def measure(self, folder: Path, manifest: Manifest) -> None:
        """Every part's files and the strip's template are in ``folder`` (``manifest``: the parts'
        entries and the design report, as the checks will read them): every check that reads
        them, measured in a thread of its own (when this one runs: parts were built), started once
        this thread has read the STLs placed so far (each is read once), which then has the
        tensioner's gear checks made beside it in a process of their own; the checks take the
        measurement (:meth:`measured`) when their files and manifest give the same key."""
        if self.thread is None:
            return
        key = measure_key(self.hashes, folder, manifest, self.plan.check.samples)
        self.measuring = threading.Thread(target=self._measure, args=(folder, manifest.copy(), key),
                                          name="hwgen-measure", daemon=True)
        self.jobs.put(("measure", folder, None))
        gears = [e for i in sorted(self.tensioner) for e in self.tensioner[i]]
        if self.store.enabled and len(gears) == self.tensioner_parts:
            self.jobs.put(("gears", folder, gears))
        else:
            self.gears.set()

    def _measure(self, folder: Path, manifest: Manifest, key: str) -> None:
        from ..checks.run import measure
        with cache.using(self.store), reading_early(self.meshes):
            try:
                self.found = (key, measure(folder, manifest, self.plan, self._gears_made))
            except Exception as e:      # the checks measure again and report what fails
                self._failed("the checks' measurement", e)

    def _gears_made(self) -> None:
        """Wait for the gear checks' process (started beside the measurement): the measurement's gear
        checks then read its values from the cache. Without the wait they would make in this process
        any value that process had not begun (it takes each entry's lock only while making it)."""
        while not self.gears.wait(1.0):
            if not self.thread.is_alive():
                return

    def _failed(self, what: str, e: Exception) -> None:
        self.failures.append(f"{what}: {type(e).__name__}: {e}")

    def measured(self, folder: Path, manifest: Manifest):
        """What :meth:`measure` found (waiting for it), when it measured the files now in
        ``folder`` against ``manifest`` (:func:`measure_key`); None when it measured others, was
        not asked, or failed."""
        if self.measuring is None:
            return None
        while not self.started.wait(1.0):
            if not self.thread.is_alive():
                return None
        self.measuring.join()
        self.taken.set()
        found, self.found = self.found, None       # let go of it with the report (its measured disks are large)
        key = measure_key(self.hashes, folder, manifest, self.plan.check.samples)
        return found[1] if found is not None and found[0] == key else None

    def _run(self) -> None:
        from ..checks import run as _      # the checks' modules and libraries, imported while this process waits
        from ..checks.meshes import read_early
        from ..checks.tension import sweeps
        from ..outputs.plots import pyplot
        pyplot()                           # and the checks' plots'
        with cache.using(self.store):
            if self.store.enabled:
                try:
                    sweeps(self.plan)
                except Exception as e:  # the checks run it again and report what it raises
                    self._failed("the tension sweeps", e)
                heap.trim()
            with reading_early(self.meshes):
                while (job := self.jobs.get()) is not None:
                    kind, folder, what = job
                    try:
                        if kind == "meshes":
                            for e in what:
                                read_early(ManifestPart.of(e).stl_in(folder))
                        elif kind == "measure":
                            self.measuring.start()
                            self.started.set()
                        elif not gears_remembered(folder, what, self.plan):
                            processes.elsewhere(gear_checks_in_child, folder, what, self.plan, self.store,
                                                name="hwgen-gears", preload=WORKER_PRELOAD).join()
                    except Exception as e:  # the checks read, measure or check the gears again
                        self._failed({"meshes": "reading the STLs", "measure": "starting the measurement"}
                                     .get(kind, "the gear checks"), e)
                    finally:
                        if kind == "gears":
                            self.gears.set()

    def join(self) -> None:
        if self.thread is not None:
            self.jobs.put(None)
            self.thread.join()
        if self.started.is_set():
            self.measuring.join()

    def abandon(self) -> None:
        """The build failed: the threads end after what they are doing, unwaited for."""
        self.jobs.put(None)


def gear_checks_in_child(folder: Path, parts: list[dict], plan: Plan, store: cache.Store) -> None:
    """The gear checks of the worms and wheels among ``parts`` (manifest entries), made and kept in
    ``store`` as the checks remember them (:func:`hwgen.checks.gear_mesh.gear_checks`), run in a
    process of their own (:func:`hwgen.processes.elsewhere`), whose memory (meshes, their copies
    posed, manifold3d solids) then never adds to the build's while it measures the rest. What it
    raises stays here, unprinted (a child's uncaught exception would print its traceback to the
    user's terminal): the checks make the same measurement in the build's own process and report
    what it raises there, with its traceback only under HWGEN_DEBUG."""
    from ..checks.gear_mesh import gear_checks
    # what it raises is the checks' to report (in the build's own process, see above)
    with cache.using(store), contextlib.suppress(Exception):
        gear_checks(folder, parts, plan)


def gears_remembered(folder: Path, parts: list[dict], plan: Plan) -> bool:
    """Whether the active store holds every measurement the gear checks of the worms and wheels
    among ``parts`` make (an edit that moved the tensioner but kept its gearing): then no process
    is started to make them."""
    from ..checks.gear_mesh import gear_checks
    try:
        with cache.recalling_only():
            gear_checks(folder, parts, plan)
    except cache.NotRemembered:
        return False
    return True


def measure_key(hashes: Hashes, folder: Path, manifest: Manifest, samples: int) -> str:
    """What :func:`hwgen.checks.run.measure` reads: every file in the folder but assembly.step (which
    only the files' own checks read), the manifest but its ``files`` (of which it reads only the
    strip template's path) and the as-built samples the checks draw (``samples``: the plan's
    ``check.samples``, as the build's options set it)."""
    from ..checks.run import backbone_template
    return cache.key("measured", {p: sha for p, sha in hashes.files(folder).items() if p != "assembly.step"},
                     replace(manifest, files={}), backbone_template(manifest), samples)


# ---------------------------------------------------------------- stages beside the others

@dataclass
class Beside:
    """A stage started beside the others, in a folder of hard links to the part files."""

    folder: Path                    # where it runs
    hashes: Hashes
    before: dict[str, str]          # the files that folder held when it started
    reused: list[str]               # its name, when the cache gave what it made
    future: Future                  # what it gives (:class:`~.context.StageResult`)

    def join(self, folder: Path) -> Added:
        """What the stage added to the manifest, its new files moved into ``folder``."""
        added = self.future.result().added
        for path in self.hashes.files(self.folder):
            if path not in self.before:
                (folder / path).parent.mkdir(parents=True, exist_ok=True)
                os.replace(self.folder / path, folder / path)
        return added


def start_beside(b: Build, manifest: Manifest, stages: list[tuple[str, Callable]],
                 after_measured: tuple[str, ...]) -> dict[str, Beside]:
    """The ``stages`` (name, stage) started in threads, each in a folder of hard links to the part
    files (a build starts them as soon as every part's files are in: they read nothing else);
    those named in ``after_measured`` wait for the checks' measurement to be over (its meshes and
    theirs, read from the same files, would be in memory at once)."""
    pool = b.stack.enter_context(ThreadPoolExecutor(max_workers=max(1, len(stages))))
    out = {}
    for name, stage in stages:
        where = b.stack.enter_context(side_folder(b.folder, b.target))
        reused: list[str] = []
        with cache.using(b.store):
            job = contextvars.copy_context().run
        gate = b.measured if name in after_measured else None
        given = StageInput(b.plan, where, manifest.copy(), options=b.options)
        out[name] = Beside(where, b.hashes, b.hashes.files(where), reused,
                           pool.submit(job, _gated, gate, cached_stage, b.store, b.hashes, name, stage, given, reused))
    return out


def _gated(gate: threading.Event | None, fn, *args):
    if gate is not None:
        gate.wait()
    return fn(*args)
