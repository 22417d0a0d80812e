"""The tensioner's worm gear where the design's own file leaves it to hwgen (issue 43, item 4).

A design that builds on a base (``base: prototype.yaml``) inherits the base's gear: module, worm
pitch diameter, worm length and starts. Those were chosen for the base's process; a user who
switches the process (FDM, ``process.min_wall: 0.9``) and writes nothing about the gear should
not be refused because the base's 1.25 mm module leaves a 0.894 mm tooth tip. The gear is a part
hwgen derives, so it follows the process: of the gear's keys the design's own file did not
write, :func:`follow_process` finds the least change that leaves the pair buildable (every rule
of :meth:`hwgen.model.gearing.WormPair.problems`, the walls round the worm's bores), searching
the module up a quarter-millimetre grid first (the wheel's tooth tip grows with it), then the
worm's pitch diameter in whole millimetres (self-locking: the lead angle atan(z1 m / d1) falls
as d1 grows), with no more starts than the base's, and the shortest worm in whole millimetres
that covers the wheel's reach. A gear that already passes is kept as it is (the prototype's
own). Where no gear of the schema's range passes, :func:`follow_process` keeps the stated gear and
says which process wall it prints with: the gear is built and its checks (``gear.tooth_tip``,
``gear.thread_tip``) fail, naming that wall. The same search is those checks' tried fix
(:func:`least_change`, from the gear as built).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .gearing import worm_pair
from .tensioner_layout.sizes import DRIVE_HEX

# the keys of the tensioner section this module may derive (the others, teeth, face, pressure
# angle, friction, are the lab's statements about the parts it buys or prints and are kept)
GEAR_KEYS = ("module", "worm_pitch_diameter", "worm_length", "worm_starts")
MODULE_STEP = 0.25          # mm: the grid the module is searched on (ISO 54's series in this range round to it)
MODULE_MAX = 3.0            # mm: the schema's bound on tensioner.module
DIAMETER_STEP = 1.0         # mm: the worm's pitch diameter in whole millimetres (a drawing's value)
DIAMETER_MAX = 40.0         # mm: the schema's bound on tensioner.worm_pitch_diameter
LENGTH_STEP = 1.0           # mm: the worm's threaded length in whole millimetres
LENGTH_MAX = 60.0           # mm: the schema's bound on tensioner.worm_length


@dataclass(frozen=True)
class GearChoice:
    """What :func:`follow_process` decided: ``values`` the derived keys (empty when the stated gear
    passes), ``note`` a sentence saying why (also when no gear passes and the stated one is kept)."""

    values: dict
    note: str = ""


def bore_problem(pair, pin_bore: float, min_wall: float) -> tuple[str, str] | None:
    """Why the worm's core is thinner than the process's wall round one of its bores (the drive
    shaft's hex end, pressed in from its near face; the dowel's, ``pin_bore`` mm, at its far end),
    or None. The check ``gear.bore_wall`` measures that wall in the worm's file."""
    hex_wall, pin_wall = pair.bore_wall(DRIVE_HEX), pair.bore_wall(round_bore=pin_bore)
    wall = min(hex_wall, pin_wall)
    if wall >= min_wall:
        return None
    what = (f"the drive shaft's {DRIVE_HEX:g} mm hex end" if hex_wall <= pin_wall else
            f"the Ø{pin_bore:g} mm bore of the dowel it turns on")
    return ("worm_bore", f"{what} leaves {wall:.2f} mm of the worm's core (root Ø{2 * pair.rf1:.2f} mm), "
                         f"under the process's {min_wall:g} mm wall")


def pin_bore(ts) -> float:
    """The worm's bore for the dowel it turns on, mm (the tensioner's shaft and its running fit)."""
    return ts.shaft_diameter + ts.running_fit


