"""The processes a build starts for the CAD kernel and the gear checks: forked from one server
process that imported their libraries once.

A worker started with ``spawn`` imports CadQuery (OCP and the VTK it imports) again: 1.3-3 s of
CPU each, on a machine already busy with the other workers, and a plain ``fork`` of a process that has built
CadQuery geometry hangs (FIELD-NOTES). The ``forkserver`` start method sits between: one server
process, started on first use, imports :data:`PRELOAD` and builds no geometry; each worker is a
fork of it, ready at once. Like spawn, a worker inherits nothing of the build's own state (its
threads, meshes or solids): only the server's imports. The server lives as long as the process
that started it (a test session reuses it) and inherits that process's environment as it was
then; a worker takes the environment of the moment it is asked for (:func:`adopt_env`), as a
spawned one would.
"""
from __future__ import annotations

import os

# what the workers import, once, in the server (a module that cannot be imported there is
# imported by each worker, which then meets the error as it would have); hwgen.cad before CadQuery,
# so that CadQuery starts without all of VTK (hwgen.cad._VtkWhileOcpStarts)
PRELOAD = ("hwgen.processes.server", "hwgen.cad", "cadquery", "hwgen.pipeline", "hwgen.checks.gear_mesh")

# the server's environment besides the starting process's, where not set: numpy's BLAS in one
# thread (read once, when numpy is imported, so in the server): the workers' products are small
# (vertices placed, (n, 3) @ (3, 3)) and the workers already share the cores with each other and
# the checks; the renderer found a second thread spent more waiting than computing
SERVER_ENV = {"OPENBLAS_NUM_THREADS": "1"}


def context():
    """The ``forkserver`` context, its server started (with :data:`PRELOAD`) if it is not running."""
    import multiprocessing
    from multiprocessing import forkserver
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    added = {k: v for k, v in SERVER_ENV.items() if k not in os.environ}
    if added:
        os.environ.update(added)
        try:
            forkserver.ensure_running()
        finally:
            for k in added:
                os.environ.pop(k, None)
    return ctx


def adopt_env(env: dict[str, str]) -> None:
    """This process's environment becomes ``env`` (a worker's first step: the environment of the
    process that asked for it, not the server's)."""
    os.environ.clear()
    os.environ.update(env)


def _call(env: dict[str, str], job, *args):
    adopt_env(env)
    return job(*args)


def elsewhere(job, *args, name: str):
    """A started process (a fork of the server) running ``job(*args)`` in this process's
    environment; the caller joins it."""
    p = context().Process(target=_call, args=(dict(os.environ), job, *args), name=name, daemon=True)
    p.start()
    return p


def pool(workers: int):
    """A process pool of ``workers`` forks of the server, each in this process's environment."""
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(max_workers=workers, mp_context=context(), initializer=adopt_env,
                               initargs=(dict(os.environ),))
