"""Bad input said in the order a user fixes it, with the words that fix it: the root cause first
and what follows from it grouped under it, tendons by their names, the nearest key a misspelt or
misplaced one means (in design, sweep and tune files alike), every channel left without a tendon
at once. In-process through the CLI (typer's runner); nothing here builds a part."""
from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from hwgen.errors import InputError
from hwgen.model import feasibility
from hwgen.params import validate

from .conftest import PARAMS
from .test_hostile import FOLLOWING, run_cli

PROTO = PARAMS / "prototype.yaml"
TABLE2 = PARAMS / "paper-table2.yaml"


def based(tmp_path: Path, body: str, base: Path = PROTO, name: str = "mine.yaml") -> Path:
    f = tmp_path / name
    f.write_text(f"base: {base}\ndesign: mine\n{body}", encoding="utf-8")
    return f


def refused(*args: str) -> list[str]:
    """The lines of a refusal (exit 2, nothing escaped)."""
    code, _, stderr, escaped = run_cli(*args)
    assert escaped is None and code == 2, (code, stderr)
    return stderr.strip().splitlines()


# ---------------------------------------------------------------- the root cause first

def test_a_strip_100_mm_thick_says_the_slot_first_and_groups_what_follows(tmp_path):
    """Table II's robot with a strip 100 mm thick: before, 12 problems in a row (the eyelets' size,
    four tendons starting in the slot, the tip's and the base mount's screws among them) that all
    went once the strip was fixed. Now the slot, on the key the user's file wrote, then one line
    counting and naming the 11 that follow from it."""
    f = based(tmp_path, "backbone:\n  thickness: 100\n", base=TABLE2)
    lines = refused("routing", str(f))
    assert len(lines) == 2, lines
    assert lines[0].startswith(f"error: {f}: backbone.thickness: the backbone slot (60.1 × 100.1 mm")
    assert FOLLOWING.fullmatch(lines[1]), lines[1]
    assert lines[1].startswith("  and 11 problems that follow from the slot (fix it first: they may go with it): ")
    for field in ("tendon_material.diameter", "disks.tip_mount.positions[0]", "tendons[0].routing ×2",
                  "tendons[3].routing", "base_mount.disk_screws[3]"):
        assert field in lines[1], field
    # with the strip as the paper has it, none of them is left
    assert run_cli("routing", str(based(tmp_path, "backbone:\n  thickness: 0.3\n", base=TABLE2)))[0] == 0


def test_the_consequences_come_after_every_root_cause_they_follow_from(tmp_path):
    """An unknown material (its own root) written after the strip: listed first, as it was found;
    the slot's consequences under the slot, not between."""
    f = based(tmp_path, "backbone:\n  thickness: 100\nprocess:\n  material: standard resin\n")
    lines = refused("routing", str(f))
    assert lines[0] == f"error: {f}: 2 problems (and 6 that follow from them):"
    assert lines[1].startswith("  - process.material: unknown material 'standard resin'; did you mean standard_resin?")
    assert lines[2].startswith("  - backbone.thickness: the backbone slot")
    assert lines[3].startswith("    and 6 problems that follow from the slot") and FOLLOWING.fullmatch(lines[3])
    assert len(lines) == 4


def test_the_order_is_the_errors_own_for_other_commands_and_the_sweep():
    """The grouping is the error's (InputError.problems): roots first, each followed by what follows
    from it; a sweep's row of a bad variant lists them in that order too."""
    doc = yaml.safe_load(TABLE2.read_text())
    doc["backbone"]["thickness"] = 100
    doc["process"]["material"] = "foo"
    with pytest.raises(InputError) as e:
        feasibility.check(validate(doc, "v.yaml"), "v.yaml")
    roots = e.value.roots
    assert [r.path for r, _ in roots] == ["process.material", "backbone.thickness"]
    assert len(roots[1][1]) == 11 and all(p.follows == feasibility.SLOT for p in roots[1][1])
    assert [p.path for p in e.value.problems][:2] == ["process.material", "backbone.thickness"]