def _problems(ts, values: dict, min_wall: float) -> list[tuple[str, str]]:
    t = _Tensioner(ts, values)
    pair = worm_pair(t, min_wall)
    bore = bore_problem(pair, pin_bore(ts), min_wall)
    return list(_pair_problems(pair, ts.friction_coefficient, min_wall)) + ([bore] if bore else [])


@functools.lru_cache(maxsize=512)
def _pair_problems(pair, mu: float, min_wall: float) -> tuple[tuple[str, str], ...]:
    return tuple(pair.problems(mu, min_wall))


class _Tensioner:
    """A tensioner section with some of its gear keys replaced (what :func:`worm_pair` reads)."""

    def __init__(self, ts, values: dict):
        self._ts, self._values = ts, values

    def __getattr__(self, name):
        return self._values[name] if name in self._values else getattr(self._ts, name)


def _thread_tip(ts, module: float) -> float:
    """The worm thread's tip thickness, mm: a ZA thread's p/2 − 2 m tan α, whatever the worm's diameter."""
    return math.pi * module / 2 - 2 * module * math.tan(math.radians(ts.pressure_angle_deg))


def _grid(start: float, step: float, stop: float) -> np.ndarray:
    """``start``, then the grid's steps above it up to ``stop``."""
    above = np.arange(math.floor(start / step + 1e-9) + 1, math.floor(stop / step + 1e-9) + 1) * step
    return np.concatenate([[start], above])


def _length(ts, values: dict, min_wall: float, free: bool) -> float | None:
    """The worm's length with the rest of the gear at ``values``: the stated one if it covers the
    wheel's reach, else (when free) the shortest whole millimetre that does."""
    stated = values.get("worm_length", ts.worm_length)
    if not any(f == "worm_length" for f, _ in _problems(ts, {**values, "worm_length": stated}, min_wall)):
        return stated
    if not free:
        return None
    for length in _grid(stated, LENGTH_STEP, LENGTH_MAX)[1:]:
        if not any(f == "worm_length" for f, _ in _problems(ts, {**values, "worm_length": float(length)}, min_wall)):
            return float(length)
    return None


def follow_process(ts, min_wall: float, free: set[str] | frozenset[str]) -> GearChoice:
    """The gear for tensioner section ``ts`` under the process's ``min_wall``, changing only the
    keys of :data:`GEAR_KEYS` in ``free`` (those the design's own file did not write)."""
    stated = {k: getattr(ts, k) for k in GEAR_KEYS}
    before = _problems(ts, {}, min_wall)
    if not before or not free:
        return GearChoice({})
    modules = _grid(ts.module, MODULE_STEP, MODULE_MAX) if "module" in free else [ts.module]
    diameters = (_grid(ts.worm_pitch_diameter, DIAMETER_STEP, DIAMETER_MAX) if "worm_pitch_diameter" in free
                 else [ts.worm_pitch_diameter])
    starts = range(ts.worm_starts, 0, -1) if "worm_starts" in free else [ts.worm_starts]
    for m in modules:
        if _thread_tip(ts, float(m)) < min_wall:       # the same for every worm diameter: a finer module is no use
            continue
        for d1 in diameters:
            for z1 in starts:
                values = {"module": float(m), "worm_pitch_diameter": float(d1), "worm_starts": int(z1)}
                if any(f != "worm_length" for f, _ in _problems(ts, values, min_wall)):
                    continue
                length = _length(ts, values, min_wall, "worm_length" in free)
                if length is None:
                    continue
                values["worm_length"] = length
                changed = {k: v for k, v in values.items() if v != stated[k]}
                return GearChoice(changed, _note(stated, changed, before, min_wall))
    if "module" not in free:            # the module the file states: the rules' faults are its own
        return GearChoice({})
    return GearChoice({}, note=_none_prints(ts, stated, before, min_wall))


