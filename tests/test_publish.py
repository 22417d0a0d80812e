"""Publishing a design's folder: whole or not at all, whoever else writes or reads, whenever a
writer is killed. These run on small stand-in folders; test_reproducible.py does it with builds."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from hwgen import atomic

FILES = 12

# A writer process: publishes `versions` versions of ROOT/design, each FILES files naming it,
# written slowly so that a kill or another writer lands in the middle of one.
WRITER = textwrap.dedent("""
    import sys, time
    from pathlib import Path
    from hwgen.atomic import new_folder
    root, tag, versions, pause = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3]), float(sys.argv[4])
    print("ready", flush=True)
    for v in range(versions):
        with new_folder(root / "design") as tmp:
            (tmp / "stl").mkdir()
            for i in range({files}):
                (tmp / "stl" / f"part_{{i:02d}}.stl").write_text(f"{{tag}}-{{v}}\\n" * 2000)
                time.sleep(pause)
            (tmp / "manifest.json").write_text(f"{{tag}}-{{v}}\\n")
        print(f"published {{tag}}-{{v}}", flush=True)
""").format(files=FILES)


def _writer(root: Path, tag: str, versions: int, pause: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", WRITER, str(root), tag, str(versions), str(pause)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _version(folder: Path) -> str:
    """The one version the folder holds; fails on a mix or a partial folder."""
    stamp = (folder / "manifest.json").read_text().strip()
    parts = sorted((folder / "stl").iterdir())
    assert len(parts) == FILES, (stamp, [p.name for p in parts])
    for p in parts:
        assert p.read_text() == f"{stamp}\n" * 2000, (stamp, p.name)
    return stamp


def _leftovers(root: Path) -> list[str]:
    return sorted(p.name for p in root.iterdir() if p.name != "design")


def test_two_writers_at_once_both_finish_and_readers_see_whole_versions(tmp_path):
    writers = [_writer(tmp_path, tag, 4, 0.004) for tag in ("a", "b")]
    seen = set()
    while any(w.poll() is None for w in writers):
        with atomic.snapshot(tmp_path / "design") as view:
            if view.exists():
                seen.add(_version(view))
        time.sleep(0.01)
    for w in writers:
        out, err = w.communicate()
        assert w.returncode == 0, err
        assert out.count("published") == 4
    final = _version(tmp_path / "design")
    assert final in {"a-3", "b-3"}                     # the last to publish wins
    assert len(seen) >= 2, seen                        # the reader saw versions come and go
    assert _leftovers(tmp_path) == []


def test_a_writer_killed_at_any_moment_leaves_the_previous_version(tmp_path):
    first = _writer(tmp_path, "first", 1, 0.0)
    assert first.wait(60) == 0
    rng = random.Random(12)
    previous = _version(tmp_path / "design")
    left = set()
    for k in range(12):
        w = _writer(tmp_path, f"k{k}", 3, 0.003)
        assert w.stdout.readline().strip() == "ready"
        time.sleep(rng.uniform(0.0, 0.2))              # while writing, publishing or cleaning up
        w.send_signal(signal.SIGKILL)
        w.wait(30)
        now = _version(tmp_path / "design")
        published = [ln.split()[1] for ln in w.stdout.read().splitlines() if ln.startswith("published")]
        # whole, and either what was there or a version this writer had reported as published,
        # or the one it was publishing when the signal came
        assert now == previous or now.startswith(f"k{k}-"), (now, previous, published)
        previous = now
        left |= {n for n in _leftovers(tmp_path) if n.endswith(".tmp")}
    assert left, "no kill landed while a version was being written"
    # what the killed writers left behind goes with the next writer
    last = _writer(tmp_path, "last", 1, 0.0)
    assert last.wait(60) == 0, last.stderr.read()
    assert _version(tmp_path / "design") == "last-0"
    assert _leftovers(tmp_path) == []


def test_leftovers_of_the_living_are_kept(tmp_path):
    """A staging folder another live process holds is not taken for a dead one's."""
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent("""
        import sys, time
        from pathlib import Path
        from hwgen.atomic import new_folder
        with new_folder(Path(sys.argv[1]) / "design") as tmp:
            (tmp / "x").write_text("x")
            print(tmp, flush=True)
            time.sleep(30)
    """), str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        staging = Path(holder.stdout.readline().strip())
        assert staging.is_dir()
        with atomic.new_folder(tmp_path / "design") as tmp:
            (tmp / "y").write_text("y")
        assert staging.is_dir() and (staging / "x").exists()
    finally:
        holder.kill()
        holder.wait()
    with atomic.new_folder(tmp_path / "design") as tmp:
        (tmp / "z").write_text("z")
    assert not staging.exists() and _leftovers(tmp_path) == []


def test_without_an_atomic_exchange_a_half_done_swap_is_put_back(tmp_path, monkeypatch):
    monkeypatch.setattr(atomic, "exchange", lambda a, b: False)
    for v in ("one", "two"):
        with atomic.new_folder(tmp_path / "design") as tmp:
            (tmp / "v").write_text(v)
    assert (tmp_path / "design" / "v").read_text() == "two" and _leftovers(tmp_path) == []
    # killed between its two renames: the old version aside, none in place
    os.rename(tmp_path / "design", tmp_path / ".design.previous")
    assert atomic.clean_leftovers(tmp_path / "design") == [tmp_path / ".design.previous"]
    assert (tmp_path / "design" / "v").read_text() == "two"


def test_a_copy_that_lost_the_race_is_dropped(tmp_path):
    """`hwgen render` adds to a copy of the published folder; a build published meanwhile wins."""
    with atomic.new_folder(tmp_path / "design") as tmp:
        (tmp / "v").write_text("build 1")
    with atomic.new_folder(tmp_path / "design", copy_current=True) as tmp:
        assert (tmp / "v").read_text() == "build 1"
        (tmp / "picture").write_text("drawn for build 1")
        with atomic.new_folder(tmp_path / "design") as other:
            (other / "v").write_text("build 2")
    assert (tmp_path / "design" / "v").read_text() == "build 2"
    assert not (tmp_path / "design" / "picture").exists() and _leftovers(tmp_path) == []


def test_snapshot_is_unchanged_by_a_swap_and_leaves_nothing(tmp_path):
    with atomic.new_folder(tmp_path / "design") as tmp:
        (tmp / "v").write_text("old")
    with atomic.snapshot(tmp_path / "design") as view:
        with atomic.new_folder(tmp_path / "design") as tmp:
            (tmp / "v").write_text("new")
        assert (view / "v").read_text() == "old"
    assert (tmp_path / "design" / "v").read_text() == "new" and _leftovers(tmp_path) == []
    with atomic.snapshot(tmp_path / "missing" / "design") as view:
        assert not view.exists()
    with atomic.snapshot(tmp_path / "nothing_yet") as view:
        assert not view.exists()
    assert _leftovers(tmp_path) == []


@pytest.mark.skipif(atomic._RENAMEAT2 is None, reason="no renameat2 here")
def test_exchange_swaps_two_folders(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    (tmp_path / "a" / "f").write_text("a")
    assert atomic.exchange(tmp_path / "a", tmp_path / "b")
    assert (tmp_path / "b" / "f").read_text() == "a" and not (tmp_path / "a" / "f").exists()
