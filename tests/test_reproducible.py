"""Rebuilds are byte-identical, and the output folder is always one whole build: killed builds
leave the previous outputs and their leftovers go with the next build; two builds at once both
finish. These run the real command line on the prototype."""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hwgen import atomic

from .conftest import PARAMS

PROTO = str(PARAMS / "prototype.yaml")


def _tree(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in ("SOURCE_DATE_EPOCH", "HWGEN_DEBUG")}
    env.update(extra)
    return env


def _build(out: Path, *args: str, **env) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "hwgen.cli", "build", PROTO, "--out", str(out), "-q", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env(**env))


def _whole(folder: Path) -> str:
    """Check that the folder is one build: every file its manifest lists, with that sha256, and
    nothing else. Returns the manifest's own sha256 (which build it is)."""
    m = json.loads((folder / "manifest.json").read_text())
    listed = {f["path"]: f["sha256"] for p in m["parts"] for f in p["files"].values()}
    listed |= {f["path"]: f["sha256"] for f in m["files"].values()}
    listed |= {f["path"]: f["sha256"] for f in m.get("render", {}).get("files", {}).values()}
    tree = _tree(folder)
    for path, sha in listed.items():
        assert tree.get(path) == sha, path
    extra = set(tree) - set(listed) - {"manifest.json", "report.json", "summary.md", "lengths.png",
                                     "tolerance.png", "sag.png", "stiffness.json", "stiffness.png", "gravity.png"}
    assert not extra, extra
    return tree["manifest.json"]


def _published(folder: Path) -> tuple[int, int]:
    """Which folder is published: its inode and its last change. The inode alone may come back: a
    build with nothing changed publishes in a second, its predecessor's inode is freed, and the
    other build's staging folder, made after that, can get it."""
    st = os.stat(folder)
    return st.st_ino, st.st_ctime_ns


def _begun(out: Path, but=()) -> bool:
    """A build's new folder holds its part folders: it is making the parts."""
    return any((p / "stl").is_dir() for p in out.glob(".prototype.*.tmp") if p not in but)


@pytest.mark.timeout(900)
def test_killed_concurrent_and_repeated_builds(built, tmp_path):
    """Over the session's build of the prototype: a build killed with SIGKILL and one stopped with
    SIGTERM leave it as it was; two builds at once (fresh processes, other string-hash seeds)
    both finish (one of them building every part afresh and compiling the numba kernels afresh,
    the other taking its parts from the session's part cache), whenever one looks the folder is
    one whole build, and what they publish has the same bytes in every file (STEP, STL, DXF, PNG,
    SVG, JSON, CSV) as the session's build, made in this process after other builds. The killed
    builds build afresh too (from the cache they would be done before the kill). SIGKILL comes as
    soon as the build's new folder is begun: the build is under way (making the tensioner's first
    channel, which comes first: seconds of the kernel before its first STL), and what it leaves behind is
    that folder whatever it holds by then. So does SIGTERM: it may land while the CAD kernel is
    being imported, whose import then fails; the stop is still what the build reports (exit 130,
    ``cli._STOPPING``), not a kernel failure."""
    first = built("prototype")
    out = tmp_path / "out"
    target = out / "prototype"
    shutil.copytree(first, target)
    before = _tree(target)
    assert len(before) >= 70
    _whole(target)

    # SIGKILL while the parts are being made: the previous outputs stay, a leftover is there
    a = _build(out, "--no-cache", HWGEN_RENDER_BACKEND="none")
    deadline = time.time() + 300
    while time.time() < deadline and not _begun(out):
        time.sleep(0.05)
    a.send_signal(signal.SIGKILL)
    a.wait(30)
    assert _tree(target) == before
    left = list(out.glob(".prototype.*.tmp"))
    assert left, "the kill came too late to leave anything"

    # SIGTERM cleans up on its way out
    t = _build(out, "--no-cache", HWGEN_RENDER_BACKEND="none")
    while time.time() < deadline and not _begun(out, but=left):
        time.sleep(0.05)
    t.send_signal(signal.SIGTERM)
    _, err = t.communicate(timeout=60)
    assert t.returncode == 130 and "interrupted" in err and "Traceback" not in err, err
    assert _tree(target) == before

    # two builds at once: both finish, and whenever one looks, the folder is one whole build
    was = _published(target)
    # the second compiles the numba kernels afresh into its own cache: compiled or loaded from
    # disk, the Monte Carlo must give the same bits (with fastmath it did not, and CI caught it)
    runs = [_build(out, PYTHONHASHSEED="4"),
            _build(out, "--no-cache", PYTHONHASHSEED="5", NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"))]
    looks = 0
    while any(r.poll() is None for r in runs):
        with atomic.snapshot(target) as view:
            _whole(view)
            looks += 1
        time.sleep(0.2)
    for r in runs:
        _, err = r.communicate()
        assert r.returncode == 0, err
    assert looks > 10 and _published(target) != was     # a new build was swapped in
    _whole(target)
    assert sorted(p.name for p in out.iterdir()) == ["prototype"]   # the killed build's leftovers are gone

    after = _tree(target)
    differ = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert differ == [], differ
    head = (target / "step" / "disk_00.step").read_text()[:400]
    assert "1970-01-01T00:00:00" in head and "FILE_NAME('disk_00'" in head
