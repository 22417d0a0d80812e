"""The manifest: per part its files and their sha256, volume, box and placement, the design
report the checks compare the files against, and what each stage after the files adds. Plain
JSON on disk; no CAD kernel.

Written here and read here: :class:`Manifest` is the manifest as every stage reads it,
:func:`read_manifest` its one reader and :func:`write_manifest` its one writer; a stage after
the files returns what it adds (:class:`Added`) and only the pipeline puts it in
(:meth:`Manifest.adding`). :class:`ManifestPart` is one part's entry as the later stages use it
(its files, placement, role, mass, its family's own fields), a frozen record, so no stage spells
the JSON's common keys itself; the manifest holds them as records and writes each back as read."""
from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..atomic import write_json
from . import Part, mass_properties

if TYPE_CHECKING:
    from ..model.plan import Plan

MANIFEST = "manifest.json"


@dataclass(frozen=True)
class Added:
    """What one stage after the files adds to the manifest: its own sections (``checks``,
    ``bom``, ``plates``, ``render``, ``guide``, ``view``) and the files it wrote that the manifest lists
    (key -> {"path", "sha256", ...})."""

    sections: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {"sections": self.sections, "files": self.files}

    @staticmethod
    def of(doc: Mapping) -> Added:
        return Added(dict(doc["sections"]), dict(doc["files"]))


@dataclass(frozen=True)
class Manifest:
    """manifest.json as the stages read it. The fields before ``parts_written`` are the files'
    (written by the parts' stage); the ones after are the stages' after the files, None until
    the stage ran (a ``--parts`` build runs none). The JSON holds them in this order."""

    name: str                           # the design's name (the JSON's "design")
    hwgen_version: str
    params_file: str
    params_sha256: str
    params_base: list                   # the file's base, its base's base, ...: merged under it
    design_resolved: dict               # the design as read, bases merged
    files: dict                         # the whole design's files: key -> {"path", "sha256", ...}
    parts: tuple[ManifestPart, ...]     # each part's record, in the build's order
    design_report: dict                 # :func:`design_report`
    parts_written: dict | None = None   # a --parts build: the pattern and the parts it wrote
    checks: list | None = None          # the checks' records (report.json's)
    checks_ok: bool | None = None
    bom: dict | None = None
    plates: dict | None = None
    render: dict | None = None
    guide: dict | None = None
    view: dict | None = None            # view.html: what the page holds and what it could not draw

    def to_json(self) -> dict:
        return {_JSON_KEY.get(f.name, f.name): [p.to_json() for p in self.parts] if f.name == "parts"
                else getattr(self, f.name) for f in dataclasses.fields(self)
                if getattr(self, f.name) is not None or f.default is not None}

    @staticmethod
    def of(doc: Mapping) -> Manifest:
        """The manifest a JSON document holds; KeyError or TypeError when it is not one hwgen wrote."""
        fields = {_JSON_KEY.get(f.name, f.name): f.name for f in dataclasses.fields(Manifest)}
        given = {fields[k]: v for k, v in doc.items() if k in fields}
        if "parts" in given:
            given["parts"] = tuple(ManifestPart.of(e) for e in given["parts"])
        return Manifest(**given)

    def adding(self, added: Added) -> Manifest:
        """This manifest with a stage's sections and files put in (files already listed keep their place)."""
        return dataclasses.replace(self, files={**self.files, **added.files}, **added.sections)

    def copy(self) -> Manifest:
        """A deep copy, for a stage that runs beside others."""
        return Manifest.of(json.loads(json.dumps(self.to_json())))


_JSON_KEY = {"name": "design"}          # a field whose JSON key is another word


def read_manifest(folder: str | Path) -> Manifest:
    """The manifest of a built folder, as :func:`write_manifest` wrote it."""
    return Manifest.of(json.loads((Path(folder) / MANIFEST).read_text()))


def write_manifest(folder: str | Path, manifest: Manifest) -> None:
    """manifest.json into the folder, whole or not at all."""
    write_json(Path(folder) / MANIFEST, manifest.to_json())


@dataclass(frozen=True, kw_only=True)
class PartFile:
    """One file of a part: its path inside the build folder and its sha256."""

    path: str
    sha256: str


