"""The programs people open hwgen's files in, run headless by the tests and `make slicer-check`.

A test that needs one skips, saying what to install, when it is missing, except under CI
(``CI=true``), where it fails: the Makefile's ``clients`` target installs them there.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

FREECAD = "freecadcmd"
PRUSA = "prusa-slicer"
INSTALL = "apt-get install prusa-slicer freecad (make clients does it as root)"

# FreeCAD 0.20: Import.insert with link groups segfaults headless, without them it works; it may
# still crash on the way out, after the labels are written
FREECAD_LABELS = """
import json, sys
import FreeCAD, Import
doc = FreeCAD.newDocument("names")
Import.insert(sys.argv[-2], doc.Name, useLinkGroup=False)
solids = [o.Label for o in doc.Objects if o.TypeId == "Part::Feature" and o.Shape.Solids and not o.OutList]
with open(sys.argv[-1], "w") as f:
    json.dump(solids, f)
"""


def need(program: str) -> str:
    path = shutil.which(program)
    if path is None:
        if os.environ.get("CI") == "true":
            pytest.fail(f"{program} is not installed, and CI must run this test ({INSTALL})")
        pytest.skip(f"{program} is not installed ({INSTALL})")
    return path


def freecad_labels(step: Path, work: Path) -> list[str]:
    """The labels FreeCAD gives the solids of a STEP file, read headless."""
    exe = need(FREECAD)
    script, out = work / "labels.py", work / "labels.json"
    script.write_text(FREECAD_LABELS)
    proc = subprocess.run([exe, str(script), str(step), str(out)], capture_output=True, text=True, timeout=300)
    assert out.exists(), f"FreeCAD read nothing (exit {proc.returncode}): {proc.stderr[-500:]}"
    return json.loads(out.read_text())


def prusa_info(files: list[Path]) -> list[dict]:
    """`prusa-slicer --info` per object: one dict (size, min/max, manifold, facets, volume, file)."""
    exe = need(PRUSA)
    proc = subprocess.run([exe, "--info", *map(str, files)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-1000:]
    out, current = [], None
    for line in proc.stdout.splitlines():
        head = re.fullmatch(r"\[(.+)\]", line.strip())
        if head:
            current = {"file": head.group(1)}
            out.append(current)
        elif current is not None and "=" in line:
            key, value = (s.strip() for s in line.split("=", 1))
            current[key] = value
    return out


def fdm_slice(plate: Path, bed, gcode: Path, coarse: bool = True) -> str:
    """Slice a plate as it is laid out (no re-arranging) in FDM; the G-code's text. ``coarse``: a
    1.2 mm nozzle at 0.8 mm layers, one perimeter and no infill, which proves the plate slices
    at a fraction of a real print's cost."""
    exe = need(PRUSA)
    w, d, h = (float(v) for v in bed)
    args = [exe, "--printer-technology", "FFF", "--bed-shape", f"0x0,{w:g}x0,{w:g}x{d:g},0x{d:g}",
            "--max-print-height", f"{h:g}", "--dont-arrange", "--gcode-label-objects"]
    args += (["--nozzle-diameter", "1.2", "--layer-height", "0.8", "--first-layer-height", "0.8", "--perimeters", "1",
              "--fill-density", "0", "--top-solid-layers", "0", "--bottom-solid-layers", "0"] if coarse else
             ["--nozzle-diameter", "0.4", "--layer-height", "0.2", "--first-layer-height", "0.2"])
    proc = subprocess.run([*args, "--export-gcode", "-o", str(gcode), str(plate)], capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0 and gcode.exists(), f"{plate.name}: exit {proc.returncode}: {proc.stderr[-1000:]}"
    return gcode.read_text(errors="replace")


def sla_slice(plate: Path, bed, out: Path) -> None:
    """Slice a plate in SLA with supports and pad (minutes per plate)."""
    exe = need(PRUSA)
    w, d, h = (float(v) for v in bed)
    args = [exe, "--printer-technology", "SLA", "--bed-shape", f"0x0,{w:g}x0,{w:g}x{d:g},0x{d:g}",
            "--display-width", f"{w:g}", "--display-height", f"{d:g}", "--display-orientation", "landscape",
            "--max-print-height", f"{h:g}", "--layer-height", "0.05", "--supports-enable", "--pad-enable",
            "--dont-arrange", "--export-sla", "-o", str(out), str(plate)]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=3600)
    assert proc.returncode == 0 and out.exists(), f"{plate.name}: exit {proc.returncode}: {proc.stderr[-1000:]}"
