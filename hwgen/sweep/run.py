"""Running a sweep on Dask, and its results as Parquet.

The variants are cut into batches (:data:`BATCH` per level, or the sweep file's ``batch``); each
batch is one Dask task (:func:`hwgen.sweep.levels.evaluate_batch`) that resolves, validates and
evaluates its variants on a worker and returns their rows. The base design is sent to the
workers once. By default a local cluster of worker processes (one per core, one thread each) is
started for the sweep and stopped after it; ``scheduler="tcp://HOST:PORT"`` uses a running Dask
cluster instead; ``scheduler="inline"`` runs the batches in this process, without Dask.

Results: ``OUT/sweeps/<name>/<level>/part-*.parquet``, one file per finished batch, each written
whole or not at all (:func:`hwgen.atomic.atomic_path`): an interrupted sweep keeps every batch it
finished. A rerun reads the hashes already there and the workers skip those variants, so a sweep
run twice, or interrupted and run again, has every design exactly once. Read them with
``pyarrow.parquet.read_table(folder)`` (or pandas, polars, DuckDB).
"""
from __future__ import annotations

import json
import os
import threading
import time
import uuid
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from ..atomic import atomic_path
from ..errors import InputError
from . import levels
from .records import METRICS, EvalOptions, Row
from .spec import Loaded, variants

BATCH = {"lengths": 256, "robust": 4, "coupling": 1, "build": 1}
PART_GLOB = "part-*.parquet"
FLOAT_COLUMNS = METRICS + ("cpu_s",)


@dataclass
class Outcome:
    folder: Path                   # the level's results folder
    total: int                     # variants in the sweep
    done_before: int               # rows already in the results when this run started
    evaluated: int                 # rows this run added
    seconds: float                 # wall time from the first task sent to the last row written
    workers: int
    start_seconds: float           # starting the local cluster (0 for an existing one or inline)
    cpu_s: float                   # the workers' CPU time for this run's rows
    verdicts: dict = field(default_factory=dict)


def results_folder(loaded: Loaded, out_root: Path) -> Path:
    return Path(out_root) / "sweeps" / loaded.spec.sweep / loaded.spec.level


def schema(loaded: Loaded) -> pa.Schema:
    kinds = {"float": pa.float64(), "int": pa.int64(), "json": pa.string()}
    fields = [pa.field("variant", pa.int64()), pa.field("hash", pa.string()), pa.field("level", pa.string())]
    fields += [pa.field(name, kinds[loaded.columns[name]]) for name in loaded.names]
    fields += [pa.field("verdict", pa.string()), pa.field("message", pa.string()), pa.field("decoupled", pa.bool_())]
    fields += [pa.field(m, pa.float64()) for m in FLOAT_COLUMNS]
    fields += [pa.field("checks_failed", pa.int64()), pa.field("per_tendon", pa.string()), pa.field("kept", pa.string())]
    return pa.schema(fields)


def table(loaded: Loaded, rows: list[Row]) -> pa.Table:
    """Rows as a table of :func:`schema`; an axis whose values are not numbers is stored as JSON."""
    sch = schema(loaded)
    cols: dict[str, list] = {f.name: [] for f in sch}
    for row in rows:
        for name, v in zip(loaded.names, row.values):
            kind = loaded.columns[name]
            cols[name].append(json.dumps(v, sort_keys=True) if kind == "json" else v)
        for f in sch:
            if f.name not in loaded.names:
                cols[f.name].append(levels.finite(getattr(row, f.name)))
    return pa.table(cols, schema=sch)


def read(folder: Path) -> pa.Table | None:
    """Every row in a results folder (None when there is none yet)."""
    parts = sorted(Path(folder).glob(PART_GLOB))
    if not parts:
        return None
    return pa.concat_tables([pq.read_table(p) for p in parts], promote_options="default")


def _done(folder: Path) -> set[str]:
    t = read(folder)
    return set() if t is None else set(t.column("hash").to_pylist())


def _batches(loaded: Loaded) -> list[list[tuple[int, tuple]]]:
    size = loaded.spec.batch or BATCH[loaded.spec.level]
    vs = [(v.index, v.values) for v in variants(loaded.spec)]
    return [vs[i:i + size] for i in range(0, len(vs), size)]


@contextmanager
def _worker_environment():
    """Dask's nannies start each worker with MALLOC_TRIM_THRESHOLD_=65536, so glibc hands freed heap
    back to the system at every 64 KiB; the CAD kernel and numpy allocate and free far more than
    that, and the worker then spends its time in page faults: one worker building 2 variants took
    94 s (26.6 s of it in the kernel) with it and 72 s (5.3 s) without, as fast as the same two
    inline. The local cluster's workers start without it (glibc's own threshold); its other
    settings (one BLAS and OpenMP thread a worker) stay. A cluster started elsewhere (--scheduler)
    keeps its own settings."""
    import dask
    env = {k: v for k, v in dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
           if k != "MALLOC_TRIM_THRESHOLD_"}
    with dask.config.set({"distributed.nanny.pre-spawn-environ": env}):
        yield


