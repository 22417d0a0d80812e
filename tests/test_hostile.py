"""Hostile and careless input, as a new user would try it: every case ends in exit 2 with one
short line naming the file, the field path and what is wrong (a file with several faults: one
short line for each, under a line naming the file), no traceback, no Python warning, and an
output folder exactly as it was.

Cases run in-process through the CLI (typer's runner), so the corpus stays cheap; a few run as
real processes to show the console script behaves the same. None of them builds a solid: bad
input is refused before the CAD kernel is imported.
"""
from __future__ import annotations

import copy
import functools
import hashlib
import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from hwgen.errors import printable

from .conftest import PARAMS

PROTO = (PARAMS / "prototype.yaml").read_text()
TABLE2 = (PARAMS / "paper-table2.yaml").read_text()
MAX_LINE = 600          # one short message, however large the input


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def with_disks_key(key: str) -> str:
    """The prototype with one more key, written as given (YAML source), in its disks section."""
    anchor = "  slot_clearance: 0.05 "
    return edit(PROTO, anchor, f"{anchor.rstrip()}\n  {key}: 1 ")


@functools.cache
def _parsed(text: str) -> dict:
    return yaml.safe_load(text)


def tree_edit(text: str, change) -> str:
    """The document parsed (once per text: the corpus is made whenever this module is collected),
    changed by ``change(doc)`` and dumped again."""
    doc = copy.deepcopy(_parsed(text))
    change(doc)
    return yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)


def setter(path: str, value):
    """change(doc) that sets a dotted path (``disks.eyelets.sweep_deg``, ``tendons.0.name``)."""
    def change(doc):
        *head, last = path.split(".")
        node = doc
        for k in head:
            node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
        node[int(last) if isinstance(node, list) else last] = value
    return change


@dataclass
class Case:
    text: str | bytes
    field: str                   # the field path the message must name ("<document>" for the whole file)
    words: tuple[str, ...]       # what the message must say
    name: str = "design.yaml"    # the file's name
    kind: str = ""


