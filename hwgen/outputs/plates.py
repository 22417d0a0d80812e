"""Print plates: the printed parts oriented for the process, packed onto as few of the printer's
plates as they fit, one 3MF per plate with one named object per part, and a summary.

Everything starts from the files: each printed part's STL (the file is in print orientation,
its largest flat face on z = 0) and its manifest entry. Libraries:

* rectpack (Apache-2.0) packs the parts' footprints, rotations by 90° allowed; the fewest
  plates of a few of its packing and sorting heuristics is kept (it is a heuristic, and cheap);
* lib3mf (BSD-3, the 3MF consortium's own library) writes the 3MF: strict to the standard,
  object names kept, and byte-identical from one build to the next once the UUIDs are fixed
  (uuid5 of the part's name); trimesh's writer draws random UUIDs and zip times.

Orientation, per part:

* FDM: as in the file, its largest flat face on the bed (adhesion, nothing to support under it);
* SLA: flat on the plate when its face on z = 0 covers ``plates.flat_contact_fraction`` of its
  footprint (no supports, holes across the layers stay round, no support scars on that face);
  otherwise tilted by ``plates.sla_tilt_deg`` about the footprint's long axis, to go on the
  slicer's supports (it needs them anyway; tilted, each layer's area, so the peel force off the
  film, stays small). A tilted part that would not fit the printer prints flat, and says so.

A part larger than the plate in every orientation tried goes on no plate and is listed as such
(the checks' ``part.build_volume`` fails it too).

The plates stage is kept between builds as a whole, like every stage after the files
(:mod:`hwgen.pipeline`); within one run, parts whose files have the same bytes are oriented once.
"""
from __future__ import annotations

import ctypes
import locale
import math
import uuid
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..cache import as_json
from ..cad.manifest import Added, Manifest, ManifestPart, sha256
from ..checks.meshes import read_mesh, sharing_meshes
from .bom import is_purchased

FOLDER = "plates"
SUMMARY_MD = "plates.md"
GRID = 100                    # rectpack works on integers: footprints in 1/100 mm
FLAT_NORMAL_Z = 0.999         # a face this close to straight down belongs to the face on the plate
ON_PLATE_MM = 1e-3            # ... when it lies this close to z = 0
UUID_SPACE = uuid.UUID("6d1f0e6a-3c47-5a0b-9e1d-2b1f4f0c9a11")   # hwgen's namespace for the 3MF UUIDs


@dataclass
class Oriented:
    """A part as it prints: vertices with the lowest point on z = 0, the footprint's corner at (0, 0)."""

    name: str
    role: str
    vertices: np.ndarray
    faces: np.ndarray
    how: str                  # "flat" or "tilted"
    reason: str
    volume_mm3: float
    tilt: tuple | None = None  # a tilted part's (axis, degrees)
    sha256: str = ""           # the sha256 of its STL's bytes, when read from a file
    size: np.ndarray = field(init=False, repr=False)    # its box's x, y, z extent, mm

    def __post_init__(self):
        self.size = np.ptp(self.vertices, axis=0)


