"""The robot as printed, read from a build: every part's mass, centre of mass and inertia, where
each printed eyelet is, where each tendon is tied and where it meets its drum.

Masses and centres of mass are the manifest's (each STL's volume and centroid times the
printed density, as the checks weigh them); the inertia about the centre of mass is
integrated over the same STL here (trimesh), turned into robot axes by the part's placement.
Eyelets are the check report's measured ones (centre where the hole's axis crosses the disk's
mid-plane, and the axis); a disk's mid-plane is where the checks found it (``as_built``).
Seats (where each tendon is knotted on the base disk) come from the manifest's design report;
each tendon's run to its drum, and the drum's winding radius and sense, from the drum's
manifest entry. The table the base mount stands on: its foot's underside and front edge, from
the mount's STL (the vertices within :data:`FOOT_MM` of its lowest). The bought metal the
tip carries (dowels, screws, nuts) is not in the files: the sim adds it from the model
(:mod:`hwgen.model.steel`). Lengths mm, masses g, inertia g·mm², robot coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..cad.families import BENCH_ROLES      # the bench's parts: not the robot the model simulates
from ..cad.manifest import Manifest, ManifestPart, manifest_parts
from ..checks.meshes import part_meshes
from ..checks.studies import as_built_disks
from ..model import steel
from ..model.gravity import Gravity

FOOT_MM = 0.5                 # a mount vertex this close above its lowest is on the table
TIP_ROLES = ("tensioner_housing", "tensioner_worm", "tensioner_drive", "tensioner_wheel", "tensioner_clamp")
BASE_ROLES = ("base_mount", "base_clamp")


@dataclass(frozen=True)
class Body:
    """A printed part as the sim places it: its file, placement, colour and mass properties."""

    name: str
    role: str
    stl: str                      # path inside the build folder
    sha256: str
    placement: np.ndarray         # 4x4, file -> robot, mm
    color: tuple
    mass_g: float
    com_mm: np.ndarray            # robot frame
    inertia_g_mm2: np.ndarray     # 3x3 about the centre of mass, robot axes
    box_min: np.ndarray           # the part's box, robot frame
    box_max: np.ndarray
    entry: dict


@dataclass(frozen=True)
class Eyelet:
    """A printed eyelet: where its axis crosses its disk's mid-plane, and the axis (robot frame)."""

    station: int
    part: str
    tendons: tuple[str, ...]
    centre_mm: np.ndarray
    axis: np.ndarray
    diameter_mm: float
    measured: bool                # False: the checks found no hole for it; placed where the design puts it


@dataclass(frozen=True)
class Run:
    """A tendon's free span from its tip eyelet to its drum, and the drum it winds on."""

    tendon: str
    channel: str
    start_mm: np.ndarray
    end_mm: np.ndarray            # where it meets the drum
    sense: int                    # +1, -1: which way the drum's turn hauls it
    drum: str                     # the wheel part
    winding: str                  # "same" or "opposite"


@dataclass(frozen=True)
class Printed:
    """Everything the sim reads from one build."""

    disks: dict                   # station -> Body
    tip: list                     # Bodies of the tip assembly (tensioner parts)
    base: list                    # Bodies bolted to the table (base mount, clamp)
    strip: dict                   # the strip as measured: height, thickness, y range, g/mm
    stations_mm: dict             # station -> measured mid-plane y
    disk_thickness_mm: dict       # station -> thickness
    eyelets: list                 # Eyelets
    seats: dict                   # tendon -> (x, z) on the base disk, and the plate face's y
    runs: dict                    # tendon -> Run
    winding_radius_mm: dict       # drum part -> radius
    table: tuple | None = None    # the mount's foot on the table: (z of the table, x min, x max, y min, y max)
    bought: tuple = ()            # the tip's bought metal (hwgen.model.steel.Piece), added by the sim


def _inertia(mesh, placement: np.ndarray, density_g_mm3: float) -> np.ndarray:
    """The STL's inertia about its centre of mass, robot axes, g·mm² (uniform density)."""
    inertia = np.asarray(mesh.moment_inertia, float) * density_g_mm3      # trimesh: density 1 per mm³
    R = placement[:3, :3]
    return R @ inertia @ R.T


def _box(part: ManifestPart) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = part.bbox_min, part.bbox_max
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    placed = corners @ part.placement[:3, :3].T + part.placement[:3, 3]
    return placed.min(axis=0), placed.max(axis=0)


def _foot(mesh, placement: np.ndarray) -> tuple:
    """(z, x min, x max, y min, y max) of a part's lowest vertices (within FOOT_MM), robot frame."""
    v = np.asarray(mesh.vertices, float) @ placement[:3, :3].T + placement[:3, 3]
    low = v[v[:, 2] <= v[:, 2].min() + FOOT_MM]
    return (float(v[:, 2].min()), float(low[:, 0].min()), float(low[:, 0].max()), float(low[:, 1].min()),
            float(low[:, 1].max()))


