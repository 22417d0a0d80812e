"""The robot's bought metal: the dowel pins, screws, nuts, set screws and inserts it carries beyond
its base (all of them in the tensioner and the tip disk), each piece's mass and where it sits, for
the weights the statics, the own-weight sag and the sim carry (numpy only).

Which pieces: the ones the bill of materials lists for the tip (the tensioner's parts and the
housing's hardware), sized as the layout sizes them: per channel a dowel through its far post
into its worm, two through the shelf and the bar into its wheel, and per clamp plate an M2 button
head screw with its nut (or insert); the housing's M3 screws through the tip disk's bolt pattern
with their nuts (or inserts), and two M3 set screws with their nuts (or inserts) in the strip's
clamp. Nothing on the base: the mount and everything on it are the clamp's.

Where: a wheel's dowels on its axis, each pressed flush with the outer face of its shelf or bar;
a worm's dowel on the worm's axis from the post's inner face; a clamp's screw and nut on its
wheel's axis at the clamp's face (their 12 mm radius on the wheel ignored: 0.3 g); the tip screws
at the tip disk's holes, head on the disk's inner face, and their nuts in the base bars' traps;
the set screws and their nuts at the centre of the strip's clamp block.

Masses from the sizes in hwgen/data/fasteners.csv and the densities in hwgen/data/metals.csv: a
dowel is its cylinder; a thread is taken at its pitch diameter (ISO 724: d₂ = d − 0.6495 P, where
a 60° thread's ridges and grooves are equal, so the cylinder there holds the thread's metal); a
socket head a cylinder of its head diameter and height, a button head a cylinder of its head
diameter and height (the dome's rounding ignored: it overstates an M2 head by about a tenth of a
gram in six); a nut its hexagon less the threaded bore; an insert its bore less the thread. The
sockets in the heads are not taken out (about 5 % of a screw). Lengths mm, masses g.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np

from . import hardware
from .tensioner_layout.sizes import INSERT, NUT, SET_SCREW, clamp_joint, clamp_on_cap, tip_joint

DOWEL, SHCS, NUT_ITEM = "dowel pin ISO 2338", "socket head cap screw ISO 4762", "hex nut ISO 4032"
SET, BUTTON, INSERT_ITEM = "set screw ISO 4026", "button head screw ISO 7380", "heat-set insert"


@dataclass(frozen=True)
class Piece:
    """One bought piece: as the bill of materials names it, its mass and where it sits (robot frame,
    straight robot), its axis, length and diameter (its inertia as a rod's)."""

    item: str
    size: str
    material: str
    mass_g: float
    centre_mm: tuple[float, float, float]
    axis: tuple[float, float, float]
    length_mm: float
    diameter_mm: float


@cache
def densities() -> dict[str, float]:
    """material -> g/cm³ (hwgen/data/metals.csv)."""
    text = resources.files("hwgen").joinpath("data/metals.csv").read_text(encoding="utf-8")
    return {r["material"]: float(r["density_g_cm3"]) for r in csv.DictReader(text.splitlines())}


def _pitch_area(thread: str) -> float:
    """The thread's cross-section taken at its pitch diameter, mm²."""
    d = float(thread.lstrip("M"))
    d2 = d - 0.649519 * hardware.size("thread", thread, "pitch")
    return math.pi * d2 ** 2 / 4


def volume(item: str, thread: str, length: float = 0.0, diameter: float = 0.0) -> float:
    """The metal's volume of one piece, mm³ (see the module's docstring)."""
    if item == DOWEL:
        return math.pi * diameter ** 2 / 4 * length
    if item == SHCS:
        head = math.pi * hardware.size("socket head cap screw", thread, "head_diameter") ** 2 / 4
        return head * hardware.size("socket head cap screw", thread, "head_height") + _pitch_area(thread) * length
    if item == BUTTON:
        head = math.pi * hardware.size("button head screw", thread, "head_diameter") ** 2 / 4
        return head * hardware.size("button head screw", thread, "head_height") + _pitch_area(thread) * length
    if item == SET:
        return _pitch_area(thread) * length
    if item == NUT_ITEM:
        af, height = hardware.nut(thread)
        return (math.sqrt(3) / 2 * af ** 2 - _pitch_area(thread)) * height
    if item == INSERT_ITEM:
        bore, height = hardware.insert(thread)
        return (math.pi * bore ** 2 / 4 - _pitch_area(thread)) * height
    raise ValueError(f"no mass rule for {item}")


def _piece(item: str, size: str, material: str, centre, axis, length: float, diameter: float,
           thread: str = "") -> Piece:
    mass = volume(item, thread, length, diameter) * densities()[material] * 1e-3
    return Piece(item, size, material, mass, tuple(float(v) for v in centre), tuple(float(v) for v in axis),
                 float(length), float(diameter))


def _held(kind: str, thread: str, centre, axis) -> Piece:
    """The nut (``kind`` "nut") or heat-set insert that holds a screw of ``thread``."""
    if kind == "nut":
        af, height = NUT[thread]
        return _piece(NUT_ITEM, thread, "steel", centre, axis, height, af, thread)
    bore, height = INSERT[thread]
    return _piece(INSERT_ITEM, f"{thread} × {height:g}", "brass", centre, axis, height, bore, thread)


def _unit_pieces(lay, u) -> list[Piece]:
    """One channel's dowels and clamp screws, layout frame."""
    d = lay.shaft_diameter
    cx, cy = u.center
    z = (0.0, 0.0, 1.0)
    out = [_piece(DOWEL, f"Ø{d:g} × {u.pins[0]:g}", "hardened steel", (cx, cy, u.lower_bar[0] + u.pins[0] / 2), z,
                  u.pins[0], d),
           _piece(DOWEL, f"Ø{d:g} × {u.pins[1]:g}", "hardened steel", (cx, cy, u.upper_shelf[1] - u.pins[1] / 2), z,
                  u.pins[1], d),
           _piece(DOWEL, f"Ø{d:g} × {lay.worm_pin:g}", "hardened steel",
                  (u.side * (lay.post[0] + lay.worm_pin / 2), u.worm_y, u.worm_z), (1.0, 0.0, 0.0), lay.worm_pin, d)]
    for zc, _ in u.clamps:
        j = clamp_joint(lay.fastening, clamp_on_cap(u.caps, zc), lay.pair.face_width)
        out.append(_piece(BUTTON, j.screw, "steel", (cx, cy, zc), z, j.screw_length, 2.0, j.thread))
        out.append(_held(j.kind, j.thread, (cx, cy, zc), z))
    return out


def _housing_pieces(lay, tip) -> list[Piece]:
    """The tip screws and the strip clamp's set screws with what holds them, layout frame."""
    j = tip_joint(lay.fastening, tip.thickness, lay.base_t)
    y_in = tip.y - tip.thickness / 2                      # the screws' heads rest on the disk's inner face
    k = hardware.size("socket head cap screw", "M3", "head_height")
    head = volume(SHCS, "M3")                              # no length: the head alone
    shank = _pitch_area("M3") * j.screw_length
    y_screw = (head * (y_in - k / 2) + shank * (y_in + j.screw_length / 2)) / (head + shank)
    y_nut = lay.y_face + (j.nut_from + j.depth) / 2
    along = (0.0, 1.0, 0.0)
    out = []
    for x, zh, _ in tip.mount_holes:
        out.append(_piece(SHCS, j.screw, "steel", (x, y_screw, zh), along, j.screw_length + k, 3.0, "M3"))
        out.append(_held(j.kind, "M3", (x, y_nut, zh), along))
    if lay.clamp_block is not None:
        x0, x1, y0, y1, z0, z1 = lay.clamp_block
        centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
        for _ in range(2):
            out.append(_piece(SET, f"M3 × {SET_SCREW:g}", "steel", centre, (0.0, 0.0, 1.0), SET_SCREW, 3.0, "M3"))
            out.append(_held(lay.fastening, "M3", centre, (0.0, 0.0, 1.0)))
    return out


def tip_pieces(plan) -> tuple[Piece, ...]:
    """Every bought piece beyond the base (see the module's docstring), robot frame; none for a
    design whose tensioner has no layout."""
    lay = plan.tensioner_layout
    if lay is None:
        return ()
    pieces = [p for u in lay.units for p in _unit_pieces(lay, u)] + _housing_pieces(lay, plan.disks[-1])
    turn = np.asarray(lay.turn, float)
    out = []
    for p in pieces:
        c = turn[:3, :3] @ p.centre_mm + turn[:3, 3]
        a = turn[:3, :3] @ p.axis
        out.append(Piece(p.item, p.size, p.material, p.mass_g, tuple(float(v) for v in c),
                         tuple(float(v) for v in a), p.length_mm, p.diameter_mm))
    return tuple(out)


def inertia(p: Piece) -> np.ndarray:
    """A piece's inertia about its centre, robot axes, g·mm²: a solid cylinder of its length and diameter."""
    a = np.asarray(p.axis, float)
    r2, ell2 = (p.diameter_mm / 2) ** 2, p.length_mm ** 2
    along, across = p.mass_g * r2 / 2, p.mass_g * (3 * r2 + ell2) / 12
    return across * np.eye(3) + (along - across) * np.outer(a, a)


def total(pieces) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass g, centre of mass mm, inertia about it g·mm²) of ``pieces`` together."""
    m = sum(p.mass_g for p in pieces)
    if m <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    c = sum(p.mass_g * np.asarray(p.centre_mm) for p in pieces) / m
    out = np.zeros((3, 3))
    for p in pieces:
        r = np.asarray(p.centre_mm) - c
        out += inertia(p) + p.mass_g * (r @ r * np.eye(3) - np.outer(r, r))
    return m, c, out


def bill(pieces) -> dict[tuple[str, str], int]:
    """(item, size) -> how many: the pieces as the bill of materials counts them."""
    out: dict = {}
    for p in pieces:
        out[(p.item, p.size)] = out.get((p.item, p.size), 0) + 1
    return out