def bomb(levels: int = 9, width: int = 9) -> str:
    lines = ['l0: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * width) + "]")
    return "\n".join(lines) + "\n"


def nested(depth: int, open_: str = "[", close: str = "]") -> str:
    return open_ * depth + close * depth


CASES: dict[str, Case] = {}


def add(kind: str, name: str, case: Case) -> None:
    case.kind = kind
    CASES[f"{kind}-{name}"] = case


# ---------------------------------------------------------------- YAML the loader must bound
for depth in (40, 5_000, 10_000):
    add("yaml", f"deep-list-{depth}", Case(PROTO + f"\nextra: {nested(depth)}\n", "extra", ("nested deeper",)))
add("yaml", "deep-mapping", Case(PROTO + "\nextra: " + "{a: " * 200 + "1" + "}" * 200 + "\n", "extra",
                                  ("nested deeper",)))
add("yaml", "deep-block-mapping", Case(PROTO + "\nextra:\n" + "".join("  " * i + "a:\n" for i in range(1, 60))
                                       + "  " * 60 + "b: 1\n", "extra", ("nested deeper",)))
add("yaml", "deep-in-a-field", Case(edit(PROTO, "  height: 60 ", f"  height: {nested(3_000)} "),
                                    "backbone.height", ("nested deeper",)))
add("yaml", "list-as-key", Case(PROTO + "\n? [a, b]\n: 1\n", "<document>", ("list used as a key",)))
add("yaml", "mapping-as-key", Case(PROTO + "\n? {a: 1}\n: 1\n", "<document>", ("mapping used as a key",)))
add("yaml", "list-as-key-in-section", Case(with_disks_key("[x]"),
                                           "disks", ("list used as a key",)))
add("yaml", "integer-5001-digits", Case(edit(PROTO, "  height: 60 ", "  height: " + "9" * 5001 + " "),
                                        "backbone.height", ("5,001 characters",)))
add("yaml", "float-4000-digits", Case(edit(PROTO, "  height: 60 ", "  height: 0." + "3" * 4000 + " "),
                                      "backbone.height", ("characters",)))
add("yaml", "long-string", Case(edit(PROTO, "  name: SLA resin, Anycubic Photon M3", "  name: " + "x" * 2000),
                                "process.name", ("2,000 characters",)))
add("yaml", "long-key", Case(PROTO + "\n? " + "k" * 5000 + "\n: 1\n", "kkkkkkkk", ("5,000 characters",)))
add("yaml", "long-simple-key", Case(PROTO + "\n" + "k" * 5000 + ": 1\n", "<document>", ("YAML syntax",)))
add("yaml", "alias-bomb-design", Case(bomb() + edit(PROTO, "design: prototype", "design: *l8"), "l5",
                                      ("expands to more than",)))
add("yaml", "alias-bomb-table", Case(bomb(5) + edit(PROTO, "      function: {kind: straight, z0: 30}",
                                                    "      table: [*l4, *l4, *l4, *l4]"),
                                     "tendons[0].routing.table", ("expands to more than",)))
add("yaml", "alias-bomb-nested-only", Case(
    edit(PROTO, "bom:", "bom:\n  x: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n  y: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
                        "  z: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b, *b]\n  w: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c, *c]\n"
                        "  v: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d, *d]\n  u: [*e, *e, *e]\n"),
    "bom.u", ("expands to more than",)))
add("yaml", "quadratic-blowup", Case(PROTO + "\nbig: &big [" + ", ".join(["0"] * 1000) + "]\nmany: ["
                                     + ", ".join(["*big"] * 400) + "]\n", "many", ("expands to more than",)))
add("yaml", "merge-key-bomb", Case(bomb(5) + "m: &m {a: *l4}\n" + PROTO.replace("bom:", "bom:\n  <<: *m", 1)
                                   + "\nmore: [" + ", ".join(["*m"] * 50) + "]\n", "more", ("expands to more than",)))
add("yaml", "recursive-list", Case("a: &a [1, *a]\n" + PROTO, "a[1]", ("refers to the list or mapping",)))
add("yaml", "recursive-mapping", Case("a: &a {b: *a}\n" + PROTO, "a.b", ("refers to the list or mapping",)))
add("yaml", "undefined-alias", Case(edit(PROTO, "  height: 60 ", "  height: *nothing "), "<document>",
                                    ("YAML syntax", "undefined alias")))
add("yaml", "two-documents", Case(PROTO + "\n---\ndesign: other\n", "<document>", ("YAML syntax", "single document")))
add("yaml", "empty-file", Case("", "<document>", ("must be a mapping",)))
add("yaml", "only-comments", Case("# nothing here\n# at all\n", "<document>", ("must be a mapping",)))
add("yaml", "null-document", Case("~\n", "<document>", ("must be a mapping",)))
add("yaml", "scalar-document", Case("hello\n", "<document>", ("must be a mapping",)))
add("yaml", "list-document", Case("- a\n- b\n", "<document>", ("must be a mapping",)))
add("yaml", "too-large", Case(PROTO + ("#" + "x" * 1023 + "\n") * 1100, "<document>", ("larger than 1 MiB",)))
add("yaml", "latin-1", Case(PROTO.replace("Ø", "").encode() + "\nnote: caf\xe9\n".encode("latin-1"), "<document>",
                            ("not UTF-8",)))
add("yaml", "utf-16", Case(PROTO.encode("utf-16"), "<document>", ("not UTF-8",)))
add("yaml", "binary-garbage", Case(bytes(range(256)) * 8, "<document>", ("not UTF-8",)))
add("yaml", "nul-byte", Case(edit(PROTO, "  height: 60 ", "  height: 6\x000 "), "<document>",
                             ("YAML syntax", "special characters")))
add("yaml", "tab-indent", Case(edit(PROTO, "  height: 60 ", "\theight: 60 "), "<document>", ("YAML syntax",)))
add("yaml", "python-tag", Case(edit(PROTO, "  height: 60 ", "  height: !!python/object/apply:os.system ['true'] "),
                               "<document>", ("YAML syntax", "python/object")))
add("yaml", "custom-tag", Case(edit(PROTO, "  height: 60 ", "  height: !mm 60 "), "<document>", ("YAML syntax",)))
add("yaml", "binary-tag", Case(edit(PROTO, "  height: 60 ", "  height: !!binary aGVsbG8= "), "backbone.height",
                               ("valid number",)))
add("yaml", "set-tag", Case(edit(PROTO, "  count: 13 ", "  count: !!set {13: null} "), "disks.count",
                            ("valid integer",)))
add("yaml", "date-for-number", Case(edit(PROTO, "  length: 270 ", "  length: 2024-01-01 "), "backbone.length",
                                    ("valid number",)))
add("yaml", "impossible-date", Case(edit(PROTO, "  length: 270 ", "  length: 2024-02-30 "), "<document>",
                                    ("YAML cannot read",)))
add("yaml", "duplicate-top-key", Case(PROTO + "\ndesign: again\n", "design", ("duplicate key",)))
add("yaml", "duplicate-nested-key", Case(edit(PROTO, "    edge: chamfer", "    edge: chamfer\n    edge: none"),
                                         "disks.eyelets.edge", ("duplicate key",)))
add("yaml", "integer-key", Case(PROTO + "\n1: one\n", "[1]", ("Keys should be strings",)))
add("yaml", "null-key", Case(PROTO + "\n~: one\n", "None", ("Keys should be strings",)))

# ---------------------------------------------------------------- text that must never be markup
add("echo", "markup-key", Case(with_disks_key("'[/x]'"),
                               "disks.[/x]", ("unknown key",)))
add("echo", "markup-open-key", Case(with_disks_key("'[bold red]'"),
                                    "disks.[bold red]", ("unknown key",)))
add("echo", "markup-design-name", Case(edit(PROTO, "design: prototype", "design: '[/x]'"), "design",
                                       ("'[/x]'", "safe file name")))
add("echo", "markup-file-name", Case(edit(PROTO, "  height: 60 ", "  height: sixty "), "backbone.height",
                                     ("valid number",), name="design[v2].yaml"))
add("echo", "markup-open-file-name", Case("- x\n", "<document>", ("mapping",), name="[bold]x.yaml"))
add("echo", "emoji-file-name", Case("- x\n", "<document>", ("mapping",), name=":smile:.yaml"))
add("echo", "emoji-value", Case(edit(PROTO, "  height: 60 ", "  height: ':thumbs_up:' "), "backbone.height",
                                (":thumbs_up:",)))
add("echo", "escape-sequence-key", Case(with_disks_key('"\\e[2J\\e[31m"'),
                                        "disks.\\x1b[2J", ("unknown key",)))
add("echo", "newline-key", Case(with_disks_key('"a\\nb"'),
                                "disks.a\\nb", ("unknown key",)))
add("echo", "bidi-override-value", Case(edit(PROTO, "design: prototype", 'design: "abc\\u202edef"'), "design",
                                        ("\\u202e", "safe file name")))
add("echo", "huge-list-value", Case(edit(PROTO, "  height: 60 ", "  height: [" + ", ".join(["1"] * 10_000) + "] "),
                                    "backbone.height", ("valid number",)))
add("echo", "huge-string-value", Case(edit(PROTO, "  height: 60 ", "  height: '" + "y" * 999 + "' "),
                                      "backbone.height", ("valid number",)))
add("echo", "huge-mapping-value", Case(edit(PROTO, "  height: 60 ", "  height: {" + ", ".join(f"k{i}: {i}" for i in range(5000))
                                            + "} "), "backbone.height", ("valid number",)))
add("echo", "many-unknown-keys", Case(PROTO + "".join(f"\nextra{i}: {i}" for i in range(2000)) + "\n", "extra0",
                                      ("unknown key",)))
add("echo", "channel-list-echo", Case(edit(PROTO, "    channel: H", "    channel: " + "Z" * 64),
                                      "tendons[3].channel", ("unknown channel",)))

# ---------------------------------------------------------------- values: types and sane bounds
BOOL_FIELDS = [("disks.thickness", True), ("disks.count", True), ("disks.spacing", "on"),
               ("backbone.height", "yes"), ("tendon_material.diameter", False),
               ("disks.tip_mount.positions", [[True, 14], [22, 14]]), ("process.build_volume", [1, True, 1]),
               ("render.width_px", True), ("tensioner.worm_starts", True), ("tensioner.module", "off"),
               ("tendons.1.routing.function.k", False), ("tendons.0.routing.function.z0", "yes")]
for path, value in BOOL_FIELDS:
    v = value if not isinstance(value, str) else value
    text = tree_edit(PROTO, setter(path, v))
    if isinstance(value, str):          # dumped quoted by safe_dump: put the bare word back
        text = text.replace(f"'{value}'", value)
    field = path.replace(".0.", "[0].").replace(".1.", "[1].")
    add("value", f"bool-{path}", Case(text, field, ("true/false",)))
add("value", "bool-channel-name", Case(edit(PROTO, "channels: [A, C1, C2, H]", "channels: [A, C1, C2, NO]"),
                                       "tensioner.channels", ("true/false", "quote")))
for path, value, words in [
    ("disks.eyelets.sweep_deg", 1e9, ("less than or equal to 360",)),
    ("disks.eyelets.sweep_deg", 0, ("greater than 0",)),
    ("disks.eyelets.sweep_deg", -5, ("greater than 0",)),
    ("disks.eyelets.sweep_deg", ".inf", ("finite",)),
    ("check.step_deg", 1e-9, ("greater than or equal to 0.1",)),
    ("check.step_deg", 0, ("greater than or equal to 0.1",)),
    ("check.max_angle_deg", 1e9, ("less than or equal to 360",)),
    ("check.max_angle_deg", 120, ("beyond the ±90°", "disks.eyelets.sweep_deg")),
    ("tendons.1.routing.function.k", 1e308, ("less than or equal to 1000",)),
    ("tendons.1.routing.function.k", -1e308, ("greater than or equal to -1000",)),
    ("tendons.1.routing.function.phase_deg", 1e308, ("less than or equal to 3600",)),
    ("tendons.1.routing.function.a", 1e308, ("less than or equal to 10000",)),
    ("tendons.0.routing.function.z0", -1e300, ("greater than or equal to -10000",)),
    ("tendons.0.routing.function.z0", ".nan", ("finite",)),
    ("backbone.length", 1e308, ("less than or equal to 10000",)),
    ("backbone.length", ".inf", ("finite",)),
    ("backbone.height", 1e-300, ()),
    ("disks.count", 10 ** 6, ("less than or equal to 200",)),
    ("disks.count", -1, ("greater than or equal to 2",)),
    ("disks.count", 1.5, ("valid integer",)),
    ("render.width_px", 10 ** 9, ("less than or equal to 8000",)),
    ("process.build_volume", [1e308, 1, 1], ("less than or equal to 10000",)),
    ("tendon_material.diameter", 50, ("Ø50 mm tendon", "do not fit")),
    ("tendon_material.diameter", 30, ("breaks through the rim",)),
    ("disks.tip_mount.positions", [[-100, 14], [100, 14]], ("breaks through the rim",)),
    ("disks.tip_mount.positions", [[0, 0]], ("cuts into the backbone slot",)),
    ("disks.tip_mount.positions", [[1, 1]] * 40, ("at most 32",)),
    ("backbone.thickness", 100, ("backbone slot", "reaches past the rim")),
    ("backbone.thickness", 0, ("greater than 0",)),
    ("disks.outer_diameter", 50, ("does not enclose the backbone slot",)),
    ("disks.stations", list(range(13)), ("must run from 0 to backbone.length",)),
    ("tensioner.channels", [f"c{i}" for i in range(17)], ("17 channels",)),
]:
    v = value
    text = tree_edit(PROTO, setter(path, v))
    if isinstance(value, str):
        text = text.replace(f"'{value}'", value)
    if path == "disks.stations":
        text = text.replace("  spacing: 22.5\n", "")
    field = path.replace(".0.", "[0].").replace(".1.", "[1].")
    if path == "backbone.height":       # valid as a number; no strip that narrow takes C1's hole where it crosses
        field, words = "tendons[1].routing.function", ("wider than the 1e-300 mm strip",)
    if path == "tendon_material.diameter" and value == 30:
        field = "tendons[0].routing.function"
    if path == "disks.tip_mount.positions" and value == [[-100, 14], [100, 14]]:
        field = "disks.tip_mount.positions[0]"
    if path == "disks.tip_mount.positions" and value == [[0, 0]]:
        field = "disks.tip_mount.positions[0]"
    if path == "tensioner.channels":
        text = text.replace("tensioner:\n", "tensioner:\n", 1)
    add("value", f"{path}={str(value)[:12]}", Case(text, field, words))
add("value", "sixty-five-tendons", Case(tree_edit(PROTO, lambda d: d["tendons"].extend(
    [{"name": f"T{i}", "channel": "A", "routing": {"function": {"kind": "straight", "z0": 5}}} for i in range(61)])),
    "tendons", ("at most 64",)))
add("value", "sweep-60-check-90", Case(tree_edit(PROTO, lambda d: (setter("disks.eyelets.sweep_deg", 60)(d),
                                                                   setter("check.max_angle_deg", 90)(d))),
                                       "check.max_angle_deg", ("±60°",)))
add("value", "channel-without-tendon", Case(edit(PROTO, "channels: [A, C1, C2, H]", "channels: [A, C1, C2, H, X]"),
                                            "tensioner", ("'X' has no tendon",)))


def _tree(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def previous_output(tmp_path):
    """An output root holding an earlier build's files (stand-ins: bad input never reads them)."""
    out = tmp_path / "out"
    (out / "prototype" / "stl").mkdir(parents=True)
    (out / "prototype" / "manifest.json").write_text('{"design": "prototype"}\n')
    (out / "prototype" / "stl" / "disk_00.stl").write_bytes(b"solid earlier build\n")
    return out


def run_cli(*args: str, env: dict | None = None):
    """The CLI in this process: (exit code, stdout, stderr, an exception that escaped or None)."""
    from typer.testing import CliRunner

    from hwgen.cli import app
    r = CliRunner().invoke(app, list(args), env=env)
    escaped = r.exception if r.exception is not None and not isinstance(r.exception, SystemExit) else None
    return r.exit_code, r.stdout, r.stderr, escaped


FOLLOWING = re.compile(r" {2}(?: {2})?and \d+ problems? that follows? from .+ \(fix it first: (they|it) may go "
                       r"with it\): .+")


def assert_one_clear_line(code, stdout, stderr, escaped, case: Case, file: Path):
    """One clear message: one line ``error: FILE: FIELD: what``; or, for a file with several
    faults, a line ``error: FILE: N problems:`` and one line ``  - FIELD: what`` for each (the
    case's field among them), then any hints. Under a problem others follow from, one line
    naming them (:data:`FOLLOWING`)."""
    assert escaped is None, f"{type(escaped).__name__}: {escaped}"
    assert code == 2, (code, stderr[-800:], stdout[-300:])
    lines = stderr.strip().splitlines()
    assert "Traceback" not in stderr and "Warning" not in stderr
    assert "\x1b" not in stderr
    assert all(len(ln) <= MAX_LINE for ln in lines), max(map(len, lines))
    head = lines[0]
    assert head.startswith("error: "), head
    assert case.name in head, head                                   # the file, as named
    following = sum(bool(FOLLOWING.fullmatch(ln)) for ln in lines)
    if head.endswith(" problems:") or " problems (and " in head:
        n = int(head.rsplit(": ", 2)[-1].split()[0])
        body = [ln for ln in lines[1:] if ln.startswith("  - ")]
        assert len(body) == min(n, 25) and n > 1, stderr[:2000]
        assert len(lines) <= len(body) + 2 + following + stderr.count("  hint: "), stderr[:2000]
        named = [ln for ln in body if ln[4:].split(": ")[0].startswith(case.field)]
        assert named, (case.field, stderr[:2000])
        line = named[0]
    else:
        assert len(lines) == 1 + following + stderr.count("  hint: "), stderr[:2000]
        line = head
        field = line.split(": ", 3)[2] if case.field != "<document>" else "<document>"
        assert case.field in field or (case.field == "<document>" and ": <document>: " in line), (case.field, line)
    for w in case.words:
        assert w in line, (w, line)


def _write(tmp_path: Path, case: Case) -> Path:
    f = tmp_path / case.name
    if isinstance(case.text, bytes):
        f.write_bytes(case.text)
    else:
        f.write_text(case.text, encoding="utf-8")
    return f


@pytest.mark.timeout(120)
@pytest.mark.parametrize("case", sorted(CASES))
def test_hostile_input_is_one_clear_line_and_writes_nothing(case, tmp_path, previous_output):
    c = CASES[case]
    f = _write(tmp_path, c)
    before = _tree(previous_output)
    entries = sorted(p.name for p in previous_output.iterdir())
    assert_one_clear_line(*run_cli("build", str(f), "--out", str(previous_output), "-q"), c, f)
    assert _tree(previous_output) == before
    assert sorted(p.name for p in previous_output.iterdir()) == entries


def test_the_corpus_covers_every_kind():
    kinds: dict[str, int] = {}
    for c in CASES.values():
        kinds[c.kind] = kinds.get(c.kind, 0) + 1
    assert kinds["yaml"] >= 40 and kinds["echo"] >= 15 and kinds["value"] >= 40, kinds


# every command reports bad input the same way
SAME_FOR_ALL = ["yaml-list-as-key", "echo-markup-key", "value-bool-disks.thickness", "value-channel-without-tendon",
                "yaml-alias-bomb-design", "value-sweep-60-check-90", "value-tendon_material.diameter=50",
                "value-tendon_material.diameter=30"]


@pytest.mark.parametrize("case", SAME_FOR_ALL)
def test_every_command_reports_bad_input_the_same_way(case, tmp_path, previous_output):
    c = CASES[case]
    f = _write(tmp_path, c)
    before = _tree(previous_output)
    lines = set()
    for cmd in (["build", "-q"], ["check", "-q"], ["render", "-q"], ["routing"], ["routing", "--json"]):
        extra = ["--out", str(previous_output)] if cmd[0] in ("build", "check", "render") else []
        code, out, err, escaped = run_cli(cmd[0], str(f), *cmd[1:], *extra)
        assert_one_clear_line(code, out, err, escaped, c, f)
        lines.add(err.strip())
    assert len(lines) == 1, lines
    assert _tree(previous_output) == before


# ---------------------------------------------------------------- the output folder and side files

def test_out_that_cannot_be_written_is_bad_input(tmp_path):
    params = str(PARAMS / "prototype.yaml")
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder\n")
    for out, words in ((a_file, "is a file, not a folder"), (a_file / "below", "lies below a file"),
                       (Path("/proc/hwgen-test"), "cannot write the outputs here")):
        for cmd in ("build", "check", "render"):
            code, stdout, stderr, escaped = run_cli(cmd, params, "--out", str(out), "-q")
            assert escaped is None and code == 2, (cmd, out, stderr)
            assert stderr.strip() == f"error: {out}: --out: {stderr.split(': --out: ')[1].strip()}"
            assert words in stderr and len(stderr.strip().splitlines()) == 1, stderr
    assert a_file.read_text() == "not a folder\n"


def test_out_without_permission_is_bad_input(tmp_path, monkeypatch):
    """Tests run as root, who may write anywhere: the refusal is simulated where the folder is made."""
    import tempfile

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied", str(tmp_path / "out"))
    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "out"), "-q")
    assert escaped is None and code == 2
    assert stderr.strip() == f"error: {tmp_path / 'out'}: --out: cannot write the outputs here (Permission denied)"


