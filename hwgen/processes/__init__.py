"""The processes a build starts for the CAD kernel and the gear checks: forked from one server
process that imported their libraries once.

A worker started with ``spawn`` imports CadQuery (OCP and the VTK it imports) again, each on a
machine already busy with the other workers, and a plain ``fork`` of a process that has built
CadQuery geometry hangs (FIELD-NOTES). The ``forkserver`` start method sits between: one server
process, started on first use, imports the modules its first caller names and builds no geometry; each worker is a
fork of it, ready at once. Like spawn, a worker inherits nothing of the build's own state (its
threads, meshes or solids): only the server's imports. The server lives as long as the process
that started it (a test session reuses it) and inherits that process's environment as it was
then; a worker takes the environment of the moment it is asked for (:func:`adopt_env`), as a
spawned one would.
"""
from __future__ import annotations

import os

# the server's environment besides the starting process's, where not set: numpy's BLAS in one
# thread (read once, when numpy is imported, so in the server): the workers' products are small
# (vertices placed, (n, 3) @ (3, 3)) and the workers already share the cores with each other and
# the checks; the renderer found a second thread spent more waiting than computing
SERVER_ENV = {"OPENBLAS_NUM_THREADS": "1"}


def context(preload: tuple[str, ...]):
    """The ``forkserver`` context, its server started if it is not running: it imports the modules
    ``preload`` names (the server started first keeps its own: the caller names the same ones)."""
    import multiprocessing
    from multiprocessing import forkserver
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(list(preload))
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


def elsewhere(job, *args, name: str, preload: tuple[str, ...]):
    """A started process (a fork of the server, :func:`context`) running ``job(*args)`` in this
    process's environment; the caller joins it."""
    p = context(preload).Process(target=_call, args=(dict(os.environ), job, *args), name=name, daemon=True)
    p.start()
    return p


def pool(workers: int, preload: tuple[str, ...]):
    """A process pool of ``workers`` forks of the server (:func:`context`), each in this process's environment."""
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(max_workers=workers, mp_context=context(preload), initializer=adopt_env,
                               initargs=(dict(os.environ),))