class _Section:
    """The tensioner section's gear keys as a built pair has them (what :func:`follow_process` reads)."""

    def __init__(self, pair, lay):
        self.module, self.worm_starts, self.wheel_teeth = pair.module, pair.starts, pair.teeth
        self.worm_pitch_diameter, self.pressure_angle_deg = pair.worm_pitch_diameter, pair.pressure_angle_deg
        self.face_width, self.worm_length, self.center_offset = pair.face_width, pair.worm_length, pair.center_offset
        self.friction_coefficient = lay.friction_coefficient
        self.shaft_diameter, self.running_fit = lay.shaft_diameter, lay.running_fit


def least_change(pair, lay, min_wall: float) -> GearChoice:
    """The least change of the built ``pair``'s module, worm diameter, length and starts that passes
    every rule of the pair at ``min_wall`` (the search of :func:`follow_process`, every gear key free):
    the tried fix of a tip or a bore's wall thinner than the wall. Empty ``values`` when none within the schema's bounds does."""
    return follow_process(_Section(pair, lay), min_wall, frozenset(GEAR_KEYS))


def thickest_wall(pair, lay, below: float) -> float | None:
    """The thickest process wall (to 0.01 mm, under ``below``) the built ``pair``'s tips and bore
    walls are not thinner than; None when none is."""
    return _thickest_wall(_Section(pair, lay), {}, below)


def _note(stated: dict, changed: dict, before: list, min_wall: float) -> str:
    said = ", ".join(f"tensioner.{k} {stated[k]:g} → {v:g}" for k, v in changed.items())
    why = "; ".join(m for _, m in before)
    return (f"the tensioner's gear follows the process (process.min_wall {min_wall:g} mm): {said}, since the "
            f"gear this file does not state would not print ({why}); write these keys to choose the gear yourself")


WALL_RULES = ("module", "pressure_angle_deg", "worm_bore")     # the fields of the gear's rules on the process's wall


def _thickest_wall(ts, values: dict, below: float) -> float | None:
    """The thickest process wall (to 0.01 mm, under ``below``) with which the gear ``values`` has no
    tooth or thread tip thinner than the wall; None when none has (bisection: thicker walls fail more)."""
    def prints(w: float) -> bool:
        return not any(f in WALL_RULES for f, _ in _problems(ts, values, w))
    if not prints(0.01):
        return None
    lo, hi = 1, math.floor(below * 100)          # in hundredths of a millimetre: lo prints, hi does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if prints(mid / 100) else (lo, mid)
    return lo / 100


def _none_prints(ts, stated: dict, before: list, min_wall: float) -> str:
    """No gear within the schema passes at ``min_wall``: the stated gear is kept (built, its checks
    fail); the thickest wall the coarsest gear prints with, and the stated gear's; "" when the stated
    gear fails at any wall (a fault of its own keys, reported on them)."""
    own = _thickest_wall(ts, {}, min_wall)
    if own is None or not any(f in WALL_RULES for f, _ in before):
        return ""
    coarse = {"module": MODULE_MAX, "worm_pitch_diameter": DIAMETER_MAX, "worm_starts": 1}
    most = _thickest_wall(ts, coarse, min_wall)
    why = "; ".join(m for _, m in before)
    gear = (f"module {stated['module']:g} mm, worm Ø{stated['worm_pitch_diameter']:g} × {stated['worm_length']:g} mm, "
            f"{stated['worm_starts']} start(s)")
    largest = (f"process.min_wall {most:g} mm or less, for which hwgen derives a gear (up to a "
               f"{MODULE_MAX:g} mm module), or " if most is not None and most > own else "")
    return (f"process.min_wall {min_wall:g} mm: no worm gear within tensioner.module ≤ {MODULE_MAX:g} mm and "
            f"worm Ø ≤ {DIAMETER_MAX:g} mm prints with this wall ({why}), so the stated gear ({gear}) is built as it "
            f"is and its wall checks fail; {largest}process.min_wall {own:g} mm, with which the stated gear "
            f"prints, or state a gear in tensioner")
