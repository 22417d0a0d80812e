"""How a build is run, as one frozen value passed from the command line to the pipeline.

The options change how a build goes, not what the robot is: where the cache stops, whether the
pictures are drawn, how many as-built samples the checks draw, how many worker processes make
the parts. The stages that read one are given it in their input, and the cache keeps what a stage
made under the options it read (:meth:`BuildOptions.stage_fields`), never under the process's
environment. The environment is read once, at the edge (:meth:`BuildOptions.from_environment`:
the command line's defaults, and those of a caller that gives none); nothing in hwgen writes it,
and a child process is given its environment explicitly.
"""
from __future__ import annotations

import os
from dataclasses import asdict, dataclass, replace

from . import cache
from .errors import InputError, clip

SAMPLES_ENV = "HWGEN_CHECK_SAMPLES"     # a count: overrides check.samples (smoke runs, the test suite)
BACKEND_ENV = "HWGEN_RENDER_BACKEND"    # "none": behave as if no OpenGL backend worked (tests, CI)
VIEWER_ENV = "HWGEN_VIEWER_JS"          # the viewer's bundle, if not where `make viewer` puts it; "none": no viewer
MAX_SAMPLES = 100_000

# the options each stage after the files reads besides the folder, the manifest and the plan: what
# the cache keeps it under (a stage not named here is not kept)
STAGE_FIELDS = {"checks": ("check_samples",), "bom": (), "plates": (), "guide": (),
                "pictures": ("pictures", "display"), "marks": ("pictures", "display"), "view": ("viewer",)}


@dataclass(frozen=True, kw_only=True)
class BuildOptions:
    """How one build is run (none of it is the design)."""

    cache_size: int = cache.DEFAULT_SIZE    # bytes the part cache is trimmed to at the end of a build
    pictures: bool = True           # draw the pictures (False: recorded as switched off, as without OpenGL)
    display: bool = False           # an X display the renderer may fall back on (its pictures may differ)
    viewer: str = ""                # view.html's viewer bundle: "" where `make viewer` puts it, a file, "none"
    check_samples: int | None = None    # the as-built Monte Carlo's samples (None: the design's check.samples)
    jobs: int = 0                   # worker processes for the parts and the assembly (0: the build's own process)

    def stage_fields(self, name: str) -> dict:
        """The options stage ``name`` reads, by name: part of what it is kept under in the cache."""
        return {k: getattr(self, k) for k in STAGE_FIELDS[name]}

    def with_jobs(self, jobs: int | None) -> BuildOptions:
        return self if jobs is None else replace(self, jobs=jobs)

    def to_json(self) -> dict:
        return asdict(self)

    @classmethod
    def from_environment(cls, **given) -> BuildOptions:
        """The options the environment states ($HWGEN_CACHE_SIZE, $HWGEN_RENDER_BACKEND,
        $HWGEN_VIEWER_JS, $HWGEN_CHECK_SAMPLES, $DISPLAY), with those ``given`` (not None) instead;
        a value the environment states wrongly is bad input naming it."""
        env = os.environ
        found = {"pictures": env.get(BACKEND_ENV, "").strip().lower() != "none",
                 "display": bool(env.get("DISPLAY")), "viewer": env.get(VIEWER_ENV, "")}
        size = env.get(cache.ENV_SIZE, "").strip()
        if size:
            try:
                found["cache_size"] = cache.parse_size(size)
            except ValueError:
                raise InputError("environment", cache.ENV_SIZE, f"{clip(size)} is not a size (2G, 500M, bytes)") \
                    from None
        samples = env.get(SAMPLES_ENV, "").strip()
        if samples:
            if not samples.isdigit() or int(samples) > MAX_SAMPLES:
                raise InputError("environment", SAMPLES_ENV, f"{clip(samples)} is not a count of samples "
                                                             f"(0 to {MAX_SAMPLES})")
            found["check_samples"] = int(samples)
        found.update((k, v) for k, v in given.items() if v is not None)
        return cls(**found)
