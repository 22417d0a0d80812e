"""Random mutations of the shipped designs (seeded): whatever a careless edit makes of them,
`hwgen routing` (load, schema, feasibility, plan) ends in exit 0, 1 or 2 with at most a short
message, never a traceback or a Python warning.

Each case is one to three mutations, of the parsed document (a value replaced, scaled, a key
dropped or added, a list item repeated or dropped, a section swapped for another) or of its
text (a line dropped, repeated or re-indented, the file cut short, stray characters typed).
A failure prints the case number and its mutations, which the seed reproduces. The fast tier runs
the first FAST_CASES of the seeded stream, the slow tier the next CASES after them. A numpy
RuntimeWarning on the way (a division the model did not guard) is an error: the CLI shows Python's
warnings when Python is told to (``sys.warnoptions``), and the test tells it.

The same cases hold hwgen's YAML reader (libyaml's parser first, PyYAML's for an error) to what
PyYAML's own parser makes of each text: the same values, or the same fault or error word for word
(the fast tier the first PARSER_CASES, the slow tier all the others).
"""
from __future__ import annotations

import copy
import random
import sys

import pytest
import yaml

from hwgen import yamlfile

from .conftest import PARAMS
from .test_hostile import FOLLOWING, run_cli

SEED = 2026
FAST_CASES = 60          # about 5 s of CPU: a fifth of them build a plan and print its routing
CASES = 300
PARSER_CASES = 20        # the fast tier's cases of the two parsers compared (the slow tier: all the others)
SOURCES = {name: (PARAMS / f"{name}.yaml").read_text() for name in ("prototype", "paper-table2")}

VALUES = [0, -1, 1, 2, 0.5, 1e-9, 1e9, 1e308, -1e308, float("nan"), float("inf"), True, False, None, "", "x",
          "[/x]", ":smile:", "\x1b[31m", "ü" * 3, "yes", "1e999", [], {}, [1, 2], [[0, 0]] * 3, {"a": 1},
          "A", "C1", "H", "straight", "cosine", "helix", "bisector", "normal", "SLA", "FDM", 13, 22.5, 270, 60]
FACTORS = [0, 0.001, 0.1, 0.5, 0.9, 0.99, 1.01, 1.1, 2, 3, 10, 100, 1e6, -1, -0.5]
TYPED = list(":[]{}&*!|>'\"#%@`,-?\t\x00é ") + ["\n", "  ", "- ", ": ", "&a ", "*a", "!!str ", "<<: "]


def _paths(node, prefix=()):
    """Every (path, value) in the document, containers included."""
    yield prefix, node
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _parent(doc, path):
    node = doc
    for k in path[:-1]:
        node = node[k]
    return node


def _tree_mutation(rng: random.Random, doc) -> str:
    paths = [p for p, _ in _paths(doc) if p]
    path = rng.choice(paths)
    parent, key = _parent(doc, path), path[-1]
    kind = rng.choice(["value", "value", "scale", "scale", "scale", "drop", "add", "repeat", "swap"])
    where = ".".join(map(str, path))
    if kind == "value":
        parent[key] = copy.deepcopy(rng.choice(VALUES))
        return f"{where} = {parent[key]!r}"
    if kind == "scale":
        numbers = [p for p, v in _paths(doc) if p and isinstance(v, (int, float)) and not isinstance(v, bool)]
        path = rng.choice(numbers)
        parent, key = _parent(doc, path), path[-1]
        f = rng.choice(FACTORS)
        parent[key] = type(parent[key])(parent[key] * f) if isinstance(parent[key], float) or f == int(f) \
            else parent[key] * f
        return f"{'.'.join(map(str, path))} *= {f}"
    if kind == "drop":
        del parent[key]
        return f"drop {where}"
    if kind == "add":
        if isinstance(parent, dict):
            parent[rng.choice(["extra", "colour", "note", "spacing", "stations", "table", "function", "mirror"])] = \
                copy.deepcopy(rng.choice(VALUES))
            return f"add a key beside {where}"
        parent.insert(key, copy.deepcopy(parent[key]))
        return f"repeat {where}"
    if kind == "repeat":
        lists = [p for p, v in _paths(doc) if p and isinstance(v, list) and v]
        if not lists:
            return "no list"
        path = rng.choice(lists)
        lst = _parent(doc, path)[path[-1]]
        if rng.random() < 0.5:
            lst.append(copy.deepcopy(rng.choice(lst)))
            return f"repeat an item of {'.'.join(map(str, path))}"
        lst.pop(rng.randrange(len(lst)))
        return f"drop an item of {'.'.join(map(str, path))}"
    other = rng.choice(paths)
    parent[key] = copy.deepcopy(_parent(doc, other)[other[-1]]) if other[:len(path)] != path else None
    return f"{where} = the value of {'.'.join(map(str, other))}"


def _text_mutation(rng: random.Random, text: str) -> tuple[str, str]:
    lines = text.splitlines(keepends=True)
    i = rng.randrange(len(lines))
    kind = rng.choice(["drop", "repeat", "indent", "cut", "type", "type", "swap"])
    if kind == "drop":
        del lines[i]
    elif kind == "repeat":
        lines.insert(i, lines[i])
    elif kind == "indent":
        lines[i] = rng.choice(["", " ", "    ", "\t"]) + lines[i].lstrip(" ")
    elif kind == "cut":
        return text[:rng.randrange(len(text))], f"cut at byte {i}"
    elif kind == "type":
        j = rng.randrange(len(lines[i]) + 1)
        lines[i] = lines[i][:j] + rng.choice(TYPED) + lines[i][j:]
    else:
        k = rng.randrange(len(lines))
        lines[i], lines[k] = lines[k], lines[i]
    return "".join(lines), f"{kind} line {i + 1}"


