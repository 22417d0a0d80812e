"""Each tendon's free span at the tip, from its tip eyelet to its spool, measured against the
exported parts: the tendon as a cylinder of its diameter against every part's STL (placed by its
manifest placement) but its own start disk's and, over the last stretch where it enters between
the flanges, its own spool's. The runs themselves are the manifest's (``tendon_runs``)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..cad.manifest import Manifest, manifest_parts
from .axes import across
from .base import REBUILD, Check
from .meshes import placed_manifold

TENDON_SEARCH_MM = 5.0        # a tendon's nearest other part is reported up to this far
TENDON_SEGMENTS = 16          # facets of the tendon's cylinder


def tendon_cylinder(p0, p1, radius: float):
    """A cylinder of the tendon's diameter from p0 to p1 (robot mm), as a manifold."""
    import manifold3d as m3d
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    length = float(np.linalg.norm(d))
    z = d / length
    x = across(z)
    y = np.cross(z, x)
    m = np.column_stack([x, y, z, p0])
    return m3d.Manifold.cylinder(length, radius, radius, TENDON_SEGMENTS).transform(m.tolist())


def tendon_checks(folder: Path, manifest: Manifest, plan) -> list[Check]:
    """Each tendon's free span (tip face to spool) against every part but its own start disk
    and, over the last stretch where it enters between the flanges, its own spool."""
    folder = Path(folder)
    d = plan.tendon_material.diameter
    every = manifest_parts(manifest)
    runs = [(p.name, r) for p in every for r in p.tendon_runs]
    if not runs:
        return [Check("tensioner.tendon_clearance", "error", False, "no tendon runs in the manifest", fix=REBUILD)]
    parts = [p for p in every if not (p.role == "disk" and p.meta.get("disk_role") == "tip")]
    solids = {}
    out = []
    for own, r in runs:
        start, end = np.asarray(r["start"], float), np.asarray(r["end"], float)
        lo, hi = np.minimum(start, end) - TENDON_SEARCH_MM, np.maximum(start, end) + TENDON_SEARCH_MM
        worst, worst_part, own_gap = math.inf, None, math.inf
        for p in parts:
            bmin, bmax, m = p.bbox_min, p.bbox_max, p.placement
            corners = np.array([[x, y, z] for x in (bmin[0], bmax[0]) for y in (bmin[1], bmax[1])
                                for z in (bmin[2], bmax[2])]) @ m[:3, :3].T + m[:3, 3]
            if np.any(corners.max(axis=0) < lo) or np.any(corners.min(axis=0) > hi):
                continue
            s0, s1 = start, end
            if p.name == own:
                trim = r["own_part_trim_mm"]
                s1 = end - trim * (end - start) / np.linalg.norm(end - start)
            if p.name not in solids:
                solids[p.name] = placed_manifold(folder, p)
            g = float(tendon_cylinder(s0, s1, d / 2).min_gap(solids[p.name], TENDON_SEARCH_MM))
            if p.name == own:
                own_gap = g
            elif g < worst:
                worst, worst_part = g, p.name
        ok = min(worst, own_gap) >= d
        if worst >= TENDON_SEARCH_MM - 1e-9:
            worst_part = None
        near = (f"nearest other part {worst_part} at {worst:.3f} mm" if worst_part else
                f"no other part within {TENDON_SEARCH_MM:g} mm")
        out.append(Check("tensioner.tendon_clearance", "error", ok,
                         f"tendon {r['tendon']}: free span from its tip eyelet to its spool: {near}, its own wheel "
                         f"{own_gap:.3f} mm short of the winding point (needs ≥ the tendon diameter {d:g} mm)",
                         min(worst, own_gap), d,
                         {"tendon": r["tendon"], "part": own if own_gap <= worst else worst_part,
                          "nearest_other_part": worst_part, "nearest_other_mm": min(worst, TENDON_SEARCH_MM)},
                         fix="" if ok else f"hwgen lays the tensioner out around each tendon's run: {REBUILD}"))
        out.append(Check("tensioner.exit_angle", "info", True,
                         f"tendon {r['tendon']}: turns {r['exit_angle_deg']:.1f}° at its tip eyelet toward its spool",
                         r["exit_angle_deg"], None, {"tendon": r["tendon"]}))
    return out
