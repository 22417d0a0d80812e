"""The `build` level: one variant through the whole pipeline (parts, files, `hwgen check`).

Imported by a worker the first time it is given a build-level variant, so CadQuery is imported
once per worker process and stays loaded for every later variant. The files are written into a
temporary folder and removed, except for the variants the sweep file lists under ``keep``: those
go to ``OUT/sweeps/<name>/kept/<variant>-<hash>/<design>/``, with their pictures.
"""
from __future__ import annotations

import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

from .. import pipeline
from ..checks.base import failing
from ..options import BuildOptions
from ..params import LoadedDesign
from .records import EvalOptions
from .spec import Resolved


def build_and_check(r: Resolved, options: EvalOptions) -> tuple[list[dict], str | None]:
    """(the failed error-severity checks, the kept folder or None) of building this variant."""
    loaded = LoadedDesign(design=r.design, source=f"variant {r.index}", sha256=r.hash)
    keep = r.index in set(options.keep)
    cache = options.cache                         # the pipeline's cache_dir: True (default folder), a folder, False
    if keep:
        root = Path(options.out) / "kept" / f"{r.index:06d}-{r.hash[:12]}"
        result = pipeline.build(loaded, root, cache_dir=cache)
        kept = str(result.folder)
    else:
        # pictures and view.html's 3D view of files about to be removed would be wasted
        bare = replace(BuildOptions.from_environment(), pictures=False, viewer="none")
        tmp = tempfile.mkdtemp(prefix="hwgen-sweep-")
        try:
            result = pipeline.build(loaded, Path(tmp), cache_dir=cache, options=bare)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        kept = None
    checks = (result.report or {}).get("checks", [])
    failed = failing(checks)
    return failed, kept
