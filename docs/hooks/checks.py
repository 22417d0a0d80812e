"""The check reference kept true to the code, and the pages' names linked (a MkDocs hook).

hwgen has no registry of its checks: each is a ``Check("id", ...)`` record made where it is measured.
:func:`code_check_ids` finds them all by reading hwgen's source (its syntax tree, not a grep): an id
written as a literal, or built in a loop over literal tuples (``for cid, kind, items in
(("eyelet.wall.edge", ...), ...)``, ``f"gear.{what}"``). One made any other way is reported, so a
new way of naming checks cannot slip past. The build warns (and, strict, fails) when a check of the
code has no row on ``checks.md``; ``tests/test_docs.py`` says the same without a build.

On every page, a code span that names a field of the design file (``disks.slot_clearance``,
``tendons[1].routing.function.k``) links to its row of the parameter reference, and one that names
a check (``disk.tilt``) to its row on the checks page. The Markdown stays plain, so the pages read
the same on GitHub; the links exist on the site only.
"""
from __future__ import annotations

import ast
import logging
import posixpath
import re
from pathlib import Path

import hwgen
import reference   # docs/hooks/reference.py: MkDocs puts a hook's folder on the path while it loads

log = logging.getLogger("mkdocs.hooks.checks")

PACKAGE = Path(hwgen.__file__).resolve().parent
CHECKS_PAGE = "checks.md"
# a row of the checks page: its first cell is the check's id, as a code span
_ROW = re.compile(r"^\|\s*`([a-z0-9_]+(?:\.[a-z0-9_]+)+)`\s*\|", re.MULTILINE)
# a code span that is not a link's text already, nor right after the anchor this hook puts before it
_SPAN = re.compile(r"(?<![\[>])`([^`\n]+)`(?!\])")
_FENCE = re.compile(r"^\s*(```|~~~)")


def _loop_values(node: ast.AST, name: str, parents: dict) -> list[str] | None:
    """The literal strings ``name`` takes in the ``for`` loop around ``node`` that binds it, where the
    loop runs over a literal tuple or list (of strings, or of tuples with a string at that place)."""
    up = parents.get(node)
    while up is not None:
        if isinstance(up, (ast.For, ast.comprehension)):
            target, items = up.target, up.iter
            if isinstance(target, ast.Name) and target.id == name:
                index = None
            elif isinstance(target, ast.Tuple) and any(isinstance(e, ast.Name) and e.id == name for e in target.elts):
                index = next(i for i, e in enumerate(target.elts) if isinstance(e, ast.Name) and e.id == name)
            else:
                up = parents.get(up)
                continue
            if not isinstance(items, (ast.Tuple, ast.List)):
                return None
            out = []
            for item in items.elts:
                value = item if index is None else (item.elts[index] if isinstance(item, ast.Tuple) else None)
                if not (isinstance(value, ast.Constant) and isinstance(value.value, str)):
                    return None
                out.append(value.value)
            return out
        up = parents.get(up)
    return None


def _ids_of(expr: ast.AST, parents: dict) -> list[str] | None:
    """The ids a ``Check``'s first argument can take, or None when the source does not say."""
    if isinstance(expr, ast.Constant) and isinstance(expr.value, str):
        return [expr.value]
    if isinstance(expr, ast.Name):
        return _loop_values(expr, expr.id, parents)
    if isinstance(expr, ast.JoinedStr):
        names = [v.value.id for v in expr.values if isinstance(v, ast.FormattedValue) and isinstance(v.value, ast.Name)]
        if len(names) != 1 or len(names) != sum(isinstance(v, ast.FormattedValue) for v in expr.values):
            return None
        values = _loop_values(expr, names[0], parents)
        if values is None:
            return None
        return ["".join(v.value if isinstance(v, ast.Constant) else value for v in expr.values) for value in values]
    return None


def code_check_ids(package: Path = PACKAGE) -> tuple[dict[str, list[str]], list[str]]:
    """Every check id hwgen's source makes, with where (``file:line``), and the places where a
    ``Check`` is made with an id the source does not spell out (to be taught here, or written plainly).
    ``Check(**record)``, which remakes a record read back, names no id and is passed over."""
    found: dict[str, list[str]] = {}
    unknown: list[str] = []
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            name = node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", None)
            if name != "Check":
                continue
            expr = node.args[0] if node.args else next((k.value for k in node.keywords if k.arg == "id"), None)
            if expr is None:
                continue
            where = f"{path.relative_to(package.parent).as_posix()}:{node.lineno}"
            ids = _ids_of(expr, parents)
            if ids is None:
                unknown.append(where)
            for cid in ids or []:
                found.setdefault(cid, []).append(where)
    return found, unknown


def page_check_ids(markdown: str) -> list[str]:
    """The checks a page's tables give a row of their own (the row's first cell)."""
    return _ROW.findall(markdown)


def _linker(fields: set[str], checks: set[str], page: str):
    """A function that turns a code span naming a field or a check into a link from ``page``."""
    here = posixpath.dirname(page)
    to_ref = posixpath.relpath(reference.PAGE, here or ".")
    to_checks = "" if page == CHECKS_PAGE else posixpath.relpath(CHECKS_PAGE, here or ".")

    def link(m: re.Match) -> str:
        text = m.group(1)
        path = re.sub(r"\[\d*\]", "[]", text)          # tendons[1].routing → tendons[].routing
        if path in fields and page != reference.PAGE:
            return f"[`{text}`]({to_ref}#{reference.anchor(path)})"
        if text in checks:
            return f"[`{text}`]({to_checks}#{text})"
        return m.group(0)
    return link


_state: dict = {}


def on_config(config):
    from hwgen.params import json_schema
    _state["fields"] = reference.paths(json_schema())
    page = Path(config["docs_dir"]) / CHECKS_PAGE
    _state["checks"] = set(page_check_ids(page.read_text(encoding="utf-8"))) if page.is_file() else set()
    return config


def on_pre_build(config):
    found, unknown = code_check_ids()
    for where in unknown:
        log.warning(f"a Check at {where} is made with an id the hook cannot read from the source: write it "
                    f"as a literal or a loop over literals, or teach docs/hooks/checks.py")
    for cid in sorted(set(found) - _state["checks"]):
        log.warning(f"check {cid} ({', '.join(found[cid])}) has no row on {CHECKS_PAGE}")


def on_page_markdown(markdown, page, config, files):
    """Link the names of fields and checks; give each row of the checks page its id as an anchor."""
    src = page.file.src_uri
    if src == CHECKS_PAGE:
        markdown = _ROW.sub(lambda m: m.group(0).replace("`", f'<span id="{m.group(1)}"></span>`', 1), markdown)
    link = _linker(_state["fields"], _state["checks"], src)
    out, fenced = [], False
    for line in markdown.split("\n"):
        if _FENCE.match(line):
            fenced = not fenced
        out.append(line if fenced or _FENCE.match(line) else _SPAN.sub(link, line))
    return "\n".join(out)
