"""CAD: frozen specs from :mod:`hwgen.model` in, CadQuery solids and their files out.

Every builder returns a :class:`Part`: the solid in its print orientation (largest flat
face on the XY plane, resting on Z = 0) and the placement that maps it to robot coordinates.
"""
from __future__ import annotations

import importlib.abc
import importlib.util
import sys
import types
import weakref
from dataclasses import dataclass, field

import numpy as np


class _VtkWhileOcpStarts(importlib.abc.MetaPathFinder):
    """OCP's packages, as CadQuery imports them (OCP itself, its IVtkOCC and IVtkVTK bindings),
    each import the ``vtk`` module, which imports every one of VTK's ~160 extension modules: 0.3 s
    of CPU in each process that imports CadQuery, on the build's critical path (the workers wait
    for their server's imports). CadQuery itself needs 31 of them, which it imports by name. While
    CadQuery (or OCP, imported first) starts, ``vtk`` is a stand-in that loads the whole of VTK only
    if an attribute of it is read; once it has started, the stand-in leaves ``sys.modules``
    (unless it was used), so that a later ``import vtk`` is the real one. Nothing changes where
    VTK was imported already, or where CadQuery or OCP was imported before hwgen.cad."""

    STARTS_VTK = ("cadquery", "OCP")

    def __init__(self):
        self.looking = False

    def find_spec(self, name, path=None, target=None):
        if name not in self.STARTS_VTK or self.looking:
            return None
        self.looking = True                 # the search below asks the finders again, this one too
        try:
            spec = importlib.util.find_spec(name)
        finally:
            self.looking = False
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        spec.loader = _StartingWithoutVtk(spec.loader)
        return spec


class _StartingWithoutVtk(importlib.abc.Loader):
    def __init__(self, loader):
        self.loader = loader

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module) -> None:
        stand_in = None
        if "vtk" not in sys.modules:
            stand_in = sys.modules["vtk"] = types.ModuleType("vtk", "VTK, loaded if used (hwgen.cad)")

            def __getattr__(name: str):
                if name.startswith("__"):       # introspection (a module's __file__, __path__): not VTK's
                    raise AttributeError(name)
                import vtkmodules.all as full
                sys.modules["vtk"] = full
                return getattr(full, name)
            stand_in.__getattr__ = __getattr__
        try:
            self.loader.exec_module(module)
        finally:
            if stand_in is not None and sys.modules.get("vtk") is stand_in:
                del sys.modules["vtk"]


if not any(isinstance(f, _VtkWhileOcpStarts) for f in sys.meta_path) and "OCP" not in sys.modules \
        and "cadquery" not in sys.modules:
    sys.meta_path.insert(0, _VtkWhileOcpStarts())       # before any module of this package imports CadQuery


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
    throated wheel's is half a second; a part is found sound by its volume and measured for the
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
