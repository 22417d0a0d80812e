"""report.json's studies as the stages after the checks read them back: typed records made once
from the JSON by ``X.of(doc)``; the checks that write each section are untouched, so the report's
bytes are theirs. (The gravity section's records are :mod:`hwgen.model.gravity`: the statics read
it, and the model may not import the checks.)

- :class:`TensionStudy`: the ``tension`` section's bending sweep, each side's actuating tendon
  hauled in with the stiffening tendons locked and free (what the sim sets its driven pair beside);
- :class:`AsBuiltDisk`: the ``as_built`` section's disks, where each one's mid-plane was measured;
- :class:`TendonReach`: the ``tendons`` section's largest length change of each tendon over the sweep.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class ActuationSide:
    """One side of the tension sweep: the actuating tendon hauled in (``inner``), the angle reached,
    each tendon's tension along the sweep with the stiffening tendons locked, and the inner tendon's
    tension at the end both runs reached, locked and free, with its ``rise`` (``actuation.coupling``)."""

    side: str
    inner: str
    reached_deg: float
    rise: float
    with_stiffening_n: float
    without_n: float
    tensions_n: Mapping[str, tuple[float, ...]]

    @classmethod
    def of(cls, doc: Mapping) -> ActuationSide:
        return cls(side=doc["side"], inner=doc["inner"], reached_deg=doc["reached_deg"], rise=doc["rise"],
                   with_stiffening_n=doc["with_stiffening_n"], without_n=doc["without_n"],
                   tensions_n={t: tuple(v) for t, v in doc["tensions_n"].items()})


@dataclass(frozen=True, kw_only=True)
class TensionStudy:
    """The ``tension`` section as its readers after the checks use it: the sides of its sweep (none
    when the study was skipped)."""

    actuation: tuple[ActuationSide, ...] = ()

    @classmethod
    def of(cls, doc: Mapping | None) -> TensionStudy:
        return cls(actuation=tuple(ActuationSide.of(s) for s in (doc or {}).get("actuation", [])))

    def side_hauling(self, tendon: str | None) -> ActuationSide | None:
        """The side on which ``tendon`` is the one hauled in, if any."""
        return next((s for s in self.actuation if s.inner == tendon), None)


@dataclass(frozen=True, kw_only=True)
class AsBuiltDisk:
    """A disk of the ``as_built`` section: its station and its mid-plane along the strip as measured
    (None where it could not be)."""

    station: int
    y_mid_mm: float | None

    @classmethod
    def of(cls, doc: Mapping) -> AsBuiltDisk:
        y = doc.get("y_mid_mm")
        return cls(station=doc["station"], y_mid_mm=None if y is None else float(y))


def as_built_disks(report: Mapping) -> tuple[AsBuiltDisk, ...]:
    """The disks of ``report``'s ``as_built`` section (none when the section is absent)."""
    return tuple(AsBuiltDisk.of(d) for d in (report.get("as_built") or {}).get("disks", []))


@dataclass(frozen=True, kw_only=True)
class TendonReach:
    """A tendon of the ``tendons`` section: how far its length changes at most over the sweep (mm;
    0 where the study has no figure)."""

    name: str
    max_abs_delta_mm: float

    @classmethod
    def of(cls, doc: Mapping) -> TendonReach:
        return cls(name=doc["name"], max_abs_delta_mm=float(doc.get("max_abs_delta_mm") or 0.0))


def tendon_reaches(report: Mapping) -> tuple[TendonReach, ...]:
    """The tendons of ``report``'s ``tendons`` section."""
    return tuple(TendonReach.of(t) for t in report.get("tendons", []))
