"""view.html in a real browser: Debian's Chromium, headless, driven by Playwright (PyPI; its own
browser download is not used: the machine's /usr/bin/chromium is). WebGL comes from SwiftShader on
the CPU. The page is opened from its file with every request that is not a file refused, so a page
that reached for the network would show it.

A test that needs the browser or the viewer's bundle skips saying what to install, except under
CI (``CI=true``), where it fails: the Makefile's ``clients`` and ``viewer`` targets install them.

    python -m tests.browser VIEW.html OUT.png [PART]    a screenshot of the page (the docs' picture),
                                                        after a click on PART when one is named
"""
from __future__ import annotations

import os
import shutil
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import pytest

CHROMIUM = "chromium"
ARGS = ["--no-sandbox", "--use-gl=swiftshader", "--enable-unsafe-swiftshader", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]
VIEWPORT = {"width": 1400, "height": 900}
READY_MS = 120_000          # SwiftShader draws the prototype's 417 000 placed triangles on the CPU of a loaded machine


def _missing(what: str) -> None:
    if os.environ.get("CI") == "true":
        pytest.fail(f"{what}, and CI must run this test")
    pytest.skip(what)


def need_browser() -> str:
    """The Chromium to drive and the viewer's bundle (else skip, or fail under CI)."""
    from tests.clients import need
    exe = need(CHROMIUM)
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        _missing("Playwright is not installed (pip install -e '.[test]')")
    from hwgen.outputs.webview import BUNDLE, viewer_bundle
    if viewer_bundle() is None:
        _missing(f"the viewer's bundle {BUNDLE} is missing (make viewer; it needs npm)")
    return exe


@dataclass
class Visit:
    """What the page did while it was open."""
    errors: list[str] = field(default_factory=list)       # uncaught exceptions and console errors
    refused: list[str] = field(default_factory=list)      # requests other than the page's own file


@contextmanager
def opened(page_file: Path, exe: str | None = None):
    """(page, visit): the page open from its file, its viewer done (ready, or what it said instead)."""
    from playwright.sync_api import sync_playwright
    exe = exe or need_browser()
    visit = Visit()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=ARGS)
        try:
            context = browser.new_context(viewport=VIEWPORT)
            url = Path(page_file).resolve().as_uri()

            def route(r):
                if r.request.url == url:
                    r.continue_()
                else:
                    visit.refused.append(r.request.url)
                    r.abort()
            context.route("**/*", route)
            page = context.new_page()
            page.on("pageerror", lambda e: visit.errors.append(f"uncaught: {e}"))
            page.on("console", lambda m: visit.errors.append(f"console: {m.text}") if m.type == "error" else None)
            page.goto(url)
            page.wait_for_function("document.body.dataset.state !== 'loading'", timeout=READY_MS)
            yield page, visit
        finally:
            browser.close()


def click(page, name: str) -> bool:
    """Click the part (or tendon) where the view shows it; False when no point of it is in view."""
    point = page.evaluate("(name) => window.hwgenView.pointOn(name)", name)
    if point is None:
        return False
    page.mouse.click(point["x"], point["y"])
    return True


def main(argv: list[str]) -> int:
    page_file, png = Path(argv[0]), Path(argv[1])
    with opened(page_file, shutil.which(CHROMIUM) or "/usr/bin/chromium") as (page, visit):
        if len(argv) > 2 and not click(page, argv[2]):
            visit.errors.append(f"{argv[2]} is not in view")
        page.screenshot(path=str(png))
        state = page.evaluate("document.body.dataset.state")
    print(f"{png}: {state}" + "".join(f"\n  {e}" for e in visit.errors + visit.refused))
    return 0 if state == "ready" and not visit.errors and not visit.refused else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
