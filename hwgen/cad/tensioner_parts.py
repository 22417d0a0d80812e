"""The tensioner's parts: worm, drive shaft, wheel with spool, tendon clamp and housing, placed.

The numbers come from :mod:`hwgen.model.gearing` (tooth and thread forms) and
:mod:`hwgen.model.tensioner_layout` (where everything sits); this module only turns them into
CadQuery solids (:mod:`.worm`, :mod:`.wheel`, :mod:`.housing`) and places them. Identical
geometry is built once: one worm, one drive shaft and one clamp for every channel, one wheel
per distinct spool layout.

Print orientations (each part's file is in it; see the README): worm and drive shaft stand on
an end face, axis along file Z, every bore open at both ends; the wheel stands on its gear's
face; the clamp plate lies flat; the housing stands on its base bars (the face that bolts to
the tip disk), file (X, Y, Z) = robot (x, -z, y - y_face), its windows' roofs at 45°.

Assembly, as the geometry allows it: nuts into their traps (resin) or inserts melted in
(thermoplastic); each worm dropped in between its far post and the spine, its dowel pressed
through the post into the worm's far bore, the drive shaft pushed from outside through the
spine into the worm's hex bore; each wheel between its shelf and bar, its two dowels pressed
in from outside; housing onto the tip disk (M3 screws from the disk's inner face) with the
strip's tip in its slot, set screws down on the strip; tendons wound, led through the anchor
hole and pinched under the clamp plate by its M2 screw.
"""
from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from ..model.gearing import GearDesignError
from ..model.tensioner_layout import TensionerLayout, Unit, tip_joint
from ..model.tensioner_layout.sizes import CLAMP_PLATE, DRIVE_HEX, INSERT, POST, SET_SCREW
from . import Part, location, placement
from .housing import housing_placement, housing_solid
from .memo import kept
from .primitives import hardware
from .wheel import CLAMP_ANGLE, clamp_joint, clamp_site, clamp_solid, gear_solid, wheel_solid, wheel_spec
from .worm import drive_solid, worm_solid

WORM_COLOR = (0.75, 0.76, 0.78, 1.0)
WHEEL_COLOR = (0.30, 0.55, 0.85, 1.0)
CLAMP_COLOR = (0.90, 0.45, 0.20, 1.0)
HOUSING_COLOR = (0.55, 0.58, 0.52, 1.0)
DRIVE_COLOR = (0.80, 0.40, 0.60, 1.0)
STEEL, BRASS = "steel", "brass"


def build_tensioner(lay: TensionerLayout, *, tendon_diameter: float, tip_screws: int,
                    tip_thickness: float) -> Iterator[Part]:
    """The tensioner's parts as ``lay`` places them (its pair carries the process's wall, the
    wheel's thinnest tip), the tendon's diameter, and the tip disk's screw count and thickness (the
    screws' grip). Channel by channel (:func:`channel_parts`, sharing their solids), then the
    housing (:func:`housing_part`)."""
    shared: dict = {}
    for u in lay.units:
        yield from channel_parts(lay, u, tendon_diameter=tendon_diameter, shared=shared)
    yield housing_part(lay, tip_screws=tip_screws, tip_thickness=tip_thickness)


def channel_parts(lay: TensionerLayout, u: Unit, *, tendon_diameter: float,
                  shared: dict | None = None) -> Iterator[Part]:
    """One channel's worm, drive shaft, wheel and clamp plate(s), as ``lay`` places them. Every
    solid is kept between builds and between the processes of one (:func:`hwgen.cad.memo.kept`:
    the thread's sweep and the gear's boolean are the costly ones), so channels made apart share
    them; ``shared`` holds the solids already made for other channels here (one worm, drive and
    clamp for all, one wheel per distinct spool layout)."""
    shared = {} if shared is None else shared
    pair = lay.pair
    if "worm" not in shared:
        problems = pair.refusals(lay.friction_coefficient)
        if problems:
            raise GearDesignError("; ".join(f"tensioner.{f}: {m}" for f, m in problems))
        # the drive's hex goes into the worm's line to line: the resin's own scatter (±0.05 mm) makes
        # it snug; modelled without overlap so the parts' interference check stays meaningful
        worm_inputs = (pair, lay.worm_near_end, DRIVE_HEX, lay.shaft_diameter + lay.running_fit,
                       lay.worm_pin - POST + 0.5)
        shared["worm"] = kept("worm", worm_inputs, lambda: worm_solid(*worm_inputs))   # the thread's sweep: costly
        drive_inputs = (float(lay.spine[1] - lay.spine[0]), float(lay.hex_key))    # through the spine, its key
        shared["drive"] = kept("drive shaft", drive_inputs, lambda: drive_solid(*drive_inputs))
        shared["gear"] = kept("throated wheel gear", pair, lambda: gear_solid(pair))   # the costliest boolean
        shared["clamp"] = kept("clamp plate", (), clamp_solid)
    # channels whose stacks are alike, measured from the wheel's own end, have one wheel; it is kept
    # under that, not where the layout puts it, so a channel made in another process has the very
    # solid of the first, and an edit that moves the tensioner but not this stack finds it made
    spec = wheel_spec(lay, u, lay.shaft_diameter + lay.running_fit)
    key = ("wheel", spec.alike())
    if key not in shared:
        shared[key] = kept("throated wheel", key[1], lambda: wheel_solid(spec, shared["gear"]))
    meta = {"channel": u.channel, "tendons": list(u.tendons)}
    yield Part(f"tensioner_worm_{u.channel}", "tensioner_worm", shared["worm"], lay.worm_placement(u), WORM_COLOR,
               meta={**meta, "mesh_with": f"tensioner_wheel_{u.channel}", "hex_key_mm": lay.hex_key,
                     "hardware": [_dowel(lay.shaft_diameter, lay.worm_pin, "pressed into the far post")],
                     **pair.summary()})
    yield Part(f"tensioner_drive_{u.channel}", "tensioner_drive", shared["drive"], lay.drive_placement(u),
               DRIVE_COLOR, meta={"channel": u.channel, "hex_key_mm": lay.hex_key,
                                  "drives": f"tensioner_worm_{u.channel}"})
    yield _wheel_part(lay, u, shared[key], meta, tendon_diameter)
    yield from _clamp_parts(lay, u, shared["clamp"], meta)