def test_report_and_junit_that_cannot_be_written(built, tmp_path):
    """--report and --junit name their option; the checks ran (on a built design) and are not lost."""
    import json

    from hwgen.checks.report import write_junit
    from hwgen.cli import _errors, _write_side_file

    out = built("prototype").parent
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    code, stdout, stderr, escaped = run_cli("check", str(PARAMS / "prototype.yaml"), "--out", str(out), "-q",
                                            "--report", str(a_file / "r.json"))
    assert escaped is None and code == 2, stderr
    assert stderr.strip() == f"error: {a_file / 'r.json'}: --report: cannot write it (it lies below a file, not a folder)"
    assert "PASS" in stdout          # the report was printed before the file failed
    rep = json.loads((out / "prototype" / "report.json").read_text())
    with pytest.raises(Exception) as e:
        with _errors(None):
            _write_side_file(tmp_path, "--junit", lambda: write_junit(rep, tmp_path))
    assert getattr(e.value, "exit_code", None) == 2


# ---------------------------------------------------------------- the CAD kernel

@pytest.mark.slow                   # builds disks with the CAD kernel
def test_a_kernel_failure_names_the_part_and_its_parameters(tmp_path, monkeypatch, own_cache):
    """OCCT raising inside a part builder becomes a design error: exit 2, the part, its parameters."""
    from OCP.Standard import Standard_Failure

    import hwgen.cad.disk as disk

    def fail(spec):
        if spec.index == 4:
            raise Standard_Failure("BRep_API: command not done")
        return real(spec)
    real = disk.build_disk
    monkeypatch.setattr(disk, "build_disk", fail)
    out = tmp_path / "out"
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(out), "-q")
    assert escaped is None and code == 2, stderr
    line = stderr.strip()
    assert line.startswith("error: ") and "prototype.yaml: disks: the CAD kernel could not make disk_04" in line
    # the disk's inputs as the plan makes them: its slot is the strip's section with the clearance around it
    from hwgen.model.plan import make_plan
    from hwgen.pipeline import load
    design = load(PARAMS / "prototype.yaml").design
    spec = make_plan(design).disks[4]
    c = design.disks.slot_clearance
    assert spec.role == "inner" and spec.slot_width == pytest.approx(design.backbone.height + 2 * c)
    assert spec.slot_height == pytest.approx(design.backbone.thickness + 2 * c)
    assert (f"inner disk at y = {spec.y:g} mm: thickness {spec.thickness:g} mm, Ø{design.disks.outer_diameter:g} mm, "
            f"slot {spec.slot_width:g} × {spec.slot_height:g} mm") in line
    assert "BRep_API: command not done" in line and len(line.splitlines()) == 1
    assert not (out / "prototype").exists() and not list(out.glob(".prototype.*"))


