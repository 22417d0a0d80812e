"""What crosses between a sweep's (or a tune's) driver and its workers, typed: the options a batch is
evaluated with (:class:`EvalOptions`) and one rule a row breaks or warns of (:class:`Failure`).

A row's ``failures`` are :class:`Failure` records on the worker; stored (a tune's trials.parquet,
its study's base row) they are :meth:`Failure.to_json`'s dicts, the keys and their order as the
sweep has always written them, and :meth:`Failure.of` reads them back. Whether one fails the
design is :func:`hwgen.checks.base.fails`'s to say, as for a check.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from ..checks.base import fails


@dataclass(frozen=True, kw_only=True)
class Failure:
    """A rule a sweep's row breaks, or only warns of: a check's id (``tendon.length``, ``eyelet.wall``,
    ``stiffening.tip``; ``input`` for bad input, ``error`` for a variant hwgen failed on: both errors),
    its severity, the sentence, what it measured against its limit (what a
    tune's constraints read), where (a tendon's name, the openings), and the check's fix where it
    gives one. Never a passed check: a row records only what fails or warns."""

    id: str
    message: str
    severity: str = "error"
    measured: Any = None
    limit: Any = None
    where: Any = None
    fix: str = ""

    @property
    def passed(self) -> bool:
        return False

    @property
    def fails(self) -> bool:
        """Whether it fails the design (an error; a warning does not)."""
        return fails(self)

    def to_json(self) -> dict:
        out = {"id": self.id, "severity": self.severity, "where": self.where, "measured": self.measured,
               "limit": self.limit, "message": self.message}
        if self.fix:
            out["fix"] = self.fix
        return out

    @classmethod
    def of(cls, f: Failure | Mapping) -> Failure:
        """A record from its JSON (a record is its own)."""
        if isinstance(f, Failure):
            return f
        return cls(id=f["id"], message=f.get("message", ""), severity=f.get("severity", "error"),
                   measured=f.get("measured"), limit=f.get("limit"), where=f.get("where"), fix=f.get("fix") or "")

    @classmethod
    def of_check(cls, c, message: str | None = None) -> Failure:
        """A check's failure (a :class:`hwgen.checks.base.Check` or its JSON) as a row records it: the
        tendon it is about as ``where``; ``message`` in place of the check's own."""
        get = c.get if isinstance(c, Mapping) else (lambda k: getattr(c, k))
        return cls(id=get("id"), message=get("message") if message is None else message, severity=get("severity"),
                   measured=get("measured"), limit=get("limit"), where=(get("where") or {}).get("tendon"),
                   fix=get("fix") or "")


@dataclass(frozen=True, kw_only=True)
class EvalOptions:
    """How :func:`hwgen.sweep.levels.evaluate_batch` evaluates a batch, beyond its level.

    ``robust_samples``: the as-built Monte Carlo's samples a variant. ``keep``: the variants whose
    build-level files are kept, under ``out``. ``cache``: the pipeline's ``cache_dir`` (True: the
    default folder; a folder; False: none). ``screen``: a variant that fails at the lengths level, or
    on its plan's screens, goes no deeper (a tune's trial that cannot be feasible). ``with_plan``:
    called with each valid variant's plan, returns more figures for its row (a tune's objectives;
    as ``statics_failures``, :class:`Failure` records of what those figures judge). ``stop``: called
    with the row once ``with_plan``'s figures are in; True ends the variant there. ``numba_threads``:
    the taut kernel's threads on this worker (None: numba's default)."""

    robust_samples: int = 200
    keep: tuple[int, ...] = ()
    out: str | Path | None = None
    cache: bool | str | Path = True
    screen: bool = False
    with_plan: Callable | None = None
    stop: Callable | None = None
    numba_threads: int | None = None


METRICS = ("centre_mm", "taut_mm", "robust_mm", "clearance_mm", "mass_g", "coupling", "least_tension_n")


@dataclass(kw_only=True)
class Row:
    """One variant's row, as a worker fills it level by level (so not frozen). The sweep's Parquet
    columns are its fields of those names (:func:`hwgen.sweep.run.schema`: ``failures``, ``screened``
    and ``figures`` are not among them); a tune stores :meth:`to_json`, the keys as the row dict had them.

    ``verdict``: pass, fail, error (hwgen failed on it) or bad input. ``per_tendon``: each tendon's
    figures as a JSON list (a Parquet string column). ``screened``: the levels after a failure were
    not run (a tune's trial). ``figures``: what ``EvalOptions.with_plan`` added (a tune's ``statics``
    and ``set_n``), top-level keys of the JSON."""

    variant: int
    hash: str
    level: str
    values: tuple
    verdict: str = "pass"
    message: str = ""
    decoupled: bool | None = None
    checks_failed: int | None = None
    per_tendon: str | None = None
    kept: str | None = None
    cpu_s: float = 0.0
    failures: list[Failure] = field(default_factory=list)
    centre_mm: float | None = None
    taut_mm: float | None = None
    robust_mm: float | None = None
    clearance_mm: float | None = None
    mass_g: float | None = None
    coupling: float | None = None
    least_tension_n: float | None = None
    screened: bool = False
    figures: dict = field(default_factory=dict)

    def set(self, **values) -> None:
        """Fields by name (a level's summary figures); a name the row has no field for is an error."""
        for k, v in values.items():
            if k not in self.__dataclass_fields__ or k == "figures":
                raise AttributeError(f"a row has no field {k!r}")
            setattr(self, k, v)

    def to_json(self) -> dict:
        """The row as the sweep wrote its dict: its fields (``screened`` only when true), the failures'
        JSON, then ``figures``' keys."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name not in ("figures", "screened")}
        out["failures"] = [f.to_json() for f in self.failures]
        if self.screened:
            out["screened"] = True
        out.update(self.figures)
        return out
