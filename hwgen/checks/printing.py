"""Printability of each part as it lies in its file (the print orientation): for resin printed
bottom-up (SLA), no cavity may be closed below and open above. Such a cup holds resin against
the vat's film at every layer, the peel pulls on it, and uncured resin is trapped inside; the
remedy is a vent through its floor or another orientation. No part may hold a closed void
either (it cannot drain). Measured by slicing the STL layer by layer."""
from __future__ import annotations

import numpy as np

from .base import REBUILD, Check
from .parts import NOT_PRINTED, LoadedPart
from .meshes import to_manifold
from .polygons import signed_area

LAYER_MM = 0.5               # slicing step: finer than any cavity worth reporting
CUP_MIN_AREA_MM2 = 1.0       # a closed-below hole smaller than this (under Ø1.1 mm) holds too little to matter


def cups(mesh) -> list[tuple[float, float, tuple[float, float]]]:
    """(height Z, area mm², centroid) of every cavity closed below, where it first appears."""
    import manifold3d as m3d
    solid = to_manifold(mesh)
    z_top = float(mesh.bounds[1, 2])
    found = []
    below = None
    for z in np.arange(LAYER_MM / 2, z_top, LAYER_MM):
        section = solid.slice(float(z))
        if below is not None:
            for contour in section.to_polygons():
                a = signed_area(contour)
                if a >= 0 or -a < CUP_MIN_AREA_MM2:
                    continue            # outer boundaries wind counter-clockwise, holes clockwise
                hole = m3d.CrossSection([contour[::-1]])
                # open below if any of it lies over a hole or outside the part one layer down
                if (hole - below).area() < 1e-3 * hole.area():
                    c = contour.mean(axis=0)
                    if not any(abs(f[0] - z) < 2 * LAYER_MM and np.hypot(*(np.subtract(f[2], c))) < 0.5
                               for f in found):
                        found.append((float(z), float(-a), (float(c[0]), float(c[1]))))
        below = section
    return found


def closed_voids(mesh) -> int:
    """How many of a closed mesh's shells (its faces connected through shared edges) enclose
    negative volume: each is a void wound inward. A mesh of one shell has its own volume's sign,
    already known; only a mesh of several has each shell's volume summed over its own faces."""
    import trimesh
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))
    shells = int(labels.max()) + 1 if len(labels) else 0
    if shells <= 1:
        return int(shells == 1 and mesh.volume < 0)
    tri, cross = mesh.triangles, mesh.triangles_cross
    return sum(trimesh.triangles.mass_properties(tri[k], crosses=cross[k], skip_inertia=True).volume < 0
               for k in (labels == i for i in range(shells)))


def printing_checks(parts: list[LoadedPart], technology: str) -> list[Check]:
    """One check per printed part: no closed void; and, for resin, no cup (each measured once per
    file: :meth:`hwgen.checks.parts.LoadedPart.measured`)."""
    out = []
    for p in parts:
        if p.role in NOT_PRINTED or not p.soundness()["watertight"]:
            continue
        where = {"part": p.name}
        voids = p.measured("print closed voids", None, lambda: closed_voids(p.mesh))
        if voids:
            out.append(Check("print.void", "error", False, f"{p.name}: holds {voids} closed void(s) that "
                             f"cannot drain: give each a drain hole", float(voids), 0.0, where,
                             fix=f"hwgen drains every cavity it makes: {REBUILD}"))
        if technology != "SLA":
            continue
        found = p.measured("print cups", (LAYER_MM, CUP_MIN_AREA_MM2), lambda: cups(p.mesh))
        if found:
            z, a, c = max(found, key=lambda f: f[1])
            msg = (f"{p.name}: {len(found)} cavit{'y' if len(found) == 1 else 'ies'} closed below in its print "
                   f"orientation, the largest {a:.1f} mm² at Z = {z:.1f} mm (file X, Y = {c[0]:.1f}, {c[1]:.1f}): "
                   f"it holds resin against the vat's film; vent its floor or turn the part")
            out.append(Check("print.cup", "error", False, msg, a, CUP_MIN_AREA_MM2, where,
                             fix=f"hwgen turns and vents its parts for resin: {REBUILD}"))
        else:
            out.append(Check("print.cup", "error", True, f"{p.name}: no cavity closed below in its print orientation "
                             f"(sliced every {LAYER_MM:g} mm; holes under {CUP_MIN_AREA_MM2:g} mm² ignored)",
                             0.0, CUP_MIN_AREA_MM2, where))
    return out