@pytest.mark.slow                   # builds disks with the CAD kernel
def test_an_empty_solid_is_a_kernel_failure(tmp_path, monkeypatch, own_cache):
    """A builder that returns a solid with no volume is refused before any file is written."""
    import cadquery as cq

    import hwgen.cad.disk as disk
    from hwgen.cad import Part

    real = disk.build_disk

    def empty(spec):
        p = real(spec)
        return Part(p.name, p.role, cq.Solid(cq.Solid.makeBox(1, 1, 1).wrapped.EmptyCopied()), p.placement, p.color)
    monkeypatch.setattr(disk, "build_disk", empty)
    code, _, stderr, escaped = run_cli("build", str(PARAMS / "prototype.yaml"), "--out", str(tmp_path / "o"), "-q")
    assert escaped is None and code == 2, stderr
    assert "disks: the CAD kernel could not make disk_00 (base disk at y = 0 mm: thickness 6 mm" in stderr
    assert "came out empty" in stderr
    assert not (tmp_path / "o" / "prototype").exists()


def test_an_unexpected_exception_is_one_line_and_exit_3(tmp_path, monkeypatch):
    import hwgen.model.plan as plan
    monkeypatch.setattr(plan, "_backbone_holes", lambda *a: 1 / 0)
    code, _, stderr, escaped = run_cli("routing", str(PARAMS / "prototype.yaml"))
    assert escaped is None and code == 3
    assert stderr.strip().startswith("error: internal error in hwgen (ZeroDivisionError: division by zero)")
    assert "HWGEN_DEBUG=1" in stderr and len(stderr.strip().splitlines()) == 1