def test_a_misspelt_channel_leaves_its_channel_without_a_tendon_said_once_under_it(tmp_path):
    body = ("tendons:\n  - {name: A1, channel: A, routing: {function: {kind: straight, z0: 30}, mirror: true,"
            " mirror_name: A2}}\n  - {name: C1, channel: C3, routing: {function: {kind: cosine, a: 25}}}\n")
    lines = refused("routing", str(based(tmp_path, body)))
    assert lines[0].endswith("tendons[1].channel: C1: unknown channel 'C3'; tensioner.channels are "
                             "['A', 'C1', 'C2', 'H']"), lines
    assert lines[1] == ("  and 3 problems that follow from the unknown channel (fix it first: they may go with it): "
                        "tensioner.channels[1], tensioner.channels[2], tensioner.channels[3]")


def test_every_channel_without_a_tendon_is_named_in_one_run(tmp_path):
    lines = refused("routing", str(based(tmp_path, "tensioner:\n  channels: [A, C1, X, C2, H, Y]\n")))
    assert lines[0].endswith(": 2 problems:"), lines
    assert lines[1:] == ["  - tensioner.channels[2]: channel 'X' has no tendon: give it one (tendons[].channel) or "
                         "drop it from tensioner.channels",
                         "  - tensioner.channels[5]: channel 'Y' has no tendon: give it one (tendons[].channel) or "
                         "drop it from tensioner.channels"]


# ---------------------------------------------------------------- tendons by name

def test_eyelet_errors_name_the_tendon(tmp_path):
    body = ("tendons:\n  - {name: A1, channel: A, routing: {function: {kind: straight, z0: 30}, mirror: true,"
            " mirror_name: A2}}\n  - {name: C1, channel: C1, routing: {function: {kind: cosine, a: 40}}}\n"
            "  - {name: C2, channel: C2, routing: {function: {kind: straight, z0: 0.01}, mirror: true}}\n"
            "  - {name: H, channel: H, routing: {function: {kind: straight, x0: 25}}}\n")
    text = "\n".join(refused("routing", str(based(tmp_path, body))))
    assert "tendons[1].routing.function: C1's eyelet at station 0 (x=0, z=40) lies outside the disk" in text
    assert "tendons[2].routing: C2 starts inside the strip's slot at the base disk (x=0, z=0.01)" in text
    assert "tendons[2].routing: C2_m starts inside the strip's slot at the base disk (x=0, z=-0.01)" in text
    table = "tendons:\n  - {name: H, channel: A, routing: {table: [[0, 20], [0, 20]]}}\n"
    lines = refused("routing", str(based(tmp_path, table + "tensioner:\n  channels: [A]\n")))
    assert lines[0].endswith("tendons[0].routing.table: H's table has 2 rows, there are 13 stations (disks.count)")


# ---------------------------------------------------------------- the words that fix it

def test_a_base_that_is_not_there_says_where_it_was_looked_for(tmp_path):
    (tmp_path / "lab").mkdir()
    f = tmp_path / "lab" / "mine.yaml"
    f.write_text("base: prototype.yaml\ndesign: mine\n")
    assert refused("routing", str(f)) == [f"error: {f}: base: prototype.yaml: no such file (looked for at "
                                          f"{tmp_path / 'lab' / 'prototype.yaml'})"]


def test_a_tendons_mapping_is_told_to_be_a_list(tmp_path):
    lines = refused("routing", str(based(tmp_path, "tendons:\n  A1: {channel: A}\n")))
    assert lines == [f"error: {tmp_path / 'mine.yaml'}: tendons: Input should be a list (items written - ..., "
                     f"or [a, b]) (got {{'A1': {{'channel': 'A'}}}})"]


@pytest.mark.parametrize("body, field, words", [
    ("count: 10\n", "count", "unknown key here; did you mean disks.count?"),
    ("heigth: 10\n", "heigth", "unknown key here; did you mean backbone.height or rig.load_cell.height?"),
    ("disks:\n  extra_tip: 3\n", "disks.extra_tip", "unknown key here; did you mean backbone.extra_tip?"),
    ("disks:\n  spacng: 22.5\n", "disks.spacng", "unknown key; did you mean spacing?"),
    ("tendons:\n  - {name: A1, chanel: A, routing: {function: {kind: straight, z0: 30}}}\n", "tendons[0].chanel",
     "unknown key; did you mean channel (required, and missing)?"),
])
def test_an_unknown_key_says_the_key_it_means(tmp_path, body, field, words):
    lines = refused("routing", str(based(tmp_path, body)))
    assert lines[0].endswith(f": {field}: {words}"), lines


