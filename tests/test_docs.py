"""The documentation: the README as the front door, the site built strict, the references complete.

The site is built once (`mkdocs build --strict` into a temporary folder): every link and anchor of
every page must resolve, and the hooks in docs/hooks/ run as `make docs` runs them. The parameter
reference is checked against the schema `hwgen schema` prints, walked here on its own (not by the
hook that writes the page); the checks page against every `Check(...)` in hwgen's source. The
guide's image links are tested where the guide is built (tests/test_guide.py).
"""
from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
HOOKS = ROOT / "docs" / "hooks"


def _mkdocs(config: Path, site: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(config),
                           "--site-dir", str(site)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    run = _mkdocs(ROOT / "mkdocs.yml", out)
    assert run.returncode == 0, run.stdout + run.stderr
    return out


def _hook(name: str):
    """A module of docs/hooks/, imported as MkDocs imports it (its folder on the path)."""
    sys.path.insert(0, str(HOOKS))
    try:
        spec = importlib.util.spec_from_file_location(f"docs_hook_{name}", HOOKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(HOOKS))


def test_the_site_builds_strict_with_every_page_of_the_nav(site):
    config = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    pages = re.findall(r":\s*([\w/-]+)\.md\s*$", config, re.MULTILINE)
    assert len(pages) >= 15
    for page in pages:
        html = site / ("index.html" if page == "index" else f"{page}/index.html")
        assert html.is_file(), page
    assert not (site / "hooks").exists() and not list(site.rglob("*.py"))    # the build's code is no page


def test_the_readme_is_the_front_door():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 300, len(lines)
    assert any("make build" in line for line in lines[:15])
    assert any(line.startswith("make test") for line in lines[:15])
    text = "\n".join(lines)
    for command in ("build", "check", "routing", "render", "stiffness", "sim", "plates", "coupon", "sweep",
                    "tune", "schema"):
        assert f"`hwgen {command} " in text or f"`hwgen {command}`" in text, command
    for line in ("failed:", "warning:", ": PASS:", ": FAIL:", "make docs", "site/index.html"):
        assert line in text, line


def test_every_image_and_page_the_readme_links_resolves_from_the_readme():
    text = README.read_text(encoding="utf-8")
    images = re.findall(r"!\[[^\]]*\]\(([^)\s]+)\)", text)
    assert len(images) >= 2
    links = [t for t in re.findall(r"(?<!!)\[[^\]]*\]\(([^)\s#]+)(?:#[^)]*)?\)", text) if "://" not in t]
    assert links
    for target in images + links:
        assert (README.parent / target).exists(), target


def test_the_pictures_are_small():
    for png in (ROOT / "docs" / "images").glob("*.png"):
        assert png.stat().st_size < 5 << 20, png.name
    big = [p.name for p in (ROOT / "docs" / "images").glob("*.png") if p.stat().st_size > 1 << 20]
    assert not big, f"over 1 MB: {big} (make docs-images keeps them as 256-colour PNGs)"


def _schema_paths(schema: dict) -> set[str]:
    """Every field's path in the JSON Schema (``tendons[].routing.function.k``), walked directly."""
    defs = schema.get("$defs", {})

    def resolve(node: dict) -> dict:
        while "$ref" in node:
            node = defs[node["$ref"].rsplit("/", 1)[1]]
        return node

    paths: set[str] = set()

    def walk(node: dict, prefix: str) -> None:
        node = resolve(node)
        for option in node.get("anyOf", []) + node.get("oneOf", []):
            walk(option, prefix)
        if node.get("type") == "array" and isinstance(node.get("items"), dict):
            walk(node["items"], prefix[:-1] + "[]." if prefix else "")
        for name, sub in node.get("properties", {}).items():
            paths.add(prefix + name)
            walk(sub, prefix + name + ".")

    walk(schema, "")
    return paths


def test_the_parameter_reference_names_every_field_of_hwgen_schema(site):
    run = subprocess.run([sys.executable, "-m", "hwgen.cli", "schema"], capture_output=True, text=True,
                         cwd=ROOT, timeout=120)
    assert run.returncode == 0, run.stderr
    paths = _schema_paths(json.loads(run.stdout))
    assert {"backbone.length", "tendons[].routing.function.k", "check.robust_severity", "base"} <= paths
    html = (site / "reference" / "parameters" / "index.html").read_text(encoding="utf-8")
    missing = sorted(p for p in paths if f"<code>{p}</code>" not in html)
    assert not missing, missing


def test_every_check_of_the_code_has_its_row_on_the_checks_page():
    hook = _hook("checks")
    found, unread = hook.code_check_ids()
    assert not unread, f"Check ids the source does not spell out: {unread}"
    # the syntax-tree reader misses none of the ids a plain search of the source sees
    literal = {m for path in (ROOT / "hwgen").rglob("*.py")
               for m in re.findall(r'\bCheck\(\s*"([a-z0-9_.]+)"', path.read_text(encoding="utf-8"))}
    assert literal and literal <= set(found), literal - set(found)
    assert {"eyelet.wall.edge", "eyelet.wall.slot", "gear.teeth", "gear.starts"} <= set(found)   # from loops
    rows = hook.page_check_ids((ROOT / "docs" / "checks.md").read_text(encoding="utf-8"))
    assert len(rows) == len(set(rows)), "a check with two rows"
    missing = {cid: found[cid] for cid in sorted(set(found) - set(rows))}
    assert not missing, f"checks with no row on docs/checks.md: {missing}"


def test_a_check_missing_from_the_checks_page_fails_the_build(tmp_path):
    """The hook that keeps the checks page complete fails `make docs`, not only this suite."""
    shutil.copytree(ROOT / "docs", tmp_path / "docs", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "mkdocs.yml", tmp_path / "mkdocs.yml")
    page = tmp_path / "docs" / "checks.md"
    text = page.read_text(encoding="utf-8")
    page.write_text("\n".join(line for line in text.splitlines() if not line.startswith("| `disk.tilt` |")),
                    encoding="utf-8")
    run = _mkdocs(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert run.returncode != 0
    assert "check disk.tilt" in run.stdout + run.stderr
