"""view.html in a real browser (tests/browser.py: Debian's Chromium, headless, WebGL on the CPU,
every request but the page's own file refused): it opens offline with no error, draws the robot
(measured in the screenshot's pixels), names every part of the manifest, and a failing robot's page
draws its failing parts magenta with their check ids, and a click on one shows its check."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from hwgen.cad.manifest import read_manifest
from hwgen.checks.report import read_report
from hwgen.outputs.pictures import WARNING_COLOUR, failing_marks
from tests.browser import click, need_browser, opened

WHITE = 0.97          # a pixel whose every channel is above this is background
SHADE = (0.3, 1.3)    # a lit colour is the part's colour times a shade in this range ...
NEAR = 0.08           # ... give or take this RGB distance (0..1)


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float).reshape(-1, 3) / 255


def _share_near(px: np.ndarray, rgb) -> float:
    """Share of the pixels that are ``rgb`` in some shade."""
    c = np.asarray(rgb, float)[:3]
    s = np.clip(px @ c / (c @ c), *SHADE)
    return float((np.linalg.norm(px - s[:, None] * c, axis=1) < NEAR).mean())


@pytest.fixture
def chromium():
    return need_browser()


def test_the_prototype_opens_offline_draws_the_robot_and_names_every_part(built, chromium):
    folder = built("prototype")
    manifest = read_manifest(folder)
    with opened(folder / "view.html", chromium) as (page, visit):
        state = page.evaluate("document.body.dataset.state")
        tree = page.inner_text("nav#tree")
        drawn = page.evaluate("window.hwgenView.parts")
        messages = page.inner_text("#messages")
        canvas = page.locator("#canvas").screenshot()
    assert state == "ready", messages
    assert visit.errors == [] and visit.refused == []
    assert messages == ""
    names = {e.name for e in manifest.parts}
    assert names <= set(tree.split()) and set(drawn) == names       # every part listed, and drawn from the GLB
    px = _pixels(canvas)
    background = float((px.min(axis=1) > WHITE).mean())
    assert 0.2 < background < 0.95, background                         # something drawn, not all of it
    disk = next(e.color for e in manifest.parts if e.role == "disk")
    assert _share_near(px, disk) > 0.02                               # the disks, lit, in their colour
    assert _share_near(px, WARNING_COLOUR) < 1e-3                      # nothing fails: no magenta


def test_a_failing_robot_marks_its_parts_and_a_click_shows_the_check(built, chromium):
    folder = built("twenty-disks")
    parts, tendons = failing_marks(read_report(folder)["checks"])
    assert parts and tendons
    with opened(folder / "view.html", chromium) as (page, visit):
        assert page.evaluate("document.body.dataset.state") == "ready"
        canvas = page.locator("#canvas").screenshot()
        marked = {li.get_attribute("data-part") or li.get_attribute("data-tendon"): li.inner_text()
                  for li in page.locator("nav#tree li.failing").all()}
        labels = page.locator("#labels .label").all_inner_texts()
        name = sorted(parts)[0]
        assert click(page, name), f"no point of {name} is in view"
        title = page.inner_text("#info-title")
        body = page.inner_text("#info-body")
    assert visit.errors == [] and visit.refused == []
    assert set(marked) == set(parts) | set(tendons)
    for n, ids in (parts | tendons).items():
        assert all(i in marked[n] for i in ids), n
    assert any(all(i in text for i in parts[name]) for text in labels)      # its ids beside it in the view
    assert _share_near(_pixels(canvas), WARNING_COLOUR) > 1e-3              # magenta drawn
    assert title.startswith(f"{name}:") and "failed" in title
    assert all(f"FAIL{i}" in body.replace(" ", "").replace("\n", "") for i in parts[name])