def _search_file(tmp_path: Path, kind: str, body: dict) -> Path:
    doc = {"sweep": {"sweep": "s", "base": str(PROTO), "axes": [{"path": "backbone.length", "values": [200]}]},
           "tune": {"tune": "t", "base": str(PROTO), "level": "lengths",
                    "free": [{"path": "backbone.length", "low": 200, "high": 300}],
                    "goal": {"minimize": "mass_g"}}}[kind]
    f = tmp_path / f"{kind}.yaml"
    f.write_text(yaml.safe_dump({**doc, **body}, sort_keys=False))
    return f


@pytest.mark.parametrize("kind, body, field, words", [
    ("sweep", {"levle": "robust"}, "levle", "unknown key; did you mean level?"),
    ("sweep", {"axes": [{"path": "disks.cont", "values": [10]}]}, "axes[0].path",
     "disks.cont: not a field of the design; did you mean disks.count?"),
    ("tune", {"budgt": 3}, "budgt", "unknown key; did you mean budget?"),
    ("tune", {"goal": {"minimize": "mass_g", "at_lest": {"tip_torsion": "base"}}}, "goal.at_lest",
     "unknown key; did you mean at_least?"),
    ("tune", {"goal": {"pas": True}}, "goal.pas", "unknown key; did you mean pass?"),
    ("tune", {"goal": {"minimize": "mass"}}, "goal.minimize", "'mass' is not a result a tune knows; did you mean "
                                                               "mass_g?"),
    ("tune", {"goal": {"minimize": "centre.C1"}}, "goal.minimize", "did you mean centre_mm.C1?"),
    ("tune", {"set": {"tendons[1].routing.function.kk": 2}}, "set.tendons[1].routing.function.kk",
     "did you mean tendons[1].routing.function.k?"),
    ("tune", {"free": [{"path": "backbone.lenght", "low": 200, "high": 300}]}, "free[0].path",
     "did you mean backbone.length?"),
])
def test_sweep_and_tune_files_say_the_key_they_mean(tmp_path, kind, body, field, words):
    f = _search_file(tmp_path, kind, body)
    lines = refused(kind, str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert any(ln.startswith((f"error: {f}: {field}: ", f"  - {field}: ")) and words in ln for ln in lines), lines
    assert not (tmp_path / "out").exists()


def test_every_unknown_state_is_named_at_once(tmp_path):
    lines = refused("stiffness", str(PROTO), "--states", "AX,A,BY", "--out", str(tmp_path / "out"))
    assert len(lines) == 1 and lines[0].startswith(f"error: {PROTO}: --states: unknown states 'AX', 'BY'; this "
                                                   f"design's are N, A, "), lines
    assert not (tmp_path / "out").exists()


def test_an_unknown_material_is_named_in_the_same_run_as_the_schemas_faults(tmp_path):
    """The material is checked after the schema passes; a file the schema refuses names it too
    (issue 43: the user learnt of it only once the other faults were gone)."""
    lines = refused("routing", str(based(tmp_path, "process:\n  material: petgg\ndisks:\n  bogus_key: 3\n")))
    assert lines[0].endswith(": 2 problems:"), lines
    assert lines[1].startswith("  - disks.bogus_key: unknown key;"), lines
    assert lines[2].startswith("  - process.material: unknown material 'petgg'; did you mean PETG?"), lines


def test_a_known_material_adds_nothing_to_the_schemas_faults(tmp_path):
    lines = refused("routing", str(based(tmp_path, "process:\n  material: PETG\n  technology: FDM\n"
                                                   "disks:\n  bogus_key: 3\n")))
    assert len(lines) == 1 and lines[0].endswith(": disks.bogus_key: unknown key; disks takes count, spacing, "
                                                 "stations, thickness, end_thickness, outer_diameter, "
                                                 "slot_clearance, eyelets, hub, anchors, tip_mount"), lines


def test_a_tune_choice_of_no_kind_is_one_line_not_one_a_kind(tmp_path):
    f = _search_file(tmp_path, "tune", {"free": [{"path": "tendons[2].routing.function.k",
                                                  "choices": [3, {"a": 1}]}], "goal": {"pass": True}})
    lines = refused("tune", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert lines == [f"error: {f}: free[0].choices[1]: Input should be a string, an integer, a number or a "
                     f"boolean (got {{'a': 1}})"], lines
