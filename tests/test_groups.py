"""The suite's own scheduling: under ``--dist loadgroup`` (``make test``, ``make test-fast``) the tests
that share a module's fixture (a build, a pool of gear cases) run in one worker, which makes it once.

Nothing else fails when they do not: each worker then makes the module's build for itself, and the
suite takes minutes longer. It did so, unseen, until November 2026: tests/conftest.py marked the
tests after pytest-xdist had read the marks, and pytest 9.2's node ids drop the group suffix
pytest-xdist writes into them (pytest-dev/pytest-xdist#1386; pyproject.toml keeps pytest below 9.2)."""
from __future__ import annotations

import os

import pytest


def test_tests_sharing_a_module_fixture_carry_their_group(request):
    if not (os.environ.get("PYTEST_XDIST_WORKER") and request.config.getvalue("loadgroup")):
        pytest.skip("not under pytest-xdist's --dist loadgroup")
    marked = [item for item in request.session.items if item.get_closest_marker("xdist_group")]
    if not marked:
        pytest.skip("no test of this run shares a module's fixture")
    lost = [item.nodeid for item in marked
            if not item.nodeid.endswith("@" + item.get_closest_marker("xdist_group").args[0])]
    assert not lost, f"{len(lost)} of {len(marked)} grouped tests will not run in one worker: {lost[:3]}"
