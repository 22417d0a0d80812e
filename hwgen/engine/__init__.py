"""How a build is carried out, below the order of its stages (:mod:`hwgen.pipeline`):

* :mod:`.context`: what a build's stages share (:class:`~.context.Build`), what a stage after
  the files is given (:class:`~.context.StageInput`), each file hashed once a build;
* :mod:`.units`: the part cache: each unit of parts built, or copied from the cache, and its
  files placed; assembly.step; the strip's template;
* :mod:`.stagecache`: the stages after the files through the cache;
* :mod:`.concurrency`: the worker processes (forks of one server that imported CadQuery once),
  the checks' work ahead in threads of the build's own process, the gear checks' process.

This module itself imports nothing but :mod:`hwgen.processes`, so that the command line can
start the workers' server (:func:`start_server`) before it reads the design.
"""
from __future__ import annotations

from .. import processes

# what the workers import, once, in their server (a module that cannot be imported there is
# imported by each worker, which then meets the error as it would have): CadQuery, the code that
# builds and exports the units (whose functions the workers run) and the gear checks' meshes
WORKER_PRELOAD = ("hwgen.processes.server", "cadquery", "hwgen.engine.units", "hwgen.checks.gear_mesh")


def start_server() -> None:
    """The workers' server started, if it is not running (it imports :data:`WORKER_PRELOAD`)."""
    processes.context(WORKER_PRELOAD)