def mutate(rng: random.Random) -> tuple[str, str, list[str]]:
    source = rng.choice(sorted(SOURCES))
    text, steps = SOURCES[source], []
    for _ in range(rng.choice([1, 1, 2, 3])):
        if rng.random() < 0.65:
            try:
                doc = yaml.safe_load(text)
            except yaml.YAMLError:
                break                       # a text mutation already broke the syntax
            if not isinstance(doc, dict):
                break
            steps.append(_tree_mutation(rng, doc))
            text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
        else:
            text, step = _text_mutation(rng, text)
            steps.append(step)
    return source, text, steps


def _run(tmp_path, first: int, count: int) -> tuple[dict[int, int], list[str]]:
    """Cases ``first`` to ``first + count - 1`` of the seeded stream through `hwgen routing`: the exit
    codes counted, and what is wrong with each case that breaks the promise."""
    rng = random.Random(SEED)
    outcomes: dict[int, int] = {}
    failures = []
    for n in range(first + count):
        source, text, steps = mutate(rng)
        if n < first:
            continue
        f = tmp_path / f"case{n:03d}.yaml"
        f.write_text(text, encoding="utf-8", errors="surrogateescape")
        code, stdout, stderr, escaped = run_cli("routing", str(f))
        outcomes[code] = outcomes.get(code, 0) + 1
        lines = stderr.strip().splitlines()
        problem = None
        if escaped is not None:
            problem = f"{type(escaped).__name__}: {escaped}"
        elif code not in (0, 1, 2):
            problem = f"exit {code}: {stderr.strip()[:300]}"
        elif "Traceback" in stderr or "Warning:" in stderr or "Warning)" in stderr:
            problem = f"traceback or warning: {stderr[:300]}"
        elif code == 2 and not (lines and lines[0].startswith("error: ") and f.name in lines[0]
                                and all(len(ln) <= 600 for ln in lines)
                                and (len(lines) == 1 or " problems" in lines[0] or lines[1].startswith("  hint: ")
                                     or FOLLOWING.fullmatch(lines[1]))
                                and all(ln.startswith(("  - ", "  hint: ", "  ... and ")) or FOLLOWING.fullmatch(ln)
                                        for ln in lines[1:])):
            problem = f"not one short error message: {stderr[:300]}"
        elif code == 0 and any(not ln.startswith("warning: ") for ln in lines):
            problem = f"stderr on success: {stderr[:300]}"
        if problem:
            failures.append(f"case {n} ({source}: {'; '.join(steps)}): {problem}")
    print(f"fuzz outcomes by exit code: {dict(sorted(outcomes.items()))}")
    return outcomes, failures


def _read(text: str, libyaml: bool) -> str:
    """What hwgen's reader makes of the text, with libyaml first or PyYAML's parser alone: the
    values (their repr: NaN equals NaN), or the fault or syntax error, its class and its words."""
    try:
        return repr(yamlfile.load(text, libyaml=libyaml))
    except (yaml.YAMLError, yamlfile.YamlFault) as e:
        return f"{type(e).__name__}: {e}"


def _parsers_disagree(first: int, count: int) -> list[str]:
    rng = random.Random(SEED)
    cases = [mutate(rng) for _ in range(first + count)][first:]
    return [f"case {first + n} ({source}: {'; '.join(steps)}): {fast[:200]} | {pure[:200]}"
            for n, (source, text, steps) in enumerate(cases)
            if (fast := _read(text, True)) != (pure := _read(text, False))]


def test_libyaml_reads_every_mutated_design_as_pyyaml_reads_it():
    """A design is parsed by libyaml (PyYAML's own parser only for its error): over the fuzz cases,
    both give the same values, fault or error, word for word."""
    if yamlfile.CParser is None:
        pytest.skip("PyYAML without libyaml: every design is read by its own parser, nothing to compare")
    assert not _parsers_disagree(0, PARSER_CASES)


@pytest.mark.slow
def test_libyaml_reads_many_more_mutated_designs_as_pyyaml_reads_them():
    assert not _parsers_disagree(PARSER_CASES, FAST_CASES + CASES - PARSER_CASES)


@pytest.fixture
def warnings_shown(monkeypatch):
    """Python told to show warnings (as ``python -W`` does), so the CLI does not hide them; with the
    test's filter, a RuntimeWarning raises where it is made."""
    monkeypatch.setattr(sys, "warnoptions", ["error::RuntimeWarning"])


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_random_mutations_end_in_exit_0_1_or_2_without_a_traceback(tmp_path, warnings_shown):
    outcomes, failures = _run(tmp_path, 0, FAST_CASES)
    assert not failures, "\n".join(failures[:20])
    assert outcomes.get(0, 0) >= 5 and outcomes.get(2, 0) >= 25, outcomes    # both paths are exercised


@pytest.mark.slow
@pytest.mark.timeout(900)
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_many_more_random_mutations(tmp_path, warnings_shown):
    outcomes, failures = _run(tmp_path, FAST_CASES, CASES)
    assert not failures, "\n".join(failures[:20])
    assert outcomes.get(0, 0) >= 20 and outcomes.get(2, 0) >= 100, outcomes
