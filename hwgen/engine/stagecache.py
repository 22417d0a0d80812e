"""The stages after the files through the cache: a stage whose inputs did not change gives what
it wrote last time (its files' bytes and what it added to the manifest) instead of running."""
from __future__ import annotations

from collections.abc import Callable

from .. import cache
from ..cad.manifest import Added
from ..checks.report import REPORT, read_report
from ..outputs import webview
from ..outputs.pictures import MARKED
from ..options import STAGE_FIELDS
from .context import Hashes, StageInput, StageResult

STAGE_REWRITES = {"marks": MARKED}   # files a stage draws again over an earlier stage's (kept in the cache)
STAGE_RESULT = {"checks": REPORT}    # a stage whose report is this file of its outputs (read back by read_report)
RENDERING = ("pictures", "marks")    # stages whose outputs are not kept when no renderer drew them
STAGE_ASSETS = {"view": webview.assets}     # what a stage reads besides the folder, the plan and hwgen's .py code


def stage_key(hashes: Hashes, name: str, given: StageInput) -> str:
    """What a stage after the files is kept under: every file in the folder, the manifest, the plan
    (the design's values as the stages read them), the build's options it reads
    (:meth:`hwgen.options.BuildOptions.stage_fields`), the files besides hwgen's code it reads
    (:data:`STAGE_ASSETS`) and hwgen's code."""
    inputs = (hashes.files(given.folder), given.manifest, given.plan, given.options.stage_fields(name))
    if name in STAGE_ASSETS:
        inputs += (STAGE_ASSETS[name](given.options.viewer),)
    return cache.entry_key("stage " + name, inputs, libraries=cache.LIBRARIES)


def cached_stage(store: cache.Store, hashes: Hashes, name: str, stage: Callable[[StageInput], StageResult],
                 given: StageInput, reused: list[str]) -> StageResult:
    """Run a stage after the files, or take what it wrote last time from the cache (:func:`stage_key`):
    the files it added to the folder and what it added to the manifest (``reused`` then gets its
    name). Pictures that could not be drawn are not kept (another try may find a renderer)."""
    if not store.enabled or name not in STAGE_FIELDS:
        return stage(given)
    folder = given.folder
    before = hashes.files(folder)
    key = stage_key(hashes, name, given)
    kept = _kept(store, key, name, given)
    if kept is not None:
        reused.append(name)
        return kept
    out = stage(given)
    after = hashes.files(folder)
    redrawn = STAGE_REWRITES.get(name, ())
    if any(after.get(path) != sha for path, sha in before.items() if path not in redrawn):
        return out                              # it changed a file it was given: not kept
    render = out.added.sections.get("render", given.manifest.render) or {}
    if name in RENDERING and (render.get("status") != "ok" or "message" in render.get("failing", {})):
        return out                              # another try may find a renderer
    files = {path: store.put_bytes((folder / path).read_bytes()) for path in after
             if path not in before or (path in redrawn and after[path] != before[path])}
    store.put_record(key, {"files": files, "added": out.added.to_json()})
    return out


def _kept(store: cache.Store, key: str, name: str, given: StageInput) -> StageResult | None:
    """What the stage kept under ``key``, its files written into the folder; None when nothing
    whole is kept."""
    rec = store.get_record(key)
    if not isinstance(rec, dict):
        return None
    try:
        blobs = {path: store.get_bytes(sha) for path, sha in rec["files"].items()}
        if any(b is None for b in blobs.values()):
            return None
        added = Added.of(rec["added"])
        for path, data in blobs.items():
            (given.folder / path).parent.mkdir(parents=True, exist_ok=True)
            (given.folder / path).write_bytes(data)
        if name not in STAGE_RESULT:
            return StageResult(added)
        report = read_report(given.folder)
        return None if report is None else StageResult(added, report)
    except (KeyError, TypeError, AttributeError, ValueError):
        return None
