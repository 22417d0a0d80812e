"""The worker processes: forks of one server that imported the CAD kernel once, each in the
environment of the moment it is asked for."""
from __future__ import annotations

import os
import subprocess
import sys

from hwgen import processes
from hwgen.engine import WORKER_PRELOAD


def _state(name: str) -> tuple[bool, str | None, int]:
    return "cadquery" in sys.modules, os.environ.get(name), os.getppid()


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


def _vtk_state() -> tuple[int, str, int]:
    def loaded():
        return sum(m.startswith("vtkmodules.") for m in sys.modules)
    before = loaded()
    import vtk
    name = vtk.vtkPolyData.__name__
    return before, name, loaded()


def test_a_worker_has_the_kernel_without_all_of_vtk_until_vtk_is_used():
    """OCP imports ``vtk`` as it starts, which would load all of VTK's modules (hwgen.cad makes
    that wait): the server's CadQuery has loaded the few it names, and the first use of ``vtk``
    loads the rest."""
    with processes.pool(1, WORKER_PRELOAD) as pool:
        before, name, after = pool.submit(_vtk_state).result()
    assert name == "vtkPolyData"
    assert 0 < before < after / 2


def test_cadquery_starts_without_all_of_vtk_and_leaves_vtk_real():
    """hwgen.cad has CadQuery start with a stand-in for ``vtk`` (which OCP's packages import):
    afterwards only the VTK modules CadQuery names are loaded, no ``vtk`` is left behind, and a
    later ``import vtk`` is the real one, whole."""
    code = ("import sys, hwgen.cad\n"
            "def n(): return sum(m.startswith('vtkmodules.') for m in sys.modules)\n"
            "import cadquery\n"
            "print(n(), 'vtk' in sys.modules)\n"
            "import vtk\n"
            "print(n(), vtk.vtkPolyData.__name__, vtk.__file__.endswith('vtk.py'))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    (before, left), (after, name, real) = (ln.split() for ln in r.stdout.splitlines())
    assert 0 < int(before) < int(after) / 2 and left == "False"
    assert name == "vtkPolyData" and real == "True"
