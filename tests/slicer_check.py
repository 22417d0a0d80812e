"""`make slicer-check`: every print plate of a built design sliced in PrusaSlicer as its process
prints it (SLA with supports and pad, 0.05 mm layers; FDM at 0.2 mm), as laid out. SLA takes
minutes per plate, so this stays out of `make test`, which runs --info and one coarse FDM slice.

    python -m tests.slicer_check out/prototype
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from tests import clients


def main(folder: str) -> int:
    folder = Path(folder)
    summary = json.loads((folder / "manifest.json").read_text())["plates"]
    failed = 0
    with tempfile.TemporaryDirectory(prefix="hwgen-slicer-") as tmp:
        for plate in summary["plates"]:
            path = folder / plate["file"]
            t = time.perf_counter()
            try:
                if summary["technology"] == "SLA":
                    clients.sla_slice(path, summary["bed_mm"], Path(tmp) / (path.stem + ".sl1"))
                else:
                    clients.fdm_slice(path, summary["bed_mm"], Path(tmp) / (path.stem + ".gcode"), coarse=False)
                verdict = "OK"
            except AssertionError as e:
                failed += 1
                verdict = f"FAIL {str(e)[-300:]}"
            print(f"{plate['file']}: {len(plate['parts'])} part(s), {time.perf_counter() - t:.0f} s: {verdict}",
                  flush=True)
    print("OK" if not failed else f"FAIL: {failed} plate(s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
