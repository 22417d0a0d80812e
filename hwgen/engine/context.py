"""What a build's stages share, passed as one value (:class:`Build`); what a stage after the
files is given (:class:`StageInput`); each file's hash taken once a build (:class:`Hashes`)."""
from __future__ import annotations

import threading
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from .. import cache, params
from ..options import BuildOptions
from ..cad.manifest import Added, Manifest, sha256
from ..checks.report import Report
from ..model.plan import Plan

class WorkAhead(Protocol):
    """What a build's stages see of the checks' work ahead (:class:`hwgen.engine.concurrency.Ahead`)."""

    meshes: dict                    # the parts' STLs read early, for the checks

    def placed(self, index: int, family: str, folder: Path, entries: list[dict]) -> None: ...

    def measure(self, folder: Path, manifest: Manifest) -> None: ...

    def measured(self, folder: Path, manifest: Manifest): ...

    def join(self) -> None: ...

    def abandon(self) -> None: ...


class Hashes:
    """Each file's sha256, read again only when its inode, size or times changed since it was last
    hashed here: every stage keys on every file in the folder, and the STEP files are read once a
    build, not once a stage."""

    def __init__(self):
        self.seen: dict[tuple, str] = {}

    def of(self, path: Path) -> str:
        st = path.stat()
        k = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
        if k not in self.seen:
            self.seen[k] = sha256(path)
        return self.seen[k]

    def files(self, folder: Path) -> dict[str, str]:
        """Every file in ``folder`` (relative path) with its sha256."""
        return {str(p.relative_to(folder)): self.of(p) for p in sorted(folder.rglob("*")) if p.is_file()}


@dataclass(eq=False)
class Build:
    """What the stages of one build share: the design and its plan, where the files go, the
    caches, the options, and the work that runs beside the stages."""

    loaded: params.LoadedDesign
    plan: Plan
    folder: Path                    # the staging folder the files are written into
    target: Path                    # out/<design>, which the staging folder replaces at the end
    store: cache.Store              # the part cache (disabled: --no-cache)
    scratch: cache.Store            # where the build's processes and threads hand each other solids and
    #                                 values: the cache, or without one a store of the build's own that starts empty
    stack: ExitStack                # what lives as long as the build's staging folder (side folders, threads)
    select: Callable[[str], bool] | None = None     # --parts: the parts whose files are written (None: all)
    options: BuildOptions = field(default_factory=BuildOptions)     # how the build is run (its jobs among them)
    progress: Callable[[str, int, int], None] | None = None    # (part name, done, total) as each part is in
    ahead: WorkAhead | None = None      # the checks' work ahead (None: no checks will run)
    measured: threading.Event = field(default_factory=threading.Event)    # the checks' measurement is over
    hashes: Hashes = field(default_factory=Hashes)

    @property
    def whole(self) -> bool:
        """Every part's files are written (no ``--parts``): the assembly and the template too."""
        return self.select is None

    @property
    def jobs(self) -> int:
        """Worker processes for the parts and the assembly (0: this process)."""
        return self.options.jobs


@dataclass(frozen=True)
class StageInput:
    """What a stage after the files is given."""

    plan: Plan
    folder: Path                    # the files so far
    manifest: Manifest
    report: Report | None = None    # the checks' report (None for the checks and the stages beside them)
    ahead: WorkAhead | None = None      # what the build measured ahead for the checks (None: measure here)
    loaded: params.LoadedDesign | None = None   # the checks: the design, to try their fixes on (None: untried)
    options: BuildOptions = field(default_factory=BuildOptions)     # how the build is run (what a stage reads of
    #                                                                 it: hwgen.options.STAGE_FIELDS)


@dataclass(frozen=True)
class StageResult:
    """What a stage after the files gives: what it adds to the manifest, and the checks' report
    (the checks stage's own; None for the others)."""

    added: Added = field(default_factory=Added)
    report: Report | None = None