def housing_part(lay: TensionerLayout, *, tip_screws: int, tip_thickness: float) -> Part:
    """The housing, standing on its base bars, with the hardware that holds it and the strip's tip."""
    hp = housing_placement(lay)
    inv = np.linalg.inv(hp)
    n_tip = tip_screws
    tip = tip_joint(lay.fastening, tip_thickness, lay.base_t)
    set_screw = {"nut": _hw("hex nut ISO 4032", "M3", 2, STEEL, "for the strip's set screws, in a side slot"),
                 "insert": _hw("heat-set insert", f"M3 × {INSERT['M3'][1]:g}", 2, BRASS,
                               "for the strip's set screws, melted in")}
    return Part("tensioner_housing", "tensioner_housing", housing_solid(lay).moved(location(inv)), hp, HOUSING_COLOR,
                meta={"channel": "all", "channels": [u.channel for u in lay.units], "layout_search": lay.search,
                      "hardware": [
                          {**_hw("socket head cap screw ISO 4762", tip.screw, n_tip, STEEL,
                                 "through the tip disk into the housing"), "tip_mount": True},
                          tip.held_by(n_tip, "takes the tip-disk screws, in a side slot"),
                          _hw("set screw ISO 4026", f"M3 × {SET_SCREW:g}", 2, STEEL, "clamps the strip's tip"),
                          set_screw[lay.fastening]]})


def _wheel_part(lay: TensionerLayout, u: Unit, solid, meta: dict, tendon_d: float) -> Part:
    # the run meets its own drum tangentially: the last stretch, where it is closer to the
    # drum than 1.5 tendon diameters, is where it is meant to touch and is not checked
    trim = math.sqrt((lay.winding_radius + 1.5 * tendon_d) ** 2 - lay.winding_radius ** 2)
    runs = [{"tendon": r.tendon, "start": list(r.start), "end": list(r.end), "sense": r.sense,
             "exit_angle_deg": r.exit_angle_deg, "own_part_trim_mm": trim}
            for r in lay.runs if r.channel == u.channel]
    return Part(f"tensioner_wheel_{u.channel}", "tensioner_wheel", solid, lay.wheel_placement(u), WHEEL_COLOR,
                meta={**meta, "tendon_runs": runs, "winding_radius_mm": lay.winding_radius,
                      "winding": lay.windings[u.channel],
                      "flange_radius_mm": lay.flange_radius, "spool_diameter_mm": 2 * lay.spool_radius,
                      "winding_zones_z_mm": [list(z) for z in u.zones],
                      "hardware": [_dowel(lay.shaft_diameter, n, "pressed into the housing") for n in u.pins]})


def _clamp_parts(lay: TensionerLayout, u: Unit, clamp, meta: dict) -> Iterator[Part]:
    rc = clamp_site(lay)
    ang = math.radians(CLAMP_ANGLE)
    for k, (zc, s) in enumerate(u.clamps):
        zf = zc - u.z_part[0]
        t = placement(np.eye(3), [rc * math.cos(ang), rc * math.sin(ang), zf if s > 0 else zf - CLAMP_PLATE[2]])
        j = clamp_joint(lay, u, zc)
        name = f"tensioner_clamp_{u.channel}" + (f"_{k + 1}" if len(u.clamps) > 1 else "")
        yield Part(name, "tensioner_clamp", clamp, lay.stack_placement(u) @ t, CLAMP_COLOR,
                   meta={**meta, "hardware": [_hw("button head screw ISO 7380", j.screw, 1, STEEL),
                                              j.held_by(1, "in the wheel")]})


def _hw(item: str, size: str, qty: int, material: str, notes: str = "") -> dict:
    """A line of hardware that always says what it is for (``notes``, empty when nothing)."""
    return hardware(item, size, qty, material, notes=notes)


def _dowel(diameter: float, length: float, notes: str) -> dict:
    return _hw("dowel pin ISO 2338", f"Ø{diameter:g} × {length:g}", 1, "hardened steel", notes)

