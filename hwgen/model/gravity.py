"""report.json's ``gravity`` section as typed records: the strip's own weight as the checks
measured it from the files (:mod:`hwgen.checks.gravity` writes the section), read by the statics
(:func:`hwgen.model.stiffness.describe`), the sim and the plots.

The section stays the JSON object it is on disk (the report's bytes do not change); :meth:`Gravity.of`
reads it into records once, so no reader spells its keys. Its figures, its curve and its cases
beyond those read here stay in :attr:`Gravity.document`."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True, kw_only=True)
class StripWeight:
    """The strip's weight, from its STL's volume and the manifest's density."""

    part: str
    mass_g: float
    y_mm: tuple[float, float]           # where the strip runs along the robot's axis, mm
    lambda_g_mm: float                  # its weight per mm, g/mm


@dataclass(frozen=True, kw_only=True)
class PointWeight:
    """A disk between the base and the tip as a point weight at its centre of mass."""

    part: str
    s_mm: float                         # along the strip, from the base disk's mid-plane
    mass_g: float


@dataclass(frozen=True, kw_only=True)
class TipWeight:
    """Everything beyond the tip station, rigid on the tip frame (printed parts and bought metal)."""

    mass_g: float
    a_mm: float                         # its centre of mass beyond the tip station, along the strip
    z_mm: float                         # ... and off the strip's plane


@dataclass(frozen=True, kw_only=True)
class StiffSpan:
    """A stretch of the strip stiffened by a glued hub, or held rigid by a disk's plate."""

    start_mm: float
    end_mm: float
    ei_nmm2: float | None               # its bending stiffness; None: rigid (a plate)


@dataclass(frozen=True, kw_only=True)
class Gravity:
    """The gravity section: the strip's section and weight, the disks' and the tip's, the spans."""

    model: str
    E_mpa: float                        # the strip's modulus
    height_mm: float                    # the strip's section as measured
    thickness_mm: float
    length_mm: float                    # base disk's mid-plane to the tip station
    strip: StripWeight
    disks: tuple[PointWeight, ...]
    tip: TipWeight
    spans: tuple[StiffSpan, ...]
    cases: Mapping[str, Mapping]        # per direction of gravity ("-z", "+z"): the solved sag's figures
    document: Mapping                   # the section whole, as report.json holds it

    @staticmethod
    def of(doc: Mapping | Gravity | None) -> Gravity | None:
        """The records of a gravity section; None when there is none (no strip was measured)."""
        if doc is None or isinstance(doc, Gravity):
            return doc
        if not doc.get("strip") or not doc.get("tip_assembly"):
            return None
        s, t = doc["strip"], doc["tip_assembly"]
        return Gravity(
            model=str(doc.get("model", "")), E_mpa=float(doc["E_mpa"]), height_mm=float(doc["height_mm"]),
            thickness_mm=float(doc["thickness_mm"]), length_mm=float(doc["length_mm"]),
            strip=StripWeight(part=s["part"], mass_g=float(s["mass_g"]),
                              y_mm=(float(s["y_mm"][0]), float(s["y_mm"][1])), lambda_g_mm=float(s["lambda_g_mm"])),
            disks=tuple(PointWeight(part=d["part"], s_mm=float(d["s_mm"]), mass_g=float(d["mass_g"]))
                        for d in doc.get("disks", [])),
            tip=TipWeight(mass_g=float(t["mass_g"]), a_mm=float(t["a_mm"]), z_mm=float(t["z_mm"])),
            spans=tuple(StiffSpan(start_mm=float(p["start_mm"]), end_mm=float(p["end_mm"]),
                                  ei_nmm2=None if p["ei_nmm2"] is None else float(p["ei_nmm2"]))
                        for p in doc.get("spans", [])),
            cases=doc.get("cases", {}), document=doc)
