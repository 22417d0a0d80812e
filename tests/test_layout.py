"""The package shows the pipeline: no import cycles between hwgen modules (function-level
imports count), and every stage imports only the stages before it; the stages after the model
reach no schema, and the plan the model hands on holds none."""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "hwgen"

# The stages in the order data flows; a module may import its own stage and those before it.
STAGES = ["errors", "atomic", "heap", "processes", "cache", "yamlfile", "designfile", "fasteners", "params_base", "params_experiment", "params_bench", "params", "options", "model", "cad", "checks", "tried", "outputs", "sim", "engine", "pipeline", "sweep", "tune", "fix", "cli", "bench"]
NO_CAD_KERNEL = ("yamlfile", "designfile", "params_base", "params_experiment", "params_bench", "params", "options", "model")         # plain data and numpy: never CadQuery or OCP


@functools.cache
def _tree(f: Path) -> ast.Module:
    """A module's syntax tree, parsed once a session (every test here walks the whole package)."""
    return ast.parse(f.read_text())


@functools.cache
def _modules() -> dict[str, Path]:
    mods = {}
    for f in PKG.rglob("*.py"):
        rel = f.relative_to(PKG.parent).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        mods[".".join(parts)] = f
    return mods


def _source(pkg: str, node: ast.ImportFrom) -> str:
    """The module a ``from ... import`` in package ``pkg`` reads, its dots resolved."""
    if not node.level:
        return node.module or ""
    base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the hwgen modules it imports, wherever the import statement stands."""
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for m, f in mods.items():
        pkg = m if f.name == "__init__.py" else m.rpartition(".")[0]
        for node in ast.walk(_tree(f)):
            if isinstance(node, ast.ImportFrom):
                target = _source(pkg, node)
                candidates = [target] + [f"{target}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                candidates = [a.name for a in node.names]
            else:
                continue
            for c in candidates:
                while c and c not in mods:
                    c = c.rpartition(".")[0]
                if c and c != m and not m.startswith(c + ".") and c != "hwgen":
                    graph[m].add(c)
    return graph


@functools.cache
def _graph() -> dict[str, set[str]]:
    """The package's import graph (:func:`_imports`), walked once a session."""
    return _imports(_modules())


def _external(f: Path) -> set[str]:
    out = set()
    for node in ast.walk(_tree(f)):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
    return out


def _stage(module: str) -> str:
    return module.split(".")[1] if "." in module else "hwgen"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected group of more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_no_import_cycles():
    assert _cycles(_graph()) == []


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_every_module_belongs_to_a_stage():
    unknown = sorted(m for m in _modules() if m != "hwgen" and _stage(m) not in STAGES)
    assert unknown == []


def test_stages_import_only_earlier_stages():
    graph = _graph()
    wrong = sorted(f"{m} imports {t}" for m, ts in graph.items() for t in ts
                   if m != "hwgen" and STAGES.index(_stage(t)) > STAGES.index(_stage(m)))
    assert wrong == []


@pytest.mark.parametrize("stage", NO_CAD_KERNEL)
def test_model_and_params_need_no_cad_kernel(stage):
    mods = {m: f for m, f in _modules().items() if _stage(m) == stage}
    assert mods
    for m, f in mods.items():
        assert not _external(f) & {"cadquery", "OCP", "vtk", "vtkmodules"}, m


AFTER_MODEL = ("cad", "checks", "outputs", "sim")     # they see the design only as the model resolved it


@pytest.mark.parametrize("stage", AFTER_MODEL)
def test_later_stages_import_no_schema(stage):
    """The model is the one adapter from the YAML's schema: the stages after it never import it."""
    graph = _graph()
    wrong = sorted(m for m, ts in graph.items() if _stage(m) == stage and "hwgen.params" in ts)
    assert wrong == []


def _schema_reads(source: str) -> list[str]:
    """Where a module reaches back into the schema: an attribute ``design`` (a plan's, or the
    loaded file's) or ``params`` (what a tensioner layout once carried), or a name ``design``
    (a parameter or variable holding the schema), as "line: text"."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in ("design", "params"):
            out.append((node.lineno, f".{node.attr}"))
        elif isinstance(node, ast.arg) and node.arg == "design":
            out.append((node.lineno, "argument design"))
        elif isinstance(node, ast.Name) and node.id == "design":
            out.append((node.lineno, "name design"))
    return [f"{n}: {what}" for n, what in sorted(out)]


def test_schema_reads_are_found():
    """The finder sees each way in, and not a manifest's "design" key or a word in a string."""
    src = ("def f(plan, design):\n    a = plan.design.process\n    b = lay.params\n    c = design\n"
           "    return manifest['design'], 'design', plan.disks\n")
    assert _schema_reads(src) == ["1: argument design", "2: .design", "3: .params", "4: name design"]


