"""Shared fixtures: the shipped designs are built once per test session into a temp folder.

Two tiers (``make test-fast`` and ``make test``): a test that builds parts with the CAD kernel is
marked ``slow``; every test that asks for the session's :func:`built` designs (directly or through
a fixture of its module) is marked here, the others that build by themselves carry the mark.

Under pytest-xdist (``-n auto --dist loadgroup``: ``make test``, ``make test-fast``) every worker
process shares the one part cache the controlling process made, so a design one worker built is
read from the cache by the other; a worker that wants a design another is building waits for it
(a lock per design) instead of building it a second time beside it; the tests that share a
module's fixture run in one worker (:func:`_module_fixtures`).
"""
from __future__ import annotations

import fcntl
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import pytest

# Every design the suite builds or checks (also through the CLI, in child processes) runs its
# as-built Monte Carlo on this many samples, not the shipped 10 000: the suite tests the machinery
# and the verdicts, `make bench` the default's cost; the slow tier measures the prototype once at
# the design's own count (tests/test_taut.py: test_the_shipped_sample_count_measures_the_prototype).
os.environ.setdefault("HWGEN_CHECK_SAMPLES", "64")
# `hwgen build` through the CLI (in this process or a child) builds its parts in the process itself,
# not in a worker (the CLI's default): CadQuery is imported once per process, and a builder a test
# monkeypatches is the one that runs. The workers have tests of their own (tests/test_cache.py).
os.environ.setdefault("HWGEN_JOBS", "0")
# One part cache for the whole session (also for the CLI in child processes), in a temp folder:
# a design's parts are built once however many tests build it; never the user's own cache. The
# controlling process makes it; pytest-xdist's workers (started after this file is read, with its
# environment) take the same folder, and only the controller removes it.
SHARED = "HWGEN_TEST_SESSION_CACHE"
WORKER = os.environ.get("PYTEST_XDIST_WORKER")       # gw0, gw1, ... in an xdist worker; None otherwise
if WORKER and os.environ.get(SHARED):
    SESSION_CACHE = os.environ[SHARED]
else:
    SESSION_CACHE = tempfile.mkdtemp(prefix="hwgen-test-cache-")
    os.environ[SHARED] = SESSION_CACHE
os.environ["HWGEN_CACHE_DIR"] = SESSION_CACHE
# with no size bound to speak of: a test that expects the session's parts to be there finds them
# (the folder goes at the end of the session; tests/test_cache.py tests the bound)
os.environ["HWGEN_CACHE_SIZE"] = "1T"

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / "params"
BUILDS = "built"          # the fixture that makes a test slow wherever it is asked for
# The order the workers are handed the suite's work units (a test, or a group of tests sharing a
# module's build), longest first so that no long one starts last; `make test` and `make test-fast`
# pass --no-loadscope-reorder, else pytest-xdist hands out the groups with the most tests first,
# whatever they cost. Measured in CPU seconds, December 2026. The first unit builds the prototype
# (most slow units need it) and the next two need no build of it: the other worker starts on them
# instead of waiting, idle, for the prototype's lock. A name that no longer matches only loses its
# place in the queue.
LONGEST = ("tests/test_sim.py::",                               # the prototype and paper-table2, simulated
           "tests/test_fix.py::test_a_lab_robot_is_fixed_whole",  # tests/labs' robot, its own parts
           "tests/test_experiment.py::",                        # the prototype's plan: hwgen experiment, compare
           "tests/test_any_robot.py::test_lab_robots_build_without_breaking",
           "tests/test_tune.py::", "tests/test_reproducible.py::", "tests/test_render.py::",
           "tests/test_tensioner.py::",
           "tests/test_user_loop.py::test_the_readmes_own_robot", "tests/test_cache.py::",
           "tests/test_variant.py::", "tests/test_sweep.py::test_build_level", "tests/test_tried.py::",
           "tests/test_fuzz.py::", "tests/test_any_design.py::")


@pytest.fixture(scope="session", autouse=True)
def remembered_in_the_session_cache():
    """Checks run directly by tests (run_checks on copies of a built design) remember what they
    may (the gear measurements, keyed by the worm and wheel files' bytes, the wheel's pose to its
    worm and the design values they read) in the session's cache, as `hwgen check` does in the user's."""
    from hwgen import cache
    with cache.using(cache.Store(Path(SESSION_CACHE))):
        yield


def pytest_sessionfinish(session, exitstatus):
    if not WORKER:
        shutil.rmtree(SESSION_CACHE, ignore_errors=True)


@contextmanager
def session_lock(name: str):
    """Held by one process of the session at a time (an flock on a file in the session's cache
    folder): the xdist workers take turns at what ``name`` guards."""
    with open(Path(SESSION_CACHE) / f".lock-{name}", "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture
def own_cache(tmp_path, monkeypatch):
    """An empty part cache of the test's own, for a test that changes how parts are built (a
    monkeypatched builder must run, and what it makes must not reach the session's cache)."""
    path = tmp_path / "part-cache"
    monkeypatch.setenv("HWGEN_CACHE_DIR", str(path))
    return path


# first: pytest-xdist's worker reads the xdist_group marks in its own pytest_collection_modifyitems (it
# appends "@group" to each node id, which --dist loadgroup schedules by); a hook of a conftest runs
# after it unless it asks to run first, and the marks added here would come too late to group anything
@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if BUILDS in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)
        if _module_fixtures(item):
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))
    if WORKER:
        # the slow tests first, the longest of them before the others in LONGEST's order, the many
        # quick ones after: they fill whichever worker is done first, instead of one long build being
        # the last test of one worker while the other waits
        items.sort(key=lambda item: (item.get_closest_marker("slow") is None, _place(item.nodeid)))


def _place(nodeid: str) -> int:
    """Where the test's unit comes in LONGEST's order (after all of them if it is not named)."""
    return next((i for i, prefix in enumerate(LONGEST) if nodeid.startswith(prefix)), len(LONGEST))


def _module_fixtures(item) -> list[str]:
    """The module- or class-scoped fixtures (a build, a pool of gear cases) the test asks for:
    under ``--dist loadgroup`` the tests of a module that ask for any run in one worker, which
    makes each once, instead of each worker making it again."""
    info = getattr(item, "_fixtureinfo", None)
    if info is None:
        return []
    return sorted(name for name, defs in info.name2fixturedefs.items()
                  if defs and defs[-1].scope in ("module", "class"))


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """build(name) -> output folder of params/<name>.yaml, built once per session (per worker
    process under xdist: the first to ask builds it, the others wait and take it from the
    session's cache, every part and stage)."""
    from hwgen.pipeline import build, load

    cache: dict[str, Path] = {}
    root = tmp_path_factory.mktemp("out")

    def get(name: str) -> Path:
        if name not in cache:
            with session_lock(f"build-{name}"):
                cache[name] = build(load(PARAMS / f"{name}.yaml"), root).folder
        return cache[name]

    return get