# the keys every part's entry has (:func:`entry`); the others are its family's own (:attr:`ManifestPart.meta`)
COMMON_KEYS = ("name", "role", "files", "volume_mm3", "material", "density_g_cm3", "mass_g", "center_of_mass_mm",
               "bbox_mm", "placement", "color", "station")


@dataclass(frozen=True, kw_only=True, eq=False)
class ManifestPart:
    """One part's manifest entry as every later stage reads it: the fields all parts have, typed,
    and ``meta``, the fields only its family has (a drum's tendons and runs, a worm's teeth, the
    housing's layout record, the hardware a part takes). ``entry`` is the JSON entry whole, as
    read or as the parts' stage made it: what the manifest writes back, in its keys' order. Two
    records are equal when their entries are."""

    name: str
    role: str
    files: Mapping[str, PartFile]       # "stl", "step" (and "brep" in the part cache)
    placement: np.ndarray               # 4x4: file coordinates -> robot coordinates, mm
    station: int | None
    volume_mm3: float | None
    mass_g: float | None
    material: str | None
    density_g_cm3: float | None
    center_of_mass_mm: tuple[float, ...] | None     # in robot coordinates
    color: tuple[float, ...] | None
    bbox_min: np.ndarray                # the solid's box in file coordinates, mm
    bbox_max: np.ndarray
    fixture: bool                       # an assembly aid (the jig), not part of the robot
    meta: Mapping                       # the family's own fields (the entry's keys beyond COMMON_KEYS)
    entry: Mapping

    @staticmethod
    def of(entry: Mapping | ManifestPart) -> ManifestPart:
        """The record of a manifest entry (a record is its own)."""
        if isinstance(entry, ManifestPart):
            return entry
        bbox = entry["bbox_mm"]
        com, color = entry.get("center_of_mass_mm"), entry.get("color")
        return ManifestPart(
            name=entry["name"], role=entry.get("role", ""),
            files={kind: PartFile(path=f["path"], sha256=f["sha256"]) for kind, f in entry["files"].items()},
            placement=np.asarray(entry["placement"], dtype=float), station=entry.get("station"),
            volume_mm3=entry.get("volume_mm3"), mass_g=entry.get("mass_g"), material=entry.get("material"),
            density_g_cm3=entry.get("density_g_cm3"), center_of_mass_mm=None if com is None else tuple(com),
            color=None if color is None else tuple(color), bbox_min=np.asarray(bbox["min"], dtype=float),
            bbox_max=np.asarray(bbox["max"], dtype=float), fixture=bool(entry.get("fixture")),
            meta={k: v for k, v in entry.items() if k not in COMMON_KEYS}, entry=entry)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ManifestPart) and self.entry == other.entry

    __hash__ = None     # type: ignore[assignment]  # equal by a mapping's value

    def to_json(self) -> dict:
        return dict(self.entry)

    @property
    def stl(self) -> str:
        """The STL's path inside the build folder."""
        return self.files["stl"].path

    @property
    def step(self) -> str:
        """The STEP file's path inside the build folder."""
        return self.files["step"].path

    def stl_in(self, folder: str | Path) -> Path:
        return Path(folder) / self.stl

    @property
    def channel(self) -> str | None:
        """The tensioner's channel the part belongs to (its worm, wheel, ...), None elsewhere."""
        ch = self.meta.get("channel")
        return ch if isinstance(ch, str) else None

    @property
    def tendons(self) -> list[str]:
        """The tendons a drum winds (none for other parts)."""
        return list(self.meta.get("tendons") or [])

    @property
    def tendon_runs(self) -> list[Mapping]:
        """Each tendon's run from the tip eyelet to its drum, as the tensioner's parts record it."""
        return list(self.meta.get("tendon_runs") or [])

    @property
    def hardware(self) -> list[Mapping]:
        """The bought hardware the part takes (screws, nuts, bearings), as its family lists it."""
        return list(self.meta.get("hardware") or [])


def manifest_parts(manifest: Manifest) -> list[ManifestPart]:
    """Every part of a manifest, in its order."""
    return list(manifest.parts)


