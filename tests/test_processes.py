"""The worker processes: forks of one server that imported the CAD kernel once, each in the
environment of the moment it is asked for."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from hwgen import processes
from hwgen.engine import WORKER_PRELOAD


def _state(name: str) -> tuple[bool, str | None, int]:
    return "cadquery" in sys.modules, os.environ.get(name), os.getppid()


@pytest.mark.slow         # three servers, each importing the CAD kernel (about 2 s of CPU apiece, in children)
def test_a_worker_starts_with_the_kernel_imported_and_the_callers_environment(monkeypatch):
    monkeypatch.setenv("HWGEN_TEST_PROCESSES", "before")
    with processes.pool(1, WORKER_PRELOAD) as pool:
        imported, seen, parent = pool.submit(_state, "HWGEN_TEST_PROCESSES").result()
    assert imported                 # preloaded by the server, not imported by the job
    assert seen == "before"
    assert parent != os.getpid()    # a fork of the server, not of this process
    monkeypatch.setenv("HWGEN_TEST_PROCESSES", "after")         # the server started before this
    with processes.pool(1, WORKER_PRELOAD) as pool:
        assert pool.submit(_state, "HWGEN_TEST_PROCESSES").result()[1] == "after"
    monkeypatch.delenv("HWGEN_TEST_PROCESSES")
    with processes.pool(1, WORKER_PRELOAD) as pool:
        assert pool.submit(_state, "HWGEN_TEST_PROCESSES").result()[1] is None


def test_the_servers_quick_exit_is_the_servers_alone():
    """Imported anywhere but in the fork server's start, hwgen.processes.server changes nothing:
    the process ends the interpreter's way, with its own exit code."""
    r = subprocess.run([sys.executable, "-c", "import atexit, hwgen.processes.server; "
                        "atexit.register(print, 'handlers ran'); raise SystemExit(7)"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 7 and "handlers ran" in r.stdout
