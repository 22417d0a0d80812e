"""Copy the build's own pictures into docs/images/ for the README and the site (`make docs-images`).

    python docs/pictures.py BUILD_ROOT docs/images

BUILD_ROOT holds fresh builds of the prototype (with `hwgen sim` and `hwgen experiment`) and of the
twenty-disk robot.
Each picture is kept as a 256-colour PNG when that is smaller (the renders and plots are flat
colours with anti-aliased edges: about a third of the bytes, no visible change), so the repository
stays small; a picture over 1 MB is reported, one over 5 MB refused.
"""
from __future__ import annotations

import io
import sys
from pathlib import Path

from PIL import Image

# docs/images/<name>: the build's file it is made from, under BUILD_ROOT
PICTURES = {
    "prototype-exploded.png": "prototype/exploded.png",
    "prototype-bent.png": "prototype/bent.png",
    "prototype-jig.png": "prototype/jig.png",
    "prototype-sag.png": "prototype/sag.png",
    "prototype-tolerance.png": "prototype/tolerance.png",
    "prototype-stiffness.png": "prototype/stiffness.png",
    "prototype-gravity.png": "prototype/gravity.png",
    "prototype-sim.png": "prototype/sim/sim.png",
    "prototype-experiment.png": "prototype/experiment/experiment.png",
    "prototype-guide-step.png": "prototype/guide/step_03.png",
    "twenty-disks-bent.png": "twenty-disks/bent.png",
    "prototype-view.png": "prototype/view.png",       # view.html in headless Chromium (python -m tests.browser)
}
LARGE = 1 << 20
TOO_LARGE = 5 << 20


def small_png(path: Path) -> bytes:
    """The picture's PNG bytes: as drawn, or quantised to 256 colours (no dithering) if smaller."""
    raw = path.read_bytes()
    with Image.open(path) as im:
        flat = im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    buf = io.BytesIO()
    flat.save(buf, format="PNG", optimize=True)
    return min(raw, buf.getvalue(), key=len)


def main(root: str, dest: str) -> int:
    root_path, dest_path = Path(root), Path(dest)
    dest_path.mkdir(parents=True, exist_ok=True)
    status = 0
    for name, source in PICTURES.items():
        data = small_png(root_path / source)
        if len(data) > TOO_LARGE:
            print(f"error: {name}: {len(data) / LARGE:.1f} MB, over 5 MB: not copied", file=sys.stderr)
            status = 1
            continue
        if len(data) > LARGE:
            print(f"warning: {name}: {len(data) / LARGE:.1f} MB, over 1 MB", file=sys.stderr)
        (dest_path / name).write_bytes(data)
        print(f"{name}: {len(data) // 1024} kB from {source}")
    return status


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