@pytest.mark.parametrize("stage", AFTER_MODEL)
def test_later_stages_read_no_schema(stage):
    """The CAD, the checks and the outputs work from the plan's frozen values alone: no
    ``plan.design``, no ``layout.params``, no design handed in."""
    found = {m: _schema_reads(f.read_text()) for m, f in _modules().items() if _stage(m) == stage}
    assert {m: r for m, r in found.items() if r} == {}


def _schema_objects(value, where: str = "plan") -> list[str]:
    """Where in a plan (dataclasses, tuples, lists, dicts, walked down) a schema object sits."""
    import dataclasses

    from pydantic import BaseModel
    if isinstance(value, BaseModel):
        return [f"{where}: {type(value).__name__}"]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return [w for f in dataclasses.fields(value) for w in _schema_objects(getattr(value, f.name), f"{where}.{f.name}")]
    if isinstance(value, (list, tuple)):
        return [w for i, v in enumerate(value) for w in _schema_objects(v, f"{where}[{i}]")]
    if isinstance(value, dict):
        return [w for k, v in value.items() for w in _schema_objects(v, f"{where}[{k!r}]")]
    return []


@pytest.mark.parametrize("name", ["prototype", "paper-table2"])
def test_the_plan_holds_no_schema(name):
    """What the model hands on is frozen plain values all the way down: no pydantic object at any
    depth of the plan (the settings the checks and outputs read included)."""
    from hwgen import params
    from hwgen.model.plan import make_plan
    plan = make_plan(params.read(PKG.parent / "params" / f"{name}.yaml").design)
    assert _schema_objects(plan) == []
    assert plan.check.max_angle_deg > 0 and plan.tensioner.actuating_channel in plan.tensioner.channels


def test_the_schema_object_finder_finds_one():
    import dataclasses

    from hwgen import params
    from hwgen.model.plan import make_plan
    design = params.read(PKG.parent / "params" / "prototype.yaml").design
    plan = make_plan(design)
    leaky = dataclasses.replace(plan, render=design.render)
    assert _schema_objects(leaky) == ["plan.render: Render"]


def _silent_handlers(tree: ast.AST) -> list[int]:
    """Lines of the ``except ...: pass`` handlers in ``tree``: a failure dropped without a word."""
    return [h.lineno for h in ast.walk(tree)
            if isinstance(h, ast.ExceptHandler) and all(isinstance(s, ast.Pass) for s in h.body)]


def test_no_failure_is_swallowed_in_silence():
    """A best-effort step says what it expects to fail with ``contextlib.suppress`` of that
    exception and why beside it; work whose failure matters keeps it (issue 49)."""
    found = {m: lines for m, f in _modules().items() if (lines := _silent_handlers(_tree(f)))}
    assert not found, f"except ...: pass in {found}"


def test_the_silent_handler_finder_finds_one():
    assert _silent_handlers(ast.parse("try:\n    x()\nexcept OSError:\n    pass\n")) == [3]
    assert _silent_handlers(ast.parse("try:\n    x()\nexcept OSError:\n    log()\n")) == []


def test_a_failing_check_is_defined_once():
    """'A check that fails the design' (not passed, an error) is :func:`hwgen.checks.base.fails`;
    no other module writes the rule out again (two bugs came from copies that drifted: issue 49)."""
    import re
    rule = re.compile(r"""not\s+c(?:heck)?(?:\.get\(\s*["']passed["']|\[["']passed["']\]|\.passed)[^\n]*severity[^\n]*==\s*["']error""")
    found = [str(f.relative_to(PKG.parent)) for m, f in _modules().items()
             if m != "hwgen.checks.base" and rule.search(f.read_text())]
    assert not found, f"the failing-check rule written out again in {found}: use checks.base.failing"
    assert rule.search('x = [c for c in cs if not c.get("passed", True) and c.get("severity") == "error"]')
    # a sweep's row, a tune's trial and a fix's round judge their failure records the same way
    # (sweep.records.Failure.fails), not by their severity alone
    severity = re.compile(r"""severity["']?\)?\]?\s*==\s*["']error""")
    found = [str(f.relative_to(PKG.parent)) for m, f in _modules().items()
             if m.startswith(("hwgen.sweep.", "hwgen.tune.", "hwgen.fix.")) and severity.search(f.read_text())]
    assert not found, f"a failure judged by its severity alone in {found}: use Failure.fails or checks.base.fails"
    assert all(severity.search(s) for s in ('f["severity"] == "error"', "c.get('severity') == 'error'",
                                            'f.severity == "error"'))