class _Ready:
    """A result worked out in this process, as a Dask future hands one over."""

    def __init__(self, key: str, value):
        self.key, self._value = key, value

    def result(self):
        return self._value

    def release(self) -> None:
        pass


class _InOrder:
    """``as_completed`` for results worked out in this process: in the order they were added, and
    more may be added while it is read."""

    def __init__(self):
        self._queue: list = []

    def add(self, future) -> None:
        self._queue.append(future)

    def __iter__(self):
        while self._queue:
            yield self._queue.pop(0)


@dataclass
class Pool:
    """Where batches run: a Dask client (a local cluster started for the run, or a running one), or
    this process (``client`` None, ``scheduler="inline"``)."""

    client: object | None
    workers: int
    start_seconds: float           # starting the local cluster (0 for an existing one or inline)

    def submit(self, fn, *args, key: str):
        """fn(*args) on a worker (a future), or here and now."""
        if self.client is None:
            return _Ready(key, fn(*args))
        return self.client.submit(fn, *args, key=key, pure=False)

    def scatter(self, value):
        """A value every task takes, sent to each worker once."""
        return value if self.client is None else self.client.scatter(value, broadcast=True)

    def completed(self):
        """An ``as_completed`` to add futures to as they are submitted."""
        if self.client is None:
            return _InOrder()
        from distributed import as_completed
        return as_completed()


@contextmanager
def pool(scheduler: str | None = None, workers: int | None = None):
    """The :class:`Pool` of a run: ``None`` starts a local cluster (one single-threaded worker process
    per core, or ``workers``) and stops it after; ``tcp://HOST:PORT`` uses a running scheduler;
    ``"inline"`` runs everything in this process. The workers have imported what every batch needs
    (:func:`hwgen.sweep.levels.warm`) before it is handed over."""
    if scheduler == "inline":
        yield Pool(None, 1, 0.0)
        return
    from distributed import Client, LocalCluster

    t_start = time.perf_counter()
    cluster = None
    if scheduler is None:
        n = workers or os.cpu_count() or 1
        with _worker_environment():
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   silence_logs=40)
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=30)
        except (OSError, TimeoutError, ValueError) as e:
            raise InputError(scheduler, "--scheduler", f"cannot reach the Dask scheduler ({e})") from None
    try:
        n_workers = len(client.scheduler_info()["workers"])
        if n_workers == 0:
            client.wait_for_workers(1, timeout=60)
            n_workers = len(client.scheduler_info()["workers"])
        client.run(levels.warm)           # imports and the compiled taut kernel, before the clock starts
        yield Pool(client, n_workers, time.perf_counter() - t_start)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run(loaded: Loaded, out_root: Path, scheduler: str | None = None, workers: int | None = None,
        progress: bool = True, cache=True) -> Outcome:
    """Run the sweep (see the module's docstring); rows already in the results are not evaluated again."""
    folder = results_folder(loaded, out_root)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(out_root, "--out", f"cannot write the results here ({e.strerror or e})") from None
    done = _done(folder)
    batches = _batches(loaded)
    total = sum(len(b) for b in batches)
    options = EvalOptions(robust_samples=loaded.spec.robust_samples, keep=tuple(loaded.spec.keep),
                          out=str(folder.parent), cache=cache)
    args = (loaded.base, loaded.names, loaded.spec.level)
    written, cpu, verdicts = set(done), 0.0, {}

    def write(rows: list[Row]) -> None:
        nonlocal cpu
        rows = [r for r in rows if r.hash not in written]        # two variants of one design: one row
        if not rows:
            return
        with atomic_path(folder / f"part-{rows[0].variant:09d}-{uuid.uuid4().hex[:8]}.parquet") as tmp:
            pq.write_table(table(loaded, rows), tmp)
        for r in rows:
            written.add(r.hash)
            cpu += r.cpu_s
            verdicts[r.verdict] = verdicts.get(r.verdict, 0) + 1

    with pool(scheduler, workers) as p:
        t0 = time.perf_counter()
        if p.client is None:
            for b in batches:
                write(levels.evaluate_batch(b, *args, done, options))
        else:
            client = p.client
            options = replace(options, numba_threads=1)
            # the base design and the hashes already done go to every worker once, not with every task
            base, seen = client.scatter([loaded.base, frozenset(done)], broadcast=True)
            futures = [client.submit(levels.evaluate_batch, b, base, loaded.names, loaded.spec.level, seen, options,
                                     key=f"sweep-{loaded.spec.sweep}-{b[0][0]}-{uuid.uuid4().hex[:6]}", pure=False)
                       for b in batches]
            bar = None
            if progress and futures:
                from distributed import progress as dask_progress
                bar = threading.Thread(target=dask_progress, args=futures, kwargs={"notebook": False}, daemon=True)
                bar.start()
            from distributed import as_completed
            for fut in as_completed(futures):
                write(fut.result())
                fut.release()
            if bar is not None:
                bar.join(timeout=5)
                print()
        seconds = time.perf_counter() - t0
    return Outcome(folder=folder, total=total, done_before=len(done), evaluated=len(written) - len(done),
                   seconds=seconds, workers=p.workers, start_seconds=p.start_seconds, cpu_s=cpu, verdicts=verdicts)
