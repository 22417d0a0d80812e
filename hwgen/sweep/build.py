"""The `build` level: one variant through the whole pipeline (parts, files, `hwgen check`).

Imported by a worker the first time it is given a build-level variant, so CadQuery is imported
once per worker process and stays loaded for every later variant. The files are written into a
temporary folder and removed, except for the variants the sweep file lists under ``keep``: those
go to ``OUT/sweeps/<name>/kept/<variant>-<hash>/<design>/``, with their pictures.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from .. import pipeline
from ..checks.base import failing
from ..outputs.view import BACKEND_ENV
from ..outputs.webview import VIEWER_ENV
from ..params import LoadedDesign
from .spec import Resolved


def build_and_check(r: Resolved, options: dict) -> tuple[list[dict], str | None]:
    """(the failed error-severity checks, the kept folder or None) of building this variant."""
    loaded = LoadedDesign(design=r.design, source=f"variant {r.index}", sha256=r.hash)
    keep = r.index in set(options.get("keep", ()))
    cache = options.get("cache", True)            # the pipeline's cache_dir: True (default folder), a folder, False
    if keep:
        root = Path(options["out"]) / "kept" / f"{r.index:06d}-{r.hash[:12]}"
        result = pipeline.build(loaded, root, cache_dir=cache)
        kept = str(result.folder)
    else:
        # pictures and view.html's 3D view of files about to be removed would be wasted
        saved = {name: os.environ.get(name) for name in (BACKEND_ENV, VIEWER_ENV)}
        os.environ.update({name: "none" for name in saved})
        tmp = tempfile.mkdtemp(prefix="hwgen-sweep-")
        try:
            result = pipeline.build(loaded, Path(tmp), cache_dir=cache)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
            for name, value in saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value
        kept = None
    checks = (result.report or {}).get("checks", [])
    failed = failing(checks)
    return failed, kept
