"""Shared fixtures: the shipped designs are built once per test session into a temp folder."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

# Every design the suite builds or checks (also through the CLI, in child processes) runs its
# as-built Monte Carlo on this many samples, not the shipped 10 000: the suite tests the machinery
# and the verdicts, `make bench` the default's cost.
os.environ.setdefault("HWGEN_CHECK_SAMPLES", "64")

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / "params"


@pytest.fixture(scope="session")
def built(tmp_path_factory):
    """build(name) -> output folder of params/<name>.yaml, built once per session."""
    from hwgen.pipeline import build, load

    cache: dict[str, Path] = {}
    root = tmp_path_factory.mktemp("out")

    def get(name: str) -> Path:
        if name not in cache:
            cache[name] = build(load(PARAMS / f"{name}.yaml"), root).folder
        return cache[name]

    return get
