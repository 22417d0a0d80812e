"""hwgen sweep: the sweep file, the lengths level against the plan and eq. (2), the cosine-k sweep's
numbers, bad variants as rows, a random robot family, resuming, and a real Dask cluster."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from hwgen import bench
from hwgen.sweep import levels, lengths, run, spec

from .clirunner import hwgen, hwgen_process
from .conftest import PARAMS
from .robots import random_robot

PROTOTYPE = PARAMS / "prototype.yaml"
K_AXIS = "tendons[1].routing.function.k"
# measured by hand on the prototype (the issue): C1's largest |ΔL| by eq. (2) over ±90°, per k
BY_HAND = {0.5: 25.0, 1.0: 0.18, 1.5: 8.2, 2.0: 0.18, 2.5: 4.6, 3.0: 0.19, 4.0: 0.20}


_cli = hwgen            # in this process: `--scheduler inline` runs the sweep here


def _sweep_file(tmp_path: Path, body: dict, name: str = "s.yaml") -> Path:
    doc = {"sweep": "t", "base": str(PROTOTYPE), **body}
    p = tmp_path / name
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def _rows(folder: Path) -> list[dict]:
    t = run.read(folder)
    return [] if t is None else t.to_pylist()


def _tendon(row: dict, name: str) -> dict:
    return next(t for t in json.loads(row["per_tendon"]) if t["name"] == name)


# ---------------------------------------------------------------- the sweep file

@pytest.mark.parametrize("body, field, words", [
    ({"axes": [{"path": "tendons[1].routing.function.kk", "values": [1]}]}, "axes[0].path", "not a field"),
    ({"axes": [{"path": "tendons[9].routing.function.k", "values": [1]}]}, "axes[0].path", "has 4 item"),
    ({"axes": [{"path": "disks..count", "values": [1]}]}, "axes[0].path", "not a parameter path"),
    ({"axes": [{"path": "disks.count", "range": {"start": 9, "stop": 5, "step": 1}}]}, "axes[0].range", "below start"),
    ({"axes": [{"path": "disks.count", "values": [9], "range": {"start": 1, "stop": 5, "step": 1}}]}, "axes[0]",
     "not values and range"),
    ({"axes": [{"path": "disks.count", "values": [9]}], "mode": "samples"}, "<document>", "needs 'samples'"),
    ({"axes": [{"path": "disks.count", "values": [9]}], "levle": "robust"}, "levle", "unknown key"),
    ({"axes": [{"path": "disks.count", "values": [9]}], "keep": [3]}, "keep[0]", "does not exist"),
    ({"axes": [{"path": "disks.count", "values": [9, 13]}, {"path": "backbone.length", "values": [200]}],
      "mode": "zip"}, "axes[1]", "mode zip"),
])
def test_bad_sweep_file_names_file_and_field(tmp_path, body, field, words):
    from hwgen.errors import InputError
    f = _sweep_file(tmp_path, body)
    with pytest.raises(InputError) as e:
        spec.load(f)
    assert (e.value.file, e.value.path or "<document>") == (str(f), field) and words in e.value.message, e.value


def test_bad_sweep_file_exits_2_and_writes_nothing(tmp_path):
    f = _sweep_file(tmp_path, {"axes": [{"path": "tendons[1].routing.function.kk", "values": [1]}]})
    r = _cli("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.strip() == (f"error: {f}: axes[0].path: tendons[1].routing.function.kk: not a field of the "
                                f"design; did you mean tendons[1].routing.function.k? (see `hwgen schema`)")
    assert not (tmp_path / "out").exists()
    r = _cli("sweep", str(f), "--scheduler", "udp://nowhere")
    assert r.returncode == 2 and "--scheduler" in r.stderr


def test_a_bad_base_design_is_named_in_its_own_file(tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text(PROTOTYPE.read_text().replace("count: 13 ", "count: 1 "))
    f = _sweep_file(tmp_path, {"base": "base.yaml", "axes": [{"path": "backbone.length", "values": [200]}]})
    r = _cli("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert r.returncode == 2 and r.stderr.startswith(f"error: {base}: disks.count:"), r.stderr


def test_variants_grid_samples_zip_and_hashes():
    base = yaml.safe_load(PROTOTYPE.read_text())
    grid = spec.Sweep.model_validate({"sweep": "g", "base": "x", "axes": [
        {"path": "disks.count", "values": [9, 13]}, {"path": K_AXIS, "range": {"start": 1, "stop": 2, "step": 0.5}}]})
    vs = spec.variants(grid)
    assert [v.values for v in vs] == [(9, 1.0), (9, 1.5), (9, 2.0), (13, 1.0), (13, 1.5), (13, 2.0)]
    draws = {"sweep": "s", "base": "x", "mode": "samples", "samples": 50, "seed": 7, "axes": [
        {"path": "backbone.length", "random": {"low": 200, "high": 300, "round": 0.5}}, {"path": "disks.count",
                                                                                      "values": [9, 13, 17]}]}
    a, b = spec.variants(spec.Sweep.model_validate(draws)), spec.variants(spec.Sweep.model_validate(draws))
    assert a == b and len({v.values for v in a}) > 40
    assert all(200 <= v.values[0] <= 300 and v.values[0] * 2 == round(v.values[0] * 2) for v in a)
    # the hash is of the resolved design: the prototype's own k = 1 written as 1 or 1.0 is one design,
    # and one design whatever else the document spells out by default
    names = (K_AXIS,)
    h1 = spec.resolve(base, names, spec.Variant(0, (1,))).hash
    h2 = spec.resolve(base, names, spec.Variant(1, (1.0,))).hash
    with_default = dict(base, check={**base["check"], "step_deg": 1.0})
    h3 = spec.resolve(with_default, names, spec.Variant(2, (1.0,))).hash
    h4 = spec.resolve(base, names, spec.Variant(3, (2.0,))).hash
    assert h1 == h2 == h3 != h4
    assert base["tendons"][1]["routing"]["function"]["k"] == 1       # the base is left as it was


# ---------------------------------------------------------------- the lengths level

def _plan_agrees(d, p) -> int:
    """The lengths level's holes against the plan's, every disk but the tip (sized there for the turn
    toward the drum, which this level leaves out, so the plan's tip holes can only be larger):
    each tendon's hole has the plan's centre, axis and diameter. Returns how many were compared."""
    from hwgen.model.fixing import disk_thicknesses

    xz = np.stack([q.points for q in p.paths])[None]
    ax, dia, centre, joined, _ = lengths._holes([d], [p.paths], np.asarray(d.stations), xz,
                                                np.asarray(disk_thicknesses(d)))
    names = [q.name for q in p.paths]
    n = 0
    for disk in p.disks[:-1]:
        for h in disk.holes:
            k = [names.index(t) for t in h.tendons]
            for t in k:
                assert dia[0, t, disk.index] == pytest.approx(h.diameter, abs=1e-9)
                assert ax[0, t, disk.index] == pytest.approx(np.asarray(h.axis), abs=1e-9)
                assert centre[0, t, disk.index] == pytest.approx([h.x, h.z], abs=1e-9)
                assert set(np.flatnonzero(joined[0, disk.index, t])) == set(k)
                n += 1
    tip = p.disks[-1]
    for h in tip.holes:
        assert all(dia[0, names.index(t), tip.index] <= h.diameter + 1e-9 for t in h.tendons)
    return n


def test_lengths_level_sizes_eyelets_as_the_plan_and_takes_eq2_as_kinematics():
    """Every hole but the tip disk's has the plan's centre, axis and diameter; eq. (2) is the
    kinematics module's; the sweep of angles is hwgen check's."""
    from hwgen.checks.lengths import sweep_angles
    from hwgen.model import kinematics as kin
    from hwgen.model.plan import make_plan
    from hwgen.params import read

    for name in ("prototype", "paper-table2"):
        d = read(PARAMS / f"{name}.yaml").design
        p = make_plan(d)
        assert _plan_agrees(d, p) >= 4 * (len(p.disks) - 1)
        xz = np.stack([q.points for q in p.paths])[None]
        ang = lengths.check_angles(d.check_angle_deg, d.check.step_deg)
        assert np.array_equal(ang, sweep_angles(d.check_angle_deg, d.check.step_deg))
        kap = kin.kappas_for_angles(ang, d.backbone.length)
        mine = lengths.centre_lengths(np.asarray(d.stations), kap, xz)[0]
        for k, q in enumerate(p.paths):
            assert mine[k] == pytest.approx(kin.tendon_lengths(d.stations, q.points, kap), abs=1e-9)


@pytest.mark.parametrize("index", [25, 72])
def test_lengths_level_merges_eyelets_routed_into_each_other_as_the_plan(index):
    """Robots 25 and 72 of the first stability draw (classic_robot) route two tendons 0.8 and 0.3 mm apart: the plan
    gives each such pair one opening around both. The lengths level has the plan's openings
    (centre, axis, diameter, which tendons), counts no wall between their tendons, and fails the
    variant naming the overlap, as hwgen check fails eyelet.overlap."""
    from hwgen.model.plan import make_plan
    from hwgen.params import Design

    from .robots import classic_robot
    from .stability import SEED

    rng = np.random.default_rng(SEED)
    doc = [classic_robot(rng, f"robot{i:03d}") for i in range(index + 1)][index]
    d = Design.model_validate(doc)
    p = make_plan(d)
    overlaps = [m for m in p.merges if m.kind == "overlap" and m.station < len(p.disks) - 1]
    assert overlaps, "the draw no longer routes tendons into each other"
    _plan_agrees(d, p)
    row = lengths.evaluate([d])[0]
    below_tip = len({m.station for m in overlaps})     # the tip disk may differ (sized without its exits)
    assert below_tip <= row["overlapping_eyelets"] <= below_tip + 1
    assert row["clearance_mm"] == 0.0
    verdict, message, _ = lengths.verdict(row)
    assert verdict == "fail" and "share one opening" in message


def test_lengths_level_imports_no_cad_kernel():
    code = ("import sys\n"
            "from hwgen.sweep import levels, spec\n"
            "import yaml\n"
            f"base = yaml.safe_load(open({str(PROTOTYPE)!r}))\n"
            f"rows = levels.evaluate_batch([(0, (1.0,)), (1, (2.0,))], base, ({K_AXIS!r},), 'lengths')\n"
            "assert [r.verdict for r in rows] == ['pass', 'pass'], rows\n"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('cadquery', 'OCP', 'vtk', 'vtkmodules'))\n"
            "print(bad)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"


def test_cosine_k_sweep_finds_whole_k_decoupled(tmp_path):
    """The shipped example: whole k within the 0.2 mm budget by eq. (2) through the hole centres,
    half-integer k far outside (the first-order condition: the integral of r(s) over L vanishes),
    as measured by hand; the taut and as-built figures beside them."""
    r = _cli("sweep", str(PARAMS / "sweep-cosine-k.yaml"), "--out", str(tmp_path), "--scheduler", "inline", "-q")
    assert r.returncode == 0, r.stderr
    assert "variants/s" in r.stdout
    folder = tmp_path / "sweeps" / "cosine-k" / "robust"
    rows = {row[K_AXIS]: row for row in _rows(folder)}
    assert sorted(rows) == [0.5 * i for i in range(1, 9)]
    # the throughput line's figures beside the results (what the bench reads): this run's rows, their verdicts
    run = json.loads((folder / "run.json").read_text())
    assert run["evaluated"] == run["variants"] == len(rows) and run["done_before"] == 0
    assert run["verdicts"] == {v: [x["verdict"] for x in rows.values()].count(v) for v in run["verdicts"]}
    assert f"over {len(rows)} variants" in bench._sweep_note(run)
    for k, row in rows.items():
        c1 = _tendon(row, "C1")
        if k == int(k):
            assert c1["centre_mm"] <= 0.2 and row["decoupled"], (k, c1)
        else:
            assert c1["centre_mm"] > 2.0 and not row["decoupled"] and row["verdict"] == "fail", (k, c1)
            assert "C1 changes" in row["message"]
        if k in BY_HAND:
            assert c1["centre_mm"] == pytest.approx(BY_HAND[k], rel=0.05, abs=0.01), k
        # the taut path cannot be shorter-changing than zero, and the as-built figure is there for each
        assert np.isfinite(c1["taut_mm"]) and np.isfinite(c1["robust_mm"]) and c1["robust_mm"] > 0
        assert row["robust_mm"] == max(t["robust_mm"] for t in json.loads(row["per_tendon"])
                                       if t["budget_mm"] is not None)
    for f in ("summary.md", "tradeoff.png", "region.png"):
        assert (folder / f).stat().st_size > 0
    assert "| 1 |" in (folder / "summary.md").read_text() or "| 3 |" in (folder / "summary.md").read_text()


def test_bad_variants_are_rows_and_leave_the_rest_alone(tmp_path):
    good = [1.0, 2.0, 3.0]
    values = [1.0, "one", 2.0, 5000, 3.0]            # not a number; beyond the schema's range
    f = _sweep_file(tmp_path, {"axes": [{"path": K_AXIS, "values": values}]})
    g = _sweep_file(tmp_path, {"sweep": "g", "axes": [{"path": K_AXIS, "values": good}]}, "g.yaml")
    # an eyelet beyond the disk's rim: valid to the schema, refused by feasibility (exit 2 in hwgen build)
    h = _sweep_file(tmp_path, {"sweep": "h", "axes": [{"path": "tendons[1].routing.function.a", "values": [25, 80]}]},
                    "h.yaml")
    for file in (f, g, h):
        run.run(spec.load(file), tmp_path / "out", scheduler="inline")
    rows = {row["variant"]: row for row in _rows(tmp_path / "out" / "sweeps" / "t" / "lengths")}
    assert len(rows) == 5
    assert rows[1]["verdict"] == rows[3]["verdict"] == "bad input"
    assert rows[1]["message"].startswith("tendons[1].routing.function.k: ") and "'one'" in rows[1]["message"]
    assert rows[3]["message"].startswith("tendons[1].routing.function.k: ") and "1000" in rows[3]["message"]
    assert rows[1]["centre_mm"] is None
    ref = {row[K_AXIS]: row for row in _rows(tmp_path / "out" / "sweeps" / "g" / "lengths")}
    for i in (0, 2, 4):
        a, b = rows[i], ref[json.loads(rows[i][K_AXIS])]
        assert a["hash"] == b["hash"] and a["per_tendon"] == b["per_tendon"] and a["verdict"] == b["verdict"] == "pass"
    far = {row["tendons[1].routing.function.a"]: row for row in _rows(tmp_path / "out" / "sweeps" / "h" / "lengths")}
    assert far[25.0 if 25.0 in far else 25]["verdict"] == "pass"
    bad = far[80.0 if 80.0 in far else 80]
    assert bad["verdict"] == "bad input" and bad["message"].startswith("tendons[1]"), bad["message"]


def test_random_robot_family_records_refusals_and_failures_as_rows(tmp_path):
    """Robots drawn as a lab writes them (tests/robots.py), as a zip sweep over the sections the draw
    changes: every robot a row; exactly those `hwgen build` would refuse at loading are bad input,
    with its message."""
    from hwgen.errors import InputError
    from hwgen.pipeline import load

    rng = np.random.default_rng(2024)
    docs = [random_robot(rng, f"r{i}") for i in range(24)]
    docs[3]["tendons"][0]["routing"]["function"] = {"kind": "straight", "z0": 500.0}    # beyond any disk
    docs[5]["disks"]["slot_clearance"] = -1                                             # schema
    paths = ["backbone", "disks", "tendons", "tensioner.channels", "tensioner.actuating_channel"]

    def part(doc, p):
        for k in p.split("."):
            doc = doc[k]
        return doc
    f = _sweep_file(tmp_path, {"sweep": "family", "mode": "zip",
                               "axes": [{"path": p, "values": [part(d, p) for d in docs]} for p in paths]})
    r = _cli("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "-q")
    assert r.returncode == 0, r.stderr
    rows = {row["variant"]: row for row in _rows(tmp_path / "out" / "sweeps" / "family" / "lengths")}
    assert sorted(rows) == list(range(len(docs)))
    base = yaml.safe_load(PROTOTYPE.read_text())
    for i, d in enumerate(docs):
        doc = dict(base, backbone=d["backbone"], disks=d["disks"], tendons=d["tendons"],
                   tensioner=dict(base["tensioner"], channels=d["tensioner"]["channels"],
                                  actuating_channel=d["tensioner"]["actuating_channel"]))
        file = tmp_path / f"r{i}.yaml"
        file.write_text(yaml.safe_dump(doc))
        try:
            load(file)
            refused = None
        except InputError as e:
            refused = f"{e.path}: {e.message}"
        row = rows[i]
        if refused:
            assert row["verdict"] == "bad input" and row["message"] == refused, (i, row["message"], refused)
        else:
            assert row["verdict"] in ("pass", "fail"), (i, row["verdict"], row["message"])
            assert row["verdict"] == "pass" or row["message"], i
    verdicts = {row["verdict"] for row in rows.values()}
    assert {"bad input", "fail"} <= verdicts


@pytest.mark.slow
def test_interrupted_sweep_resumes_with_every_variant_once(tmp_path):
    """Killed (SIGKILL, cluster and all) after some batches were written, then run again: every
    variant exactly once, with the figures a whole run gives."""
    body = {"batch": 20, "axes": [{"path": K_AXIS, "range": {"start": 0.5, "stop": 4, "step": 0.05}},
                                  {"path": "tendons[1].routing.function.a", "values": [15, 20, 25]},
                                  {"path": "tendons[1].routing.function.phase_deg", "values": [0, 10, 20]}]}
    f = _sweep_file(tmp_path, body)
    total = spec.count(spec.load(f).spec)
    folder = tmp_path / "out" / "sweeps" / "t" / "lengths"
    p = subprocess.Popen([sys.executable, "-m", "hwgen.cli", "sweep", str(f), "--out", str(tmp_path / "out"),
                          "--workers", "1", "-q"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True)
    try:
        deadline = time.monotonic() + 240
        while len(list(folder.glob(run.PART_GLOB))) < 3 and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    before = _rows(folder)
    assert 0 < len(before) < total, (len(before), total)
    r = _cli("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "-q")
    assert r.returncode == 0, r.stderr
    assert f"{len(before)} already in the results" in r.stdout
    after = _rows(folder)
    assert sorted(row["variant"] for row in after) == list(range(total))
    assert len({row["hash"] for row in after}) == total
    again = _cli("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "-q")
    assert f"{total} already in the results, 0 evaluated" in again.stdout
    fresh = tmp_path / "fresh"
    g = _sweep_file(tmp_path, {**body, "sweep": "t"}, "fresh.yaml")
    _cli("sweep", str(g), "--out", str(fresh), "--scheduler", "inline", "-q")
    _same(folder, fresh / "sweeps" / "t" / "lengths")


def _same(a: Path, b: Path) -> None:
    """Two results folders hold the same rows (all but the CPU time each took)."""
    ra = sorted(_rows(a), key=lambda r: r["hash"])
    rb = sorted(_rows(b), key=lambda r: r["hash"])
    assert len(ra) == len(rb) > 0
    for x, y in zip(ra, rb):
        for k in x:
            if k == "cpu_s":
                continue
            if isinstance(x[k], float):
                assert x[k] == pytest.approx(y[k], rel=1e-12, abs=1e-12), k
            else:
                assert x[k] == y[k], k


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_sweep_on_a_real_dask_cluster_matches_the_local_run(tmp_path):
    """A `dask scheduler` and two `dask worker` processes on 127.0.0.1, started here: the same
    Parquet content as the default local cluster."""
    f = _sweep_file(tmp_path, {"batch": 16, "axes": [
        {"path": K_AXIS, "range": {"start": 0.5, "stop": 4, "step": 0.25}},
        {"path": "tendons[1].routing.function.a", "values": [20, 25, 30]},
        {"path": "disks.count", "values": [9, 13]}]})
    port = _free_port()
    dask = [str(Path(sys.executable).parent / "dask")]
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--dashboard-address", "127.0.0.1:0"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True, env=env)]
    try:
        for _ in range(2):
            procs.append(subprocess.Popen([*dask, "worker", f"tcp://127.0.0.1:{port}", "--nthreads", "1",
                                           "--host", "127.0.0.1", "--no-dashboard"], stdout=subprocess.DEVNULL,
                                          stderr=subprocess.DEVNULL, start_new_session=True, env=env))
        from distributed import Client
        with Client(f"tcp://127.0.0.1:{port}", timeout=60) as c:
            c.wait_for_workers(2, timeout=120)
        r = hwgen_process("sweep", str(f), "--out", str(tmp_path / "tcp"), "--scheduler", f"tcp://127.0.0.1:{port}",
                          "-q")
        assert r.returncode == 0, r.stderr
        assert "on 2 worker(s)" in r.stdout
    finally:
        for p in reversed(procs):
            os.killpg(p.pid, signal.SIGTERM)
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
    r = hwgen_process("sweep", str(f), "--out", str(tmp_path / "local"), "--workers", "2", "-q")
    assert r.returncode == 0, r.stderr
    _same(tmp_path / "tcp" / "sweeps" / "t" / "lengths", tmp_path / "local" / "sweeps" / "t" / "lengths")
    assert len(_rows(tmp_path / "local" / "sweeps" / "t" / "lengths")) == 15 * 3 * 2


# ---------------------------------------------------------------- the build level (CAD)

@pytest.mark.slow
def test_build_level_keeps_the_files_asked_for_and_records_refusals(built, tmp_path):
    """Two variants of a small robot (the prototype on 5 disks) through the whole pipeline: C1 as
    shipped (kept, with hwgen check's report) and C1 beyond the disks' rim (a row, nothing built).
    Through the session's part cache once it holds the prototype: the variant's tensioner is the
    prototype's (the same tip eyelets and gears), so its units and their gear measurements are
    read from the cache, and the disks, strip, fixtures and every check are made for the variant
    (a cache returns the bytes a fresh build writes: tests/test_cache.py)."""
    built("prototype")
    f = _sweep_file(tmp_path, {"level": "build", "keep": [0], "robust_samples": 50, "mode": "zip", "axes": [
        {"path": "disks.count", "values": [5, 5]}, {"path": "disks.spacing", "values": [67.5, 67.5]},
        {"path": "tendons[1].routing.function.a", "values": [25, 80]}]})
    # no pictures in the kept build: nothing here reads one
    r = hwgen_process("sweep", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline", "-q", timeout=900,
                      env={**os.environ, "HWGEN_RENDER_BACKEND": "none"})
    assert r.returncode == 0, r.stderr
    rows = {row["variant"]: row for row in _rows(tmp_path / "out" / "sweeps" / "t" / "build")}
    ok, bad = rows[0], rows[1]
    assert bad["verdict"] == "bad input" and bad["kept"] is None
    kept = Path(ok["kept"])
    assert kept.is_dir() and (kept / "manifest.json").is_file()
    report = json.loads((kept / "report.json").read_text())
    failed = [c for c in report["checks"] if not c["passed"] and c["severity"] == "error"]
    assert ok["checks_failed"] == len(failed)
    assert ok["verdict"] == ("pass" if not failed else "fail")
    assert ok["coupling"] is not None and ok["robust_mm"] is not None
    assert [p for p in (tmp_path / "out" / "sweeps" / "t" / "kept").iterdir()] == [kept.parent]