def _bodies(folder: Path, parts: list[ManifestPart]) -> tuple[dict[str, Body], tuple | None]:
    """Each part's Body, and the base mount's foot (:func:`_foot`; None without a mount)."""
    out, foot = {}, None
    for part, mesh in part_meshes(folder, parts):
        if part.role == "base_mount":
            foot = _foot(mesh, part.placement)
        lo, hi = _box(part)
        out[part.name] = Body(name=part.name, role=part.role, stl=part.stl, sha256=part.files["stl"].sha256,
                              placement=part.placement, color=part.color or (0.7, 0.7, 0.7, 1.0),
                              mass_g=float(part.mass_g), com_mm=np.asarray(part.center_of_mass_mm, float),
                              inertia_g_mm2=_inertia(mesh, part.placement, float(part.density_g_cm3) * 1e-3),
                              box_min=lo, box_max=hi, entry=dict(part.entry))
    return out, foot


def _eyelets(report: dict, drep: dict, stations: dict) -> list[Eyelet]:
    holes = {}
    for d in drep["disks"]:
        for h in d["holes"]:
            holes[(d["index"], tuple(h["tendons"]))] = h
    out = []
    for e in report.get("eyelets", []):
        st_, tendons = int(e["station"]), tuple(e["tendons"])
        hole = holes.get((st_, tendons), {})
        found = e.get("measured_xz_mm") is not None      # ok, moved, or read from the strip's hole (in the slot)
        x, z = e["measured_xz_mm"] if found else e["design_xz_mm"]
        axis = e.get("axis") if found and e.get("axis") is not None else hole.get("axis", (0.0, 1.0, 0.0))
        dia = e.get("diameter_mm") if found and e.get("diameter_mm") else hole.get("diameter_mm", 1.0)
        out.append(Eyelet(st_, e["part"], tendons, np.array([x, stations[st_], z], float),
                          np.asarray(axis, float) / np.linalg.norm(axis), float(dia), found))
    return out


def read_build(folder: Path, manifest: Manifest, report: dict) -> Printed:
    """The printed robot of a build folder (its manifest and check report)."""
    parts = [p for p in manifest_parts(manifest) if not p.fixture and p.role not in BENCH_ROLES]
    bodies, foot = _bodies(folder, [p for p in parts if p.role != "backbone"])
    drep = manifest.design_report
    mids = {d.station: d.y_mid_mm for d in as_built_disks(report) if d.y_mid_mm is not None}
    stations = {i: mids.get(i, float(y)) for i, y in enumerate(drep["stations_mm"])}
    disks = {p.station: bodies[p.name] for p in parts if p.role == "disk"}
    thick = {p.station: float(p.meta["thickness_mm"]) for p in parts if p.role == "disk"}
    g = Gravity.of(report["gravity"])
    strip = {"height_mm": g.height_mm, "thickness_mm": g.thickness_mm, "y_mm": list(g.strip.y_mm),
             "g_per_mm": g.strip.lambda_g_mm, "E_mpa": g.E_mpa}
    base = drep["disks"][0]
    face = stations[0] - thick.get(0, base["thickness_mm"]) / 2
    seats = {s["tendon"]: (float(s["x"]), float(s["z"]), face) for s in base.get("seats", [])}
    runs, radius = {}, {}
    for p in parts:
        if p.role != "tensioner_wheel":
            continue
        radius[p.name] = float(p.meta.get("winding_radius_mm", p.meta.get("spool_diameter_mm", 10.0) / 2))
        for r in p.tendon_runs:
            runs[r["tendon"]] = Run(r["tendon"], p.meta.get("channel", ""), np.asarray(r["start"], float),
                                    np.asarray(r["end"], float), int(r.get("sense", 1)), p.name,
                                    p.meta.get("winding", "same"))
    return Printed(disks=disks, tip=[b for b in bodies.values() if b.role in TIP_ROLES],
                   base=[b for b in bodies.values() if b.role in BASE_ROLES], strip=strip, stations_mm=stations,
                   disk_thickness_mm=thick, eyelets=_eyelets(report, drep, stations), seats=seats, runs=runs,
                   winding_radius_mm=radius, table=foot)


def tip_masses(printed: Printed) -> list:
    """(mass g, centre mm, inertia g·mm²) of each printed part of the tip assembly and of each piece
    of bought metal it carries."""
    return ([(b.mass_g, b.com_mm, b.inertia_g_mm2) for b in printed.tip]
            + [(p.mass_g, np.asarray(p.centre_mm), steel.inertia(p)) for p in printed.bought])