# ---------------------------------------------------------------- as real processes

REAL = ["yaml-deep-list-10000", "echo-markup-file-name", "value-tendons.1.routing.function.k=1e+308"]


@pytest.mark.timeout(300)
def test_the_console_script_keeps_the_promise(tmp_path, previous_output):
    before = _tree(previous_output)
    for case in REAL:
        c = CASES[case]
        f = _write(tmp_path, c)
        r = subprocess.run([sys.executable, "-m", "hwgen.cli", "build", str(f), "--out", str(previous_output), "-q"],
                           capture_output=True, text=True, timeout=60,
                           env={k: v for k, v in os.environ.items() if k != "HWGEN_DEBUG"})
        assert_one_clear_line(r.returncode, r.stdout, r.stderr, None, c, f)
    assert _tree(previous_output) == before


def test_a_file_that_never_ends_is_refused(tmp_path):
    code, _, stderr, escaped = run_cli("routing", "/dev/zero")
    assert escaped is None and code == 2 and "error: /dev/zero: <document>: larger than 1 MiB" in stderr
    code, _, stderr, escaped = run_cli("routing", str(tmp_path))
    assert escaped is None and code == 2 and "cannot read the file (a folder, not a file)" in stderr


def _unreadable(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Files no design can be read from, each with what the message says of it: a symbolic link
    that leads to itself, a folder, a link to nothing, a named pipe, a device, a name no file can
    have (as a base names them; the command line cannot pass a NUL)."""
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(loop.name)
    (tmp_path / "two.yaml").symlink_to("three.yaml")
    (tmp_path / "three.yaml").symlink_to("two.yaml")
    (tmp_path / "folder.yaml").mkdir()
    (tmp_path / "dangling.yaml").symlink_to("nowhere.yaml")
    os.mkfifo(tmp_path / "pipe.yaml")
    return {"loop.yaml": (loop, "a symbolic link that leads back to itself: a loop"),
            "two.yaml": (tmp_path / "two.yaml", "a symbolic link that leads back to itself: a loop"),
            "folder.yaml": (tmp_path / "folder.yaml", "a folder, not a file"),
            "dangling.yaml": (tmp_path / "dangling.yaml", "a symbolic link to nothing"),
            "pipe.yaml": (tmp_path / "pipe.yaml", "not a regular file"),
            "/dev/zero": (Path("/dev/zero"), "not a regular file"),
            "a\x00b.yaml": (tmp_path / "a\x00b.yaml", "not a name a file can have")}


def test_a_params_file_that_is_a_symlink_loop_is_bad_input(tmp_path):
    """A symbolic link to itself, or two that point at each other, given as the design, sweep or
    tune file: exit 2 naming the file, never the RuntimeError pathlib raises on a loop."""
    bad = _unreadable(tmp_path)
    for name in ("loop.yaml", "two.yaml"):
        f, words = bad[name]
        for cmd in (["routing"], ["check", "-q"], ["sweep"], ["tune"]):
            out = [] if cmd[0] == "routing" else ["--out", str(tmp_path / "out")]
            code, _, stderr, escaped = run_cli(cmd[0], str(f), *cmd[1:], *out)
            assert escaped is None and code == 2, (cmd, code, stderr)
            assert stderr.strip() == f"error: {f}: <document>: cannot read the file ({words})", stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind", ["design", "sweep", "tune"])
def test_a_base_that_cannot_be_read_names_the_base_key_and_where_it_looked(tmp_path, kind):
    """A design's, a sweep's or a tune's ``base`` that is no readable file: exit 2, one line naming
    the file that wrote it, ``base``, what is wrong, and the path it was looked for at."""
    bad = _unreadable(tmp_path)
    body = {"design": "design: mine\n", "sweep": "sweep: s\naxes: [{path: backbone.length, values: [200]}]\n",
            "tune": "tune: t\nfree: [{path: backbone.length, low: 200, high: 300}]\ngoal: {minimize: mass_g}\n"}
    command = {"design": "routing", "sweep": "sweep", "tune": "tune"}[kind]
    if kind == "design":          # a lone surrogate (the schema of a sweep or tune file refuses it as no string)
        bad["\ud800.yaml"] = (tmp_path / "\ud800.yaml", "not a name a file can have")
    for name, (target, words) in bad.items():
        f = tmp_path / f"{kind}.yaml"
        f.write_text(f"base: {json.dumps(name)}\n{body[kind]}", encoding="utf-8")
        out = [] if kind == "design" else ["--out", str(tmp_path / "out")]
        code, _, stderr, escaped = run_cli(command, str(f), *out)
        assert escaped is None and code == 2, (name, code, stderr)
        assert stderr.strip() == (f"error: {f}: base: {printable(name)}: {words} (looked for at "
                                  f"{printable(os.path.abspath(target))})"), stderr
    assert not (tmp_path / "out").exists()


def test_a_base_without_permission_is_bad_input(tmp_path, monkeypatch):
    """Tests run as root, who may read anything: the refusal is simulated where the file is opened."""
    from hwgen import designfile
    lab = tmp_path / "lab.yaml"
    lab.write_text(PROTO)
    f = tmp_path / "mine.yaml"
    f.write_text("base: lab.yaml\ndesign: mine\n")

    def refuse(path, *a, **k):
        if Path(path) == lab:
            raise PermissionError(13, "Permission denied", str(path))
        return open(path, *a, **k)
    monkeypatch.setattr(designfile, "open", refuse, raising=False)
    code, _, stderr, escaped = run_cli("routing", str(f))
    assert escaped is None and code == 2
    assert stderr.strip() == f"error: {lab}: <document>: cannot read the file (Permission denied)"


def _tune_file(tmp_path: Path, **body) -> Path:
    doc = {"tune": "t", "base": str(PARAMS / "prototype.yaml"), "level": "lengths",
           "free": [{"path": "backbone.length", "low": 200, "high": 300}], "goal": {"minimize": "mass_g"}, **body}
    f = tmp_path / "t.yaml"
    f.write_text(yaml.safe_dump(doc))
    return f


def test_a_tune_that_removes_a_list_item_is_bad_input(tmp_path):
    """``set: {tendons[0]: null}``: null gives a field its default, and a list's item has none
    (it was an AttributeError, exit 3)."""
    f = _tune_file(tmp_path, set={"tendons[0]": None})
    code, _, stderr, escaped = run_cli("tune", str(f), "--out", str(tmp_path / "out"), "--scheduler", "inline")
    assert escaped is None and code == 2
    assert stderr.strip() == (f"error: {f}: set.tendons[0]: null gives a field its default, and a list's item has "
                              f"none: set the list whole, without the item")
    assert not (tmp_path / "out").exists()


def test_a_tune_may_free_a_key_its_base_leaves_to_the_default(tmp_path):
    """A channel's winding the base does not write, freed as a choice: the base's value is unset
    (it was a KeyError, exit 3, before any trial)."""
    from hwgen.tune import spec
    f = _tune_file(tmp_path, free=[{"path": "tensioner.winding.A", "choices": ["same", "opposite"]}])
    loaded = spec.load(f)
    assert loaded.names == ("tensioner.winding.A",) and loaded.base_values == (None,)


def test_a_manifest_edited_into_nonsense_is_rebuilt_not_a_crash(built, tmp_path, monkeypatch):
    """`hwgen check` trusts the files; a manifest that is not one hwgen wrote means the outputs
    are stale (they are rebuilt), never a traceback."""
    import json

    from hwgen import pipeline
    from hwgen.pipeline import load, stale_reason

    loaded = load(PARAMS / "prototype.yaml")
    folder = tmp_path / "prototype"
    folder.mkdir()
    good = json.loads((built("prototype") / "manifest.json").read_text())
    for broken in ({**good, "parts": 5}, {**good, "files": None}, {**good, "parts": [{"files": {"stl": {}}}]},
                   {**good, "design_report": []}, [1, 2], "text"):
        (folder / "manifest.json").write_text(json.dumps(broken))
        assert stale_reason(folder, loaded) is not None, broken
    rebuilt = []
    monkeypatch.setattr(pipeline, "build", lambda *a, **k: rebuilt.append(1) or
                        type("R", (), {"report": {"ok": True, "checks": []}})())
    rep, _, why = pipeline.check(loaded, tmp_path)
    assert rebuilt and why == "manifest.json is not one hwgen wrote"


def test_an_error_made_of_a_stop_signal_is_the_stop(capsys):
    """A SIGTERM that lands while an extension module is imported comes back as that import's
    ImportError ("initialization failed"), which a unit's kernel-failure handler would report as
    bad input (exit 2): once a stop was asked for, any error is the stop (exit 130, outputs as
    they were). Before the signal, the same error is the internal error it is."""
    import typer

    from hwgen import cli
    for stopping, code in ((False, cli.EXIT_BUG), (True, 130)):
        if stopping:
            cli._STOPPING.set()
        try:
            with pytest.raises(typer.Exit) as e:
                with cli._errors(None):
                    raise ImportError("initialization failed")
        finally:
            cli._STOPPING.clear()
        assert e.value.exit_code == code
    assert "interrupted" in capsys.readouterr().err
