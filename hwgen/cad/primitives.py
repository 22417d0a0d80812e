"""The CAD stage's primitives: boxes, cylinders, hexagonal and outline prisms between points, one
solid out of a boolean's result, and a line of purchased hardware as the bill of materials reads it.

Every builder makes its solids from these, so a box or a bore is made the same way in every part.
"""
from __future__ import annotations

import math

import cadquery as cq
import numpy as np

TOOL = 1.0               # cutting tools overrun faces by this much, mm


def wire(points) -> cq.Wire:
    """A closed polygon through (x, y, z) points."""
    return cq.Wire.makePolygon([cq.Vector(*p) for p in points], close=True)


def box(x0, x1, y0, y1, z0, z1) -> cq.Solid:
    """The box between two corners, in either order along each axis."""
    xs, ys, zs = sorted((x0, x1)), sorted((y0, y1)), sorted((z0, z1))
    return cq.Solid.makeBox(xs[1] - xs[0], ys[1] - ys[0], zs[1] - zs[0], cq.Vector(xs[0], ys[0], zs[0]))


def cylinder(r, p0, p1) -> cq.Solid:
    """A cylinder of radius r from point p0 to point p1."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    return cq.Solid.makeCylinder(r, float(np.linalg.norm(d)), cq.Vector(*p0), cq.Vector(*d))


def hex_prism(across_flats: float, p0, p1, flat_normal) -> cq.Solid:
    """Hexagonal prism from p0 to p1, one pair of flats facing ``flat_normal`` (made square to the axis)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    ax = (p1 - p0) / np.linalg.norm(p1 - p0)
    n = np.asarray(flat_normal, float)
    n = n - ax * (n @ ax)
    if np.linalg.norm(n) < 1e-9:
        n = np.cross(ax, [1.0, 0.0, 0.0] if abs(ax[0]) < 0.9 else [0.0, 1.0, 0.0])
    n /= np.linalg.norm(n)
    m = np.cross(ax, n)
    r = across_flats / math.sqrt(3)                        # corner radius
    corners = [p0 + r * (math.cos(a) * m + math.sin(a) * n) for a in np.radians(np.arange(0, 360, 60))]
    face = cq.Face.makeFromWires(wire(corners))
    return cq.Solid.extrudeLinear(face, cq.Vector(*(p1 - p0)))


def prism(axis: int, lo: float, hi: float, outline) -> cq.Solid:
    """An outline of (y, v) points (v = z for an x normal, x for a z normal) extruded from lo to hi."""
    pts = np.asarray(outline, float).reshape(-1, 2)
    if axis == 0:
        corners = [(lo, y, v) for y, v in pts]
        step = cq.Vector(hi - lo, 0, 0)
    else:
        corners = [(v, y, lo) for y, v in pts]
        step = cq.Vector(0, 0, hi - lo)
    return cq.Solid.extrudeLinear(cq.Face.makeFromWires(wire(corners)), step)


def one(shape, error: type[Exception] = ValueError) -> cq.Solid:
    """The single solid a boolean left; ``error`` (a ValueError) when it left none or several."""
    solids = shape.Solids() if not isinstance(shape, cq.Solid) else [shape]
    if len(solids) != 1:
        raise error(f"expected one solid, got {len(solids)}")
    return solids[0]


def hardware(item: str, size: str, qty: int, material: str = "steel", **extra) -> dict:
    """One line of purchased hardware, as the bill of materials sums it (by item and size)."""
    return {"item": item, "size": size, "qty": qty, "material": material, **extra}
