"""CAD: frozen specs from :mod:`hwgen.model` in, CadQuery solids and their files out.

Every builder returns a :class:`Part`: the solid in its print orientation (largest flat
face on the XY plane, resting on Z = 0) and the placement that maps it to robot coordinates.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Part:
    name: str
    role: str                       # "disk", "backbone", ...
    solid: object                   # cadquery.Solid in print orientation
    placement: np.ndarray           # 4x4: part file coordinates -> robot coordinates, mm
    color: tuple[float, float, float, float]
    station: int | None = None
    meta: dict = field(default_factory=dict)   # extra manifest fields (channel, ...)
    material: str | None = None     # None: printed in the process's material; else what it is cut from
    density_g_cm3: float | None = None   # of that material (None: the process's)


def placement(rotation, translation) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return m


# Disk files lie in XY with their base-side face on Z = 0: file (X, Y, Z) = robot (x, -z, y - y0).
DISK_ROTATION = np.array([[1.0, 0.0, 0.0],
                          [0.0, 0.0, 1.0],
                          [0.0, -1.0, 0.0]])


def disk_placement(y_mid: float, thickness: float) -> np.ndarray:
    return placement(DISK_ROTATION, [0.0, y_mid - thickness / 2, 0.0])


def location(matrix: np.ndarray):
    """cq.Location from a 4x4 rigid transform (CadQuery is imported only when a solid is moved)."""
    import cadquery as cq
    from OCP.gp import gp_Trsf
    t = gp_Trsf()
    t.SetValues(*(float(matrix[r, c]) for r in range(3) for c in range(4)))
    return cq.Location(t)


MASS_EPS = 1e-6   # relative precision of the volume integration (CadQuery's Volume() is 0.2-0.3 % off
#                   on the throated wheel's B-spline flanks; its STL agrees with this to 0.04 %)


def mass_properties(solid) -> tuple[float, tuple[float, float, float]]:
    """Volume (mm³) and centroid (file mm) of a solid, integrated to MASS_EPS: once per solid (a
    throated wheel's is costly; a part is found sound by its volume and measured for the
    manifest by both), or as :func:`known_mass` gave them."""
    found = _MASS.get(solid)
    if found is None:
        from OCP.BRepGProp import BRepGProp
        from OCP.GProp import GProp_GProps
        props = GProp_GProps()
        BRepGProp.VolumeProperties_s(solid.wrapped, props, MASS_EPS)
        c = props.CentreOfMass()
        found = _MASS[solid] = (props.Mass(), (c.X(), c.Y(), c.Z()))
    return found


def known_mass(solid, found) -> None:
    """``solid``'s :func:`mass_properties` are ``found`` (what they were for the solid it was read
    back from: hwgen.cad.memo keeps them with it)."""
    volume, (x, y, z) = found
    _MASS[solid] = (float(volume), (float(x), float(y), float(z)))


_MASS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()     # each solid's mass_properties, once found
