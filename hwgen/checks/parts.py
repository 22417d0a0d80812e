"""Whole parts: sound meshes, no two parts occupying the same space, each fits the printer."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path

import numpy as np

from ..cad.manifest import Manifest, manifest_parts
from ..cache import as_json
from .base import REBUILD, Check
from .meshes import measured_by_file, read_mesh, to_manifold

NOT_PRINTED = {"backbone"}     # roles cut from stock rather than printed: no build-volume check
VOLUME_REL_TOL = 0.01          # STL volume versus the solid's volume in the manifest
BBOX_MARGIN_MM = 0.01          # boxes closer than this are tested for interference


@dataclass
class LoadedPart:
    name: str
    role: str
    mesh: object               # trimesh.Trimesh in file coordinates
    placement: np.ndarray
    volume_mm3: float | None
    entry: Mapping = field(default_factory=dict)   # the part's manifest entry
    sha256: str | None = None  # of its file's bytes (None: a mesh not read from a file)

    def measured(self, kind: str, values, compute):
        """``compute()``, a measurement of this part's mesh alone (and of the design ``values`` it
        reads), as JSON gives it back: made once for every file of the same bytes and remembered
        by the file (:func:`hwgen.checks.meshes.measured_by_file`); a mesh of no file is measured."""
        if self.sha256 is None:
            return as_json(compute())
        return measured_by_file(self.sha256, kind, values, compute)

    def soundness(self) -> dict:
        """The mesh's own soundness (:func:`soundness`), measured once per file."""
        return self.measured("part mesh soundness", None, lambda: soundness(self.mesh, self.placement))

    def volume_and_centroid(self) -> tuple[float, np.ndarray] | None:
        """Its closed mesh's volume (mm³) and centre of mass in robot coordinates; None when the
        mesh is not closed."""
        m = self.soundness()
        if not m["watertight"]:
            return None
        com = self.placement[:3, :3] @ np.asarray(m["center_mass"], dtype=float) + self.placement[:3, 3]
        return m["volume"], com

    @property
    def fixture(self) -> bool:
        """An assembly aid (the jig): not part of the robot."""
        return bool(self.entry.get("fixture"))

    def robot_bounds(self) -> np.ndarray:
        v = self.mesh.vertices @ self.placement[:3, :3].T + self.placement[:3, 3]
        return np.array([v.min(axis=0), v.max(axis=0)])


def load_parts(folder: Path, manifest: Manifest) -> tuple[list[LoadedPart], list[Check]]:
    parts, checks = [], []
    for p in manifest_parts(manifest):
        try:
            sha, mesh = read_mesh(p.stl_in(folder))
        except Exception as e:  # unreadable file: say so and go on with the others
            checks.append(Check("part.mesh", "error", False, f"{p.name}: cannot read {p.stl_in(folder).name} ({e})",
                                None, None, {"part": p.name}, fix=REBUILD))
            continue
        parts.append(LoadedPart(p.name, p.role, mesh, p.placement, p.volume_mm3, p.entry, sha))
    return parts, checks


def soundness(mesh, placement: np.ndarray | None = None) -> dict:
    """What :func:`mesh_checks` and :func:`mass_summary` read of one mesh: watertight, consistently
    wound, manifold3d's status (of the solid under ``placement``, which the interference check
    then intersects: made once for both; the status is the mesh's topology, whatever the
    placement), its triangles, and, when closed, its volume and centre of mass (file coordinates)."""
    closed = bool(mesh.is_watertight)
    return {"watertight": closed, "winding": bool(mesh.is_winding_consistent),
            "manifold": to_manifold(mesh, placement).status().name, "triangles": len(mesh.faces),
            "volume": float(mesh.volume) if closed else None,
            "center_mass": [float(v) for v in mesh.center_mass] if closed else None}


def mesh_checks(parts: list[LoadedPart]) -> list[Check]:
    """Watertight, consistently wound, positive volume, accepted by manifold3d, volume as built
    (measured once per file: :meth:`LoadedPart.soundness`)."""
    import manifold3d as m3d
    out = []
    for p in parts:
        m = p.soundness()
        faults = []
        if not m["watertight"]:
            faults.append("not watertight")
        if not m["winding"]:
            faults.append("inconsistent winding")
        if m["watertight"] and m["volume"] <= 0:
            faults.append("inside out (negative volume)")
        if m["manifold"] != m3d.Error.NoError.name:
            faults.append(f"not a manifold ({m['manifold']})")
        vol = m["volume"]
        where = {"part": p.name}
        if faults:
            out.append(Check("part.mesh", "error", False, f"{p.name}: mesh is " + ", ".join(faults),
                             None, None, where, fix=REBUILD))
        else:
            out.append(Check("part.mesh", "error", True,
                             f"{p.name}: watertight manifold, {m['triangles']} triangles, {vol:.1f} mm³",
                             vol, None, where))
        if vol is not None and p.volume_mm3:
            rel = abs(vol - p.volume_mm3) / p.volume_mm3
            ok = rel <= VOLUME_REL_TOL
            out.append(Check("part.volume", "warning", ok,
                             f"{p.name}: STL volume {vol:.1f} mm³ {'matches' if ok else 'differs from'} the solid's "
                             f"{p.volume_mm3:.1f} mm³ ({rel * 100:.2f} %)", rel, VOLUME_REL_TOL, where,
                             fix="" if ok else REBUILD))
    return out


