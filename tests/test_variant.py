"""A different robot builds without code changes, and its files follow its own routing."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from hwgen.cad.manifest import ManifestPart
from hwgen.pipeline import build
from hwgen.checks.sections import disk_mid_section
from hwgen.pipeline import load
from hwgen.model.routing import tendon_paths

from .conftest import PARAMS


@pytest.mark.slow
def test_nine_disk_robot_with_mirrored_tendon(tmp_path, monkeypatch):
    # the whole build, its checks too; no pictures: nothing here reads one
    monkeypatch.setenv("HWGEN_RENDER_BACKEND", "none")
    doc = yaml.safe_load((PARAMS / "prototype.yaml").read_text())
    doc["design"] = "short9"
    doc["backbone"]["length"] = 180
    doc["disks"].update(count=9, spacing=22.5)
    doc["tensioner"]["channels"] = ["A", "C", "H"]
    doc["tendons"] = [
        doc["tendons"][0],
        {"name": "C", "channel": "C", "routing": {"function": {"kind": "cosine", "a": 20, "k": 1, "axis": "x",
                                                               "phase_deg": 90, "z0": 10}, "mirror": True}},
        {"name": "H", "channel": "H", "routing": {"function": {"kind": "helix", "a": 20, "k": 2}}},
    ]
    src = tmp_path / "short9.yaml"
    src.write_text(yaml.safe_dump(doc, sort_keys=False))
    loaded = load(src)
    folder = build(loaded, tmp_path / "out").folder
    man = json.loads((folder / "manifest.json").read_text())
    disks = sorted((p for p in man["parts"] if p["role"] == "disk"), key=lambda p: p["station"])
    assert len(disks) == 9
    paths = {p.name: p for p in tendon_paths(loaded.design)}
    assert set(paths) == {"A1", "A2", "C", "C_m", "H"}
    assert np.allclose(paths["C_m"].points, paths["C"].points * [1, -1])
    for part in disks:
        i = part["station"]
        sec = disk_mid_section(ManifestPart.of(part).stl_in(folder), np.array(part["placement"]))
        assert abs(sec.y_mid - 22.5 * i) < 1e-6
        holes = [lp for lp in sec.inner if lp.extent[0] < 10]
        for p in paths.values():
            x, z = p.points[i]
            if abs(z) < 0.5 and abs(x) < 30.2:
                continue  # crosses the backbone inside the slot
            assert min(np.hypot(h.centroid[0] - x, h.centroid[1] - z) for h in holes) < 0.02, (p.name, i)