# ---------------------------------------------------------------- the house's mechanical limits (issue 49)

MAX_FUNCTION_LINES = 100
MAX_POSITIONAL = 8
# calls that may pass more positional arguments: a table's row, a pool's job, numpy's and the
# compiled kernels' arrays, a digest of many arrays (what each is, not a record)
MANY_POSITIONAL = {"add_row", "submit", "broadcast_arrays", "sweep_kernel", "newton", "_digest"}
ENV_WRITES = {"update", "setdefault", "pop", "clear", "popitem", "putenv", "unsetenv"}


def _house_faults(mods: dict[str, Path]) -> list[str]:
    """Every function over :data:`MAX_FUNCTION_LINES` lines (numba kernels aside), every call with more
    than :data:`MAX_POSITIONAL` positional arguments (:data:`MANY_POSITIONAL` aside), every private
    name imported from another package, and every write to ``os.environ``, in the modules ``mods``."""
    out = []
    for m, f in mods.items():
        pkg = m if f.name == "__init__.py" else m.rpartition(".")[0]
        for node in ast.walk(_tree(f)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES and not any("njit" in ast.unparse(d) for d in node.decorator_list):
                    out.append(f"{m}:{node.lineno} {node.name}: {lines} lines")
            elif isinstance(node, ast.Call):
                if len(node.args) > MAX_POSITIONAL:
                    name = ast.unparse(node.func).rpartition(".")[2]
                    if name not in MANY_POSITIONAL:
                        out.append(f"{m}:{node.lineno} {name}(...): {len(node.args)} positional arguments")
                if isinstance(node.func, ast.Attribute) and node.func.attr in ENV_WRITES:
                    target = ast.unparse(node.func)
                    if target.startswith(("os.environ.", "os.putenv", "os.unsetenv")):
                        out.append(f"{m}:{node.lineno} {target}: writes the environment")
            elif isinstance(node, (ast.Assign, ast.AugAssign, ast.Delete)):
                targets = node.targets if isinstance(node, (ast.Assign, ast.Delete)) else [node.target]
                if any(isinstance(t, ast.Subscript) and ast.unparse(t.value) == "os.environ" for t in targets):
                    out.append(f"{m}:{node.lineno} os.environ[...]: writes the environment")
            elif isinstance(node, ast.ImportFrom):
                source = _source(pkg, node)
                src_file = mods.get(source)
                src_pkg = source if src_file is not None and src_file.name == "__init__.py" else source.rpartition(".")[0]
                other = src_pkg != pkg
                for a in node.names:
                    if other and a.name.startswith("_") and not a.name.startswith("__"):
                        out.append(f"{m}:{node.lineno} {a.name} from {source}: a private name of another package")
    return out


def test_the_house_keeps_its_limits():
    """No function over 100 lines, no call of more than 8 positional arguments (records are built
    by keyword), no private name imported across packages (what is shared is promoted), and no
    code that writes ``os.environ`` (child processes get their environment explicitly), outside
    hwgen/tune/ for now. hwgen/processes/ is where a forked worker takes the environment it is
    handed (``adopt_env``) and the workers' server starts with one more variable: the one place."""
    faults = [f for f in _house_faults(_modules()) if not f.startswith("hwgen.processes")]
    assert faults == []


def test_the_house_checker_finds_each_fault(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    src = {"long.py": f"def f():\n{body}\n",
           "many.py": "Record(1, 2, 3, 4, 5, 6, 7, 8, 9)\nt.add_row(1, 2, 3, 4, 5, 6, 7, 8, 9)\n",
           "private.py": "from ..outputs.plots import _pyplot\nfrom .common import _cache\n",
           "env.py": "import os\nos.environ['A'] = '1'\nos.environ.update(B='2')\nos.environ.get('C')\n"}
    mods = {}
    for name, text in src.items():
        (tmp_path / "pkg").mkdir(exist_ok=True)
        (tmp_path / "pkg" / name).write_text(text)
        mods[f"hwgen.pkg.{name[:-3]}"] = tmp_path / "pkg" / name
    got = _house_faults(mods)
    assert [g.split(" ")[0] for g in got] == ["hwgen.pkg.long:1", "hwgen.pkg.many:1", "hwgen.pkg.private:1",
                                               "hwgen.pkg.env:2", "hwgen.pkg.env:3"], got
