"""The tensioner's housing: the layout's members (:class:`hwgen.model.tensioner_layout.Member`:
boxes, cylinders, hexagonal bosses, windowed prisms) fused, and its cuts taken out in one boolean."""
from __future__ import annotations

import cadquery as cq
import numpy as np
from OCP.BRepMesh import BRepMesh_IncrementalMesh

from ..model.gearing import GearDesignError
from ..model.tensioner_layout import TensionerLayout
from . import DISK_ROTATION, location, placement
from .export import STL_ANGULAR_RAD, STL_TOLERANCE_MM
from .primitives import box, cylinder, hex_prism, one, prism

MERGE_MM = 1e-6         # mesh vertices this close are one (the faces' meshes share their edges' points)


def member_solid(m) -> cq.Solid:
    """A :class:`hwgen.model.tensioner_layout.Member` as a solid."""
    d = m.dims
    if m.kind == "box":
        return box(*d)
    if m.kind == "cyl":
        return cylinder(d[0], d[1:4], d[4:7])
    if m.kind == "prism":
        return prism(int(d[0]), d[1], d[2], d[3:])
    return hex_prism(d[0], d[1:4], d[4:7], d[7:10])


def housing_solid(lay: TensionerLayout) -> cq.Solid:
    """The housing in robot coordinates, from the layout's members (fused, their coplanar faces
    merged) and cuts (one cut). Merging the faces (OCCT's unify-same-domain) can leave the floor,
    where the base bars, cross bar and spine feet meet the strip's slot and the tendon passages, a
    face the mesher does not fill (an STL with a hole in its floor: part.mesh): that housing is cut
    from the members fused as they are instead."""
    solids = [member_solid(m) for m in lay.members]
    cuts = [member_solid(m) for m in lay.cuts]
    fused = solids[0].fuse(*solids[1:])
    body = one(fused.clean().cut(*cuts), GearDesignError)
    if not closed_when_meshed(body):
        body = one(fused.cut(*cuts), GearDesignError)
    return body.moved(location(lay.turn))


def closed_when_meshed(body: cq.Shape) -> bool:
    """Whether ``body`` meshed as its STL is (:func:`hwgen.cad.export.write_stl`'s deflections) is
    closed: every triangle edge shared by two triangles. Meshed on a copy, so the body's own
    triangulation (and the file written from it) is what the export makes of it."""
    probe = body.copy()
    BRepMesh_IncrementalMesh(probe.wrapped, STL_TOLERANCE_MM, False, STL_ANGULAR_RAD, True)
    vertices, triangles = probe.tessellate(STL_TOLERANCE_MM, STL_ANGULAR_RAD)
    if not triangles:
        return False
    points = np.round(np.array([v.toTuple() for v in vertices]) / MERGE_MM).astype(np.int64)
    _, index = np.unique(points, axis=0, return_inverse=True)
    tri = index.reshape(-1)[np.asarray(triangles, dtype=np.int64)]
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edges = edges[edges[:, 0] != edges[:, 1]]                  # a sliver's collapsed edge
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))



def housing_placement(lay: TensionerLayout) -> np.ndarray:
    return placement(DISK_ROTATION, [0.0, lay.y_face, 0.0])

