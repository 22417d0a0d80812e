"""The command line: routing tables, deviations, schema, deprecated keys."""
from __future__ import annotations

import json

import yaml

from .clirunner import hwgen
from .conftest import PARAMS


_run = hwgen            # in this process (tests/test_hostile.py runs the console script itself)


def test_routing_reports_table_deviation_station_by_station():
    r = _run("routing", str(PARAMS / "paper-table2.yaml"), "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    c2 = {d["station"]: d["distance_mm"] for d in rep["deviations"] if d["tendon"] == "C2"}
    assert len(c2) == 13
    # Table II types 19.4 where 25 cos(3π·22.5/270) = 17.678 at every odd station
    assert all(abs(c2[i] - (19.4 - 25 * 2 ** -0.5)) < 1e-9 for i in range(1, 13, 2))
    assert all(c2[i] < 1e-9 for i in range(0, 13, 2))
    h = [d["distance_mm"] for d in rep["deviations"] if d["tendon"] == "H"]
    assert max(h) < 0.04  # 17.7 typed for 17.678
    shared = {(m["station"], tuple(m["tendons"])) for m in rep["merges"] if m["kind"] == "shared"}
    assert {0, 4, 8, 12} <= {s for s, _ in shared}
    assert (6, ("C1", "C2")) in shared  # also shared at the middle disk: both at (0, 0)


def test_routing_table_prints_for_people():
    r = _run("routing", str(PARAMS / "prototype.yaml"))
    assert r.returncode == 0, r.stderr
    assert "crosses backbone" in r.stdout and "shared" in r.stdout
    assert "table versus function" not in r.stdout  # the prototype names no tables


def test_schema_is_json_schema_matching_the_yaml_keys():
    r = _run("schema")
    assert r.returncode == 0
    schema = json.loads(r.stdout)
    assert schema["additionalProperties"] is False
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    assert set(doc) <= set(schema["properties"])
    assert "mm" in schema["$defs"]["Backbone"]["properties"]["length"]["description"]


def test_bom_allowances_under_render_are_read_with_a_deprecation_warning(tmp_path):
    """Tendon allowances moved from render: to bom:; the old place is read for one release."""
    from hwgen.pipeline import load
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    doc["render"].update(doc.pop("bom"))
    doc["render"]["tie_off_mm"] = 42.0
    old = tmp_path / "old.yaml"
    old.write_text(yaml.safe_dump(doc))
    loaded = load(old)
    assert loaded.design.bom.tie_off_mm == 42.0
    assert any("render.tie_off_mm is deprecated" in w and "bom.tie_off_mm" in w for w in loaded.warnings)
    r = _run("routing", str(old))
    assert r.returncode == 0 and "render.tie_off_mm is deprecated" in r.stderr
    doc["bom"] = {"tie_off_mm": 10}
    both = tmp_path / "both.yaml"
    both.write_text(yaml.safe_dump(doc))
    r = _run("routing", str(both))
    assert r.returncode == 2 and "render.tie_off_mm:" in r.stderr and "keep only bom.tie_off_mm" in r.stderr


def test_a_design_built_before_from_the_same_bytes_starts_no_worker_server_ahead(tmp_path):
    """`hwgen build` starts the workers' server before reading the design unless a folder under
    --out was built from these very bytes by this hwgen (a rebuild that likely needs no worker)."""
    from hwgen import __version__
    from hwgen.cli import _built_before
    params = tmp_path / "robot.yaml"
    params.write_bytes((PARAMS / "prototype.yaml").read_bytes())
    out = tmp_path / "out"
    assert not _built_before(params, out)                   # nothing built yet
    (out / "prototype").mkdir(parents=True)
    sha = __import__("hashlib").sha256(params.read_bytes()).hexdigest()
    manifest = out / "prototype" / "manifest.json"
    manifest.write_text(json.dumps({"params_sha256": sha, "hwgen_version": __version__}))
    assert _built_before(params, out)
    manifest.write_text(json.dumps({"params_sha256": sha, "hwgen_version": __version__ + ".other"}))
    assert not _built_before(params, out)
    manifest.write_text(json.dumps({"params_sha256": sha, "hwgen_version": __version__}))
    params.write_bytes(params.read_bytes() + b"\n# edited\n")
    assert not _built_before(params, out)                   # an edit: the server is started ahead
    manifest.write_text("{not json")
    assert not _built_before(params, out)
    assert _built_before(tmp_path / "missing.yaml", out)    # the load will say what is wrong