def _together(a: LoadedPart, b: LoadedPart) -> bool:
    """Whether two parts are ever in place at once: a fixture only with the parts it holds (and the
    other pieces of itself), the robot's parts with each other."""
    if a.fixture and b.fixture:
        return True
    if a.fixture or b.fixture:
        f, other = (a, b) if a.fixture else (b, a)
        return other.name in f.entry.get("holds", [])
    return True


def interference_checks(parts: list[LoadedPart], tol_mm3: float) -> list[Check]:
    """Every pair whose boxes meet is intersected with manifold3d; a volume above ``tol_mm3`` fails.
    A fixture (the jig) is tested against the parts it holds and its own other pieces only."""
    out = []
    boxes = {p.name: p.robot_bounds() for p in parts}
    cache = {}
    tested = 0
    for a, b in combinations(parts, 2):
        if not _together(a, b):
            continue
        ba, bb = boxes[a.name], boxes[b.name]
        if np.any(ba[0] > bb[1] + BBOX_MARGIN_MM) or np.any(bb[0] > ba[1] + BBOX_MARGIN_MM):
            continue
        tested += 1
        for p in (a, b):
            if p.name not in cache:
                cache[p.name] = to_manifold(p.mesh, p.placement)
        vol = float((cache[a.name] ^ cache[b.name]).volume())
        ok = vol <= tol_mm3
        where = {"parts": [a.name, b.name]}
        msg = (f"{a.name} and {b.name}: no interference ({vol:.4f} mm³ shared)" if ok else
               f"{a.name} and {b.name} interfere: they share {vol:.3f} mm³ (tolerance {tol_mm3:g} mm³)")
        fix = "" if ok else (f"if a position you gave puts them together (disks.tip_mount.positions, "
                             f"base_mount.disk_screws), move it; else {REBUILD}")
        out.append(Check("part.interference", "error", ok, msg, vol, tol_mm3, where, fix=fix))
    out.append(Check("part.interference.boxes", "info", True,
                     f"{len(parts)} parts: {tested} pair(s) with touching bounding boxes intersected, "
                     f"the other {len(parts) * (len(parts) - 1) // 2 - tested} are apart", float(tested), None, {}))
    return out


def build_volume_checks(parts: list[LoadedPart], build_volume) -> list[Check]:
    """Each printed part, in its print orientation (turning it about Z allowed), fits the printer."""
    out = []
    bx, by, bz = build_volume
    for p in parts:
        if p.role in NOT_PRINTED:
            continue
        ext = p.mesh.bounds[1] - p.mesh.bounds[0]
        fits = ext[2] <= bz and ((ext[0] <= bx and ext[1] <= by) or (ext[0] <= by and ext[1] <= bx))
        size = " × ".join(f"{v:.1f}" for v in ext)
        where = {"part": p.name}
        msg = (f"{p.name}: {size} mm fits the build volume {bx:g} × {by:g} × {bz:g} mm" if fits else
               f"{p.name}: {size} mm does not fit the build volume {bx:g} × {by:g} × {bz:g} mm")
        fix = "" if fits else (
            f"a printer that takes {size} mm (process.build_volume; turning about Z is allowed), or a smaller part"
            + (": disks.outer_diameter under the bed's shorter side" if p.role == "disk" else
               ": the jig is cut into pieces to fit the bed, a fault of hwgen's if one does not" if p.fixture else ""))
        out.append(Check("part.build_volume", "error", fits, msg, float(max(ext)), float(max(build_volume)), where,
                         fix=fix))
    return out


def mass_summary(parts: list[LoadedPart], manifest: Manifest) -> tuple[dict, list[Check]]:
    """Mass and centre of mass of the robot (the base mount included, the jig not) and of everything
    beyond the tip disk, from the STLs (volume and centroid of each closed mesh) and each part's
    density in the manifest (design data: the files do not say what they are printed in)."""
    entries = {p.name: p for p in manifest.parts}
    tip_y = max(manifest.design_report["stations_mm"])
    rows = []
    for p in parts:
        e = entries.get(p.name)
        # the bench's frame and rig are not the robot's (hwgen.checks.bench weighs them)
        weighed = e is not None and e.density_g_cm3 is not None and not p.fixture and not e.meta.get("bench")
        closed = p.volume_and_centroid() if weighed else None
        if closed is None:
            continue
        volume, com = closed
        rows.append((p.name, p.role, volume, volume / 1000 * e.density_g_cm3, com))

    def group(sel) -> dict:
        m = sum(r[3] for r in sel)
        c = sum(r[3] * r[4] for r in sel) / m if m else np.zeros(3)
        return {"parts": [r[0] for r in sel], "volume_cm3": sum(r[2] for r in sel) / 1000, "mass_g": m,
                "center_of_mass_mm": [float(v) for v in c]}
    free_end = group([r for r in rows if r[1] not in ("disk", "backbone") and r[4][1] > tip_y])
    out = {"total": group(rows), "free_end": free_end, "tip_station_y_mm": tip_y}
    beyond = free_end["center_of_mass_mm"][1] - tip_y
    check = Check("mass.free_end", "info", True,
                  f"beyond the tip disk: {len(free_end['parts'])} parts, {free_end['volume_cm3']:.1f} cm³, "
                  f"{free_end['mass_g']:.1f} g, centre of mass {beyond:.1f} mm beyond the tip station "
                  f"(volumes and centroids from the STLs, densities from the manifest); whole robot "
                  f"{out['total']['mass_g']:.1f} g", free_end["mass_g"], None,
                  {"parts": free_end["parts"], "beyond_tip_mm": beyond})
    return out, [check]