def _rotation(axis: str, deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _to_corner(v: np.ndarray) -> np.ndarray:
    return v - v.min(axis=0)


def contact_fraction(vertices: np.ndarray, faces: np.ndarray) -> float:
    """The share of the footprint (the convex hull of the part seen from above) that the faces
    lying on z = 0 cover."""
    from scipy.spatial import ConvexHull
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(n, axis=1) / 2
    down = (n[:, 2] < -FLAT_NORMAL_Z * np.linalg.norm(n, axis=1)) & (np.abs(tri[:, :, 2]).max(axis=1) < ON_PLATE_MM)
    hull = ConvexHull(vertices[:, :2]).volume       # a 2-D hull's "volume" is its area
    return float(area[down].sum() / hull) if hull > 0 else 0.0


def decide(vertices: np.ndarray, faces: np.ndarray, technology: str, settings, build_volume) -> dict:
    """The part's print orientation for the process (see the module), as plain values: ``how``
    ("flat" or "tilted"), ``axis`` (the side a tilted part turns about, else None) and ``reason``."""
    v = _to_corner(np.asarray(vertices, float))
    if technology != "SLA":
        return {"how": "flat", "axis": None, "reason": "FDM: its largest flat face on the bed (the file's "
                "orientation): it holds the part down and needs no support under it"}
    share = contact_fraction(v, faces)
    if share >= settings.flat_contact_fraction:
        return {"how": "flat", "axis": None, "reason": f"SLA, flat on the plate: its face on the plate covers "
                f"{share:.0%} of its footprint, so it needs no supports; holes across the layers stay round and "
                f"that face stays clean"}
    size = np.ptp(v, axis=0)
    axis = "x" if size[0] >= size[1] else "y"        # tilt about the long side: the footprint grows least
    if not _fits(np.ptp(_tilted(v, axis, settings), axis=0), build_volume, settings):
        return {"how": "flat", "axis": None, "reason": f"SLA, flat on the plate on supports: its face on the plate "
                f"covers only {share:.0%} of its footprint, but tilted {settings.sla_tilt_deg:g}° it would not fit "
                f"the printer"}
    return {"how": "tilted", "axis": axis, "reason": f"SLA, tilted {settings.sla_tilt_deg:g}° about its long side "
            f"on supports: its face on the plate covers only {share:.0%} of its footprint, so it needs supports "
            f"anyway, and tilted no broad layer peels off the film at once"}


def _tilted(v: np.ndarray, axis: str, settings) -> np.ndarray:
    return _to_corner(v @ _rotation(axis, settings.sla_tilt_deg).T)


def oriented(name: str, role: str, vertices: np.ndarray, faces: np.ndarray, volume: float, decision: dict,
             settings, sha: str = "") -> Oriented:
    """The part as :func:`decide` (``decision``) has it print: its vertices turned and moved so."""
    v = _to_corner(np.asarray(vertices, float))
    if decision["how"] == "tilted":
        return Oriented(name=name, role=role, vertices=_tilted(v, decision["axis"], settings), faces=faces,
                        how="tilted", reason=decision["reason"], volume_mm3=volume,
                        tilt=(decision["axis"], float(settings.sla_tilt_deg)), sha256=sha)
    return Oriented(name=name, role=role, vertices=v, faces=faces, how=decision["how"], reason=decision["reason"],
                    volume_mm3=volume, tilt=None, sha256=sha)


def orient(name: str, role: str, vertices: np.ndarray, faces: np.ndarray, volume: float, technology: str,
           settings, build_volume) -> Oriented:
    """The part's print orientation for the process, with the reason (see the module)."""
    return oriented(name, role, vertices, faces, volume, decide(vertices, faces, technology, settings, build_volume),
                    settings)


def _fits(size, build_volume, settings) -> bool:
    w, d, h = (float(x) for x in build_volume)
    room = np.array([w, d]) - 2 * settings.edge_margin_mm
    a, b = sorted(size[:2])
    return h >= size[2] and a <= min(room) and b <= max(room)


# --------------------------------------------------------------------------- packing

PACKERS = ("MaxRectsBssf", "MaxRectsBaf", "MaxRectsBlsf", "SkylineBlWm", "GuillotineBssfSas")
SORTS = ("SORT_AREA", "SORT_LSIDE", "SORT_PERI", "SORT_SSIDE")


def pack(sizes: dict[str, tuple[float, float]], bed: tuple[float, float], gap: float, margin: float
         ) -> tuple[list[dict[str, tuple[float, float, bool]]], list[str]]:
    """Footprints (name -> (x, y) size, mm) onto as few beds as they fit: a list of plates, each
    name -> (x, y of the footprint's corner, turned 90°), and the names that fit on no bed."""
    import rectpack

    W = int(math.floor((bed[0] - 2 * margin + gap) * GRID))
    H = int(math.floor((bed[1] - 2 * margin + gap) * GRID))
    rects = {n: (int(math.ceil((w + gap) * GRID)), int(math.ceil((h + gap) * GRID))) for n, (w, h) in sizes.items()}
    fit = [n for n, (w, h) in rects.items() if (w <= W and h <= H) or (h <= W and w <= H)]
    best = None
    for algo in PACKERS:
        for sort in SORTS:
            packer = rectpack.newPacker(pack_algo=getattr(rectpack, algo), sort_algo=getattr(rectpack, sort),
                                        rotation=True)
            for n in fit:
                packer.add_rect(*rects[n], rid=n)
            packer.add_bin(W, H, count=len(fit) or 1)
            packer.pack()
            placed = packer.rect_list()
            if len(placed) != len(fit):
                continue
            if best is None or len(packer) < best[0]:
                best = (len(packer), placed)
    plates: list[dict] = [dict() for _ in range(best[0])] if best else []
    for b, x, y, w, h, n in (best[1] if best else []):
        turned = (w, h) != rects[n]
        plates[b][n] = (margin + x / GRID, margin + y / GRID, turned)
    plates = [p for p in plates if p]
    return plates, [n for n in sizes if n not in fit]


def placed_vertices(o: Oriented, x: float, y: float, turned: bool) -> np.ndarray:
    v = o.vertices
    if turned:
        v = _to_corner(v @ _rotation("z", 90).T)
    return v + np.array([x, y, 0.0])


# --------------------------------------------------------------------------- 3MF

@contextmanager
def _locale_kept():
    """lib3mf sets the C library's locale to "C" when it writes (for its numbers); Python then
    reads text as ASCII. The locale is put back as it was."""
    before = locale.setlocale(locale.LC_ALL)
    try:
        yield
    finally:
        locale.setlocale(locale.LC_ALL, before)


def write_3mf(path: Path, objects: list[tuple[str, np.ndarray, np.ndarray]]) -> None:
    """One 3MF of named mesh objects (name, vertices in mm, triangles), each built once where it
    is, through lib3mf; UUIDs are uuid5 of the names, so the bytes repeat."""
    with _locale_kept():
        _write_3mf(path, objects)


@lru_cache(maxsize=1)
def _wrapper():
    """lib3mf's wrapper, loaded once (loading it looks up every function of the library); every
    model made through it is its own."""
    import lib3mf
    return lib3mf.get_wrapper()


def _write_3mf(path: Path, objects) -> None:
    import lib3mf

    wrapper = _wrapper()
    model = wrapper.CreateModel()
    model.SetUnit(lib3mf.ModelUnit.MilliMeter)
    identity = lib3mf.Transform()
    for i in range(3):
        identity.Fields[i][i] = 1.0
    stem = Path(path).stem
    for name, vertices, faces in objects:
        mesh = model.AddMeshObject()
        mesh.SetName(name)
        mesh.SetUUID(str(uuid.uuid5(UUID_SPACE, f"{stem}/{name}/object")))
        V = np.ascontiguousarray(vertices, dtype=np.float32)
        F = np.ascontiguousarray(faces, dtype=np.uint32)
        vbuf = (lib3mf.Position * len(V)).from_buffer(V)
        fbuf = (lib3mf.Triangle * len(F)).from_buffer(F)
        wrapper.checkError(mesh, wrapper.lib.lib3mf_meshobject_setgeometry(
            mesh._handle, ctypes.c_uint64(len(V)), vbuf, ctypes.c_uint64(len(F)), fbuf))
        item = model.AddBuildItem(mesh, identity)
        item.SetUUID(str(uuid.uuid5(UUID_SPACE, f"{stem}/{name}/item")))
    model.SetBuildUUID(str(uuid.uuid5(UUID_SPACE, f"{stem}/build")))
    model.QueryWriter("3mf").WriteToFile(str(path))


def read_3mf(path: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The named mesh objects of a 3MF with their build items' transforms applied (lib3mf, strict)."""
    with _locale_kept():
        return _read_3mf(path)


def _read_3mf(path: Path) -> list[tuple[str, np.ndarray, np.ndarray]]:
    model = _wrapper().CreateModel()
    reader = model.QueryReader("3mf")
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(str(path))
    out = []
    items = model.GetBuildItems()
    while items.MoveNext():
        item = items.GetCurrent()
        obj = item.GetObjectResource()
        mesh = model.GetMeshObjectByID(obj.GetResourceID())
        V = np.array([p.Coordinates[:] for p in mesh.GetVertices()], float)
        F = np.array([t.Indices[:] for t in mesh.GetTriangleIndices()], np.int64)
        T = item.GetObjectTransform()
        M = np.array([[T.Fields[r][c] for c in range(3)] for r in range(4)], float)   # rows: 3 axes, translation
        out.append((mesh.GetName(), V @ M[:3] + M[3], F))
    return out


# --------------------------------------------------------------------------- the stage

def printed_parts(manifest: Manifest) -> list[ManifestPart]:
    return [e for e in manifest.parts if not is_purchased(e)]


def layout(folder: Path, manifest: Manifest, proc, settings) -> tuple[list[Oriented], list[dict], list[str]]:
    """Every printed part oriented, the plates (name -> corner x, y and turned) and the parts on none;
    ``proc``: the plan's process (technology, build volume), ``settings``: its plates settings.
    Parts whose files have the same bytes are decided once."""
    oriented_parts, decided = [], {}
    with sharing_meshes():            # files of the same bytes: one mesh, one decision
        for p in printed_parts(manifest):
            sha, mesh = read_mesh(p.stl_in(folder))
            V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
            if sha not in decided:
                decided[sha] = as_json(decide(V, F, proc.technology, settings, proc.build_volume))
            oriented_parts.append(oriented(p.name, p.role, V, F, float(p.volume_mm3), decided[sha], settings, sha))
    too_tall = {o.name for o in oriented_parts if o.size[2] > proc.build_volume[2]}
    sizes = {o.name: (float(o.size[0]), float(o.size[1])) for o in oriented_parts if o.name not in too_tall}
    plates, nowhere = pack(sizes, proc.build_volume[:2], settings.gap_mm, settings.edge_margin_mm)
    return oriented_parts, plates, sorted(too_tall) + nowhere


def write_plate(path: Path, plate: dict[str, tuple[float, float, bool]], by_name: dict[str, Oriented]) -> bytes:
    """One plate's 3MF at ``path``, its bytes returned."""
    write_3mf(path, [(n, placed_vertices(by_name[n], x, y, turned), by_name[n].faces)
                     for n, (x, y, turned) in sorted(plate.items())])
    return path.read_bytes()


def write_plates(folder: Path, manifest: Manifest, proc, settings) -> Added:
    """plates/plate_NN.3mf and plates/plates.md into the folder (``proc``, ``settings``: as
    :func:`layout` takes them); what the manifest lists of them (the summary, ``plates``, and the files)."""
    folder = Path(folder)
    oriented_parts, plates, nowhere = layout(folder, manifest, proc, settings)
    by_name = {o.name: o for o in oriented_parts}
    (folder / FOLDER).mkdir(exist_ok=True)
    summary = {"technology": proc.technology, "printer": proc.name, "bed_mm": list(proc.build_volume),
               "gap_mm": settings.gap_mm, "edge_margin_mm": settings.edge_margin_mm,
               "plates": [], "not_placed": nowhere,
               "parts": {o.name: {"orientation": o.how, "reason": o.reason} for o in oriented_parts}}
    for k, plate in enumerate(plates, start=1):
        name = f"plate_{k:02d}.3mf"
        data = write_plate(folder / FOLDER / name, plate, by_name)
        tallest = max(plate, key=lambda n: by_name[n].size[2])
        summary["plates"].append({
            "file": f"{FOLDER}/{name}", "sha256": sha256(folder / FOLDER / name),
            "parts": sorted(plate),
            "volume_ml": round(sum(by_name[n].volume_mm3 for n in plate) / 1000, 2),
            "tallest": {"part": tallest, "height_mm": round(float(by_name[tallest].size[2]), 2)},
            "placed": {n: {"x_mm": round(x, 2), "y_mm": round(y, 2), "turned_90": t} for n, (x, y, t) in
                       sorted(plate.items())}})
    (folder / FOLDER / SUMMARY_MD).write_text(summary_markdown(manifest, summary), encoding="utf-8")
    files = {Path(p["file"]).stem: {"path": p["file"], "sha256": p["sha256"]} for p in summary["plates"]}
    files["plates_md"] = {"path": f"{FOLDER}/{SUMMARY_MD}", "sha256": sha256(folder / FOLDER / SUMMARY_MD)}
    return Added({"plates": summary}, files)


def summary_markdown(manifest: Manifest, s: dict) -> str:
    what = "resin" if s["technology"] == "SLA" else "filament"
    bed = " × ".join(f"{v:g}" for v in s["bed_mm"])
    total = sum(p["volume_ml"] for p in s["plates"])
    L = [f"# Print plates: {manifest.name}", "",
         f"{s['printer']} ({s['technology']}), build volume {bed} mm; {len(s['plates'])} plate(s), "
         f"{s['gap_mm']:g} mm between parts, {s['edge_margin_mm']:g} mm from the edge. Parts' {what}: "
         f"{total:.1f} ml in all (before supports and waste).", ""]
    if s["technology"] == "SLA":
        L += ["Print time on a resin printer follows the tallest part of the plate (every layer takes the "
              "same time, whatever its area).", ""]
    L += [f"| plate | parts | {what}, ml | tallest part | height, mm |", "|---|---|---:|---|---:|"]
    for p in s["plates"]:
        L.append(f"| `{p['file']}` | {', '.join(p['parts'])} | {p['volume_ml']:.2f} | {p['tallest']['part']} | "
                 f"{p['tallest']['height_mm']:.1f} |")
    if s["not_placed"]:
        L += ["", f"Too large for this printer, on no plate: {', '.join(s['not_placed'])}."]
    L += ["", "## Orientation", "", "| part | prints | why |", "|---|---|---|"]
    for name, o in s["parts"].items():
        L.append(f"| {name} | {o['orientation']} | {o['reason']} |")
    return "\n".join(L) + "\n"
