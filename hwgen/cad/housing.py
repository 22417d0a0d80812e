"""The tensioner's housing: the layout's members (:class:`hwgen.model.tensioner_layout.Member`:
boxes, cylinders, hexagonal bosses, windowed prisms) fused, and its cuts taken out in one boolean."""
from __future__ import annotations

import cadquery as cq
import numpy as np

from ..model.gearing import GearDesignError
from ..model.tensioner_layout import TensionerLayout
from . import DISK_ROTATION, location, placement
from .primitives import box, cylinder, hex_prism, one, prism


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
    """The housing in robot coordinates, from the layout's members (fused) and cuts (one cut)."""
    solids = [member_solid(m) for m in lay.members]
    body = solids[0].fuse(*solids[1:]).clean()
    body = one(body.cut(*(member_solid(m) for m in lay.cuts)), GearDesignError)
    return body.moved(location(lay.turn))



def housing_placement(lay: TensionerLayout) -> np.ndarray:
    return placement(DISK_ROTATION, [0.0, lay.y_face, 0.0])

