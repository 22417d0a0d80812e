"""Bad input: one clear message naming the file and the field path, exit 2, nothing written."""
from __future__ import annotations

import hashlib
import subprocess
import sys
from pathlib import Path

import pytest

from .clirunner import hwgen
from .conftest import PARAMS

PROTO = (PARAMS / "prototype.yaml").read_text()
TABLE2 = (PARAMS / "paper-table2.yaml").read_text()


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


CASES = {
    "yaml-syntax": (_edit(PROTO, "  height: 60 ", "  height: [60 "), "<document>", "YAML syntax"),
    "duplicate-key": (_edit(PROTO, "  height: 60 ", "  height: 60\n  height: 61 "), "backbone.height", "duplicate key"),
    "unknown-key": (_edit(PROTO, "  slot_clearance: 0.05 ", "  slot_clearance: 0.05\n  colour: red "),
                    "disks.colour", "unknown key"),
    "wrong-type": (_edit(PROTO, "  height: 60 ", "  height: sixty "), "backbone.height", "valid number"),
    "non-positive": (_edit(PROTO, "  thickness: 3.0 ", "  thickness: 0 "), "disks.thickness", "greater than 0"),
    "non-finite": (_edit(PROTO, "  length: 270 ", "  length: .nan "), "backbone.length", "finite"),
    "table-rows": (_edit(TABLE2, "        - [0, -25]\n  - name: H", "  - name: H"),
                   "tendons[2].routing.table", "12 rows, there are 13 stations"),
    "eyelet-outside": (_edit(PROTO, "z0: 30}", "z0: 36.5}"), "tendons[0].routing.function", "outside the disk"),
    "eyelet-outside-table": (_edit(TABLE2, "        - [17.7, 17.7]", "        - [37.7, 17.7]"),
                             "tendons[3].routing.table[1]", "outside the disk"),
    "duplicate-name": (_edit(PROTO, "  - name: H ", "  - name: C1 "), "tendons[3].name", "duplicate tendon name"),
    "duplicate-mirror-name": (_edit(PROTO, "mirror_name: A2", "mirror_name: C2"),
                              "tendons[2].name", "duplicate tendon name"),
    "unknown-channel": (_edit(PROTO, "    channel: H", "    channel: H2"), "tendons[3].channel", "unknown channel"),
    "unsafe-design-name": (_edit(PROTO, "design: prototype", "design: ../../etc"), "design", "safe file name"),
    "unsafe-tendon-name": (_edit(PROTO, "  - name: H ", "  - name: 'H/1' "), "tendons[3].name", "safe file name"),
    "spacing-mismatch": (_edit(PROTO, "  spacing: 22.5 ", "  spacing: 20 "), "disks.spacing", "backbone.length"),
    "not-a-mapping": ("- just\n- a list\n", "<document>", "mapping"),
    # a knot smaller than the smallest seat the process prints pulls through it
    "termination-too-small": (_edit(PROTO, "    diameter: 1.5 ", "    diameter: 0.6 "),
                              "tendon_material.termination.diameter", "pulls through the smallest seat"),
    # 13 disks 3 mm thick (6 at the ends) cannot stand 2 mm apart (a hub too long for its gap is a finding)
    "disks-overlap": (_edit(_edit(PROTO, "  spacing: 22.5 ", "  spacing: 2 "), "  length: 270 ", "  length: 24 "),
                      "disks.spacing", "disk 0 and disk 1 overlap"),
    "crimp-without-length": (_edit(PROTO, "    kind: knot", "    kind: crimp"),
                             "tendon_material.termination", "needs its 'length'"),
}


@pytest.fixture(scope="module")
def previous_output(tmp_path_factory):
    """An out folder holding an earlier build; bad input must leave it byte for byte."""
    from hwgen.pipeline import build
    from hwgen.pipeline import load
    out = tmp_path_factory.mktemp("out")
    build(load(PARAMS / "prototype.yaml"), out, post_build=False)
    return out


def _tree(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_exits_2_names_field_and_writes_nothing(case, tmp_path, previous_output):
    text, field_path, what = CASES[case]
    bad = tmp_path / f"{case}.yaml"
    bad.write_text(text)
    before = _tree(previous_output)
    r = subprocess.run([sys.executable, "-m", "hwgen.cli", "build", str(bad), "--out", str(previous_output), "-q"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stderr
    msg = " ".join(r.stderr.split())
    assert "Traceback" not in r.stderr
    assert str(bad.name) in msg and f"{field_path}:" in msg and what in msg, msg
    assert len(r.stderr.strip().splitlines()) <= 3, r.stderr  # one message (rich may wrap it)
    assert _tree(previous_output) == before


def test_missing_file_and_usage_errors_exit_2(tmp_path):
    for args in (["build", str(tmp_path / "nope.yaml")], ["build"], ["frobnicate"]):
        r = hwgen(*args, "--out", str(tmp_path / "o"))
        assert r.returncode == 2, (args, r.stderr)
        assert "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()