def manifest_files(manifest: Manifest) -> list[PartFile]:
    """Every file the manifest lists: each part's, then the whole design's (assembly, template, ...)."""
    out = [f for p in manifest_parts(manifest) for f in p.files.values()]
    return out + [PartFile(path=f["path"], sha256=f["sha256"]) for f in manifest.files.values()]


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def design_report(plan: Plan) -> dict:
    """The design intent the checks compare against, as plain JSON."""
    return {
        "stations_mm": list(plan.stations),
        "tendons": [{"name": p.name, "channel": p.channel, "source": p.source, "budget_mm": p.budget_mm,
                     "eyelets_xz_mm": p.points.tolist()} for p in plan.paths],
        "disks": [{"index": d.index, "y_mm": d.y, "role": d.role, "thickness_mm": d.thickness,
                   "outer_diameter_mm": d.outer_diameter, "slot_mm": [d.slot_width, d.slot_height],
                   "holes": [{"x": h.x, "z": h.z, "axis": list(h.axis), "diameter_mm": h.diameter,
                              "tendons": list(h.tendons), "worst_angle_deg": h.worst_angle_deg,
                              "in_slot": h.in_slot} for h in d.holes],
                   "edge_mm": d.edge_size,
                   "mount_holes": [list(m) for m in d.mount_holes],
                   "engagement_mm": d.engagement,
                   "hub": None if d.hub is None else {
                       "side": d.hub.side, "length_mm": d.hub.length, "wall_mm": d.hub.wall,
                       "windows_x_mm": [list(w) for w in d.hub.windows],
                       "glue_port": None if d.hub.port is None else {
                           "x_mm": d.hub.port[0], "beyond_face_mm": d.hub.port[1], "diameter_mm": d.hub.port[2]}},
                   "seat_plate_mm": d.seat_plate,
                   "seat_chambers": [{"x": x, "z": z, "diameter_mm": dia, "height_mm": h}
                                     for x, z, dia, h in d.seat_chambers],
                   "seats": [{"tendon": s.tendon, "x": s.x, "z": s.z, "diameter_mm": s.diameter,
                              "termination_mm": s.termination} for s in d.seats]} for d in plan.disks],
        "merges": [{"station": m.station, "tendons": list(m.tendons), "kind": m.kind} for m in plan.merges],
        "backbone_holes": [{"tendon": h.tendon, "station": h.station, "x_mm": h.x, "y_mm": h.y,
                            "diameter_mm": h.diameter} for h in plan.backbone.holes],
        "findings": list(plan.findings),
    }


def measure(part: Part) -> dict:
    """What the manifest needs from the solid itself: volume (mm³), centre of mass and bounding
    box in file coordinates (mm). Plain JSON, so the part cache can keep it with the files."""
    bb = part.solid.BoundingBox()
    volume, com = mass_properties(part.solid)
    return {"volume_mm3": volume, "center_of_mass_file_mm": list(com),
            "bbox_mm": {"min": [bb.xmin, bb.ymin, bb.zmin], "max": [bb.xmax, bb.ymax, bb.zmax]}}


def describe(part: Part) -> dict:
    """The part without its solid, as plain JSON: everything its manifest entry holds besides
    the measurements and the files."""
    return {"name": part.name, "role": part.role, "placement": np.asarray(part.placement).tolist(),
            "color": list(part.color), "station": part.station, "meta": part.meta, "material": part.material,
            "density_g_cm3": part.density_g_cm3}


def entry(described: dict, measured: dict, files: dict[str, Path], root: Path, material: str,
          density_g_cm3: float, hashes: dict[str, str] | None = None) -> dict:
    """A manifest entry from :func:`describe` and :func:`measure` of a part (fresh, or as the part
    cache kept them) and its files (their sha256 from ``hashes`` when given, else read)."""
    if described["density_g_cm3"] is not None:
        material, density_g_cm3 = described["material"], described["density_g_cm3"]
    volume = measured["volume_mm3"]
    com_robot = np.asarray(described["placement"], float) @ [*measured["center_of_mass_file_mm"], 1.0]
    out = {
        "name": described["name"],
        "role": described["role"],
        "files": {kind: {"path": str(p.relative_to(root)), "sha256": hashes[kind] if hashes else sha256(p)}
                  for kind, p in files.items()},
        "volume_mm3": volume,
        "material": material,
        "density_g_cm3": density_g_cm3,
        "mass_g": volume / 1000 * density_g_cm3,
        "center_of_mass_mm": [float(v) for v in com_robot[:3]],
        "bbox_mm": measured["bbox_mm"],
        "placement": described["placement"],
        "color": described["color"],
    }
    if described["station"] is not None:
        out["station"] = described["station"]
    out.update(described["meta"])
    return out
