"""The worm gear's thinnest printed features, measured from its files against the process's wall:
the wheel's tooth tip across its face (``gear.tooth_tip``) and the worm's thread tip
(``gear.thread_tip``).

A gear whose tips are thinner than ``process.min_wall`` is still a gear: it is built, and these
checks fail naming the wall, the tip measured and the gear that prints, found by the search that
derives a gear where the design leaves it to hwgen (:func:`hwgen.model.gear_choice.least_change`)
and tried on the model of the generated tooth (:meth:`hwgen.model.gearing.WormPair.thinnest_tip`,
:attr:`~hwgen.model.gearing.WormPair.thread_tip`), scaled by what the built tip measures against
that model's figure for it.

How a tip is read: in a section of the part, the tooth's (thread's) width is cut by a thin ring
(band) at a few depths under its tip and extrapolated along a straight line to the tip; read at the
tip itself a ring would meet the tessellated tip's chords (0.01 mm under the true surface) in
pieces. The wheel is cut normal to its axis at the planes the model looks at (mid-face to where
the rim's chamfer begins, and where the throat meets the outside radius; both sides); the worm in
the plane through its axis, the threads clear of its ends by a pitch.
"""
from __future__ import annotations

import math

import numpy as np

from ..model import gear_choice
from ..model.gearing import WormPair
from .base import REBUILD, Check, Fix, Screen, fix_text

TIP_TOL_MM = 0.02             # each flank of a tip tessellated up to 0.01 mm inside the solid
TIP_DEPTHS_MM = (0.05, 0.1, 0.15, 0.2)   # under the tip, where the width is cut, then extrapolated to it
BAND_MM = 0.002               # the ring's (band's) width
RING_SEGMENTS = 4096


def tip_planes(pair: WormPair) -> tuple[float, ...]:
    """Where the wheel is cut, mm from mid-face along its axis: the model's planes
    (:meth:`WormPair.tip_planes`) on both sides of mid-face."""
    return tuple(sorted({round(s * z, 6) for z in pair.tip_planes() for s in (1.0, -1.0)}))


def _extrapolated(widths: dict[float, float]) -> float:
    """The width at the tip (depth 0) of a straight line through (depth, width)."""
    d = np.array(list(widths), dtype=float)
    w = np.array(list(widths.values()), dtype=float)
    _, at_tip = np.polyfit(d, w, 1)
    return float(at_tip)


def wheel_tip(mesh, axis, planes: tuple[float, ...]) -> dict:
    """The thinnest tooth tip of a wheel (mm) over the sections ``planes`` (mm from mid-face, the
    middle of its crest), and the plane it is in."""
    import manifold3d as m3d
    solid = _manifold(mesh, axis.frame())
    mid = sum(axis.crest) / 2
    best = {"tip_mm": math.inf, "plane_mm": None}
    for z in planes:
        cs = solid.slice(mid + z)
        polys = [np.asarray(p) for p in cs.to_polygons()]
        if not polys:
            continue
        r_tip = max(float(np.hypot(p[:, 0], p[:, 1]).max()) for p in polys)
        widths = {}
        for depth in TIP_DEPTHS_MM:
            rad = r_tip - depth
            ring = (m3d.CrossSection.circle(rad + BAND_MM / 2, RING_SEGMENTS)
                    - m3d.CrossSection.circle(rad - BAND_MM / 2, RING_SEGMENTS))
            chords = [_chord(piece, rad) for piece in (cs ^ ring).decompose()]
            if chords:
                widths[depth] = min(chords)
        if len(widths) >= 2:
            tip = _extrapolated(widths)
            if tip < best["tip_mm"]:
                best = {"tip_mm": tip, "plane_mm": z}
    return best


def _chord(piece, rad: float) -> float:
    """The chord across one tooth's piece of a ring at radius ``rad``."""
    q = np.vstack([np.asarray(p) for p in piece.to_polygons()])
    a = np.arctan2(q[:, 1], q[:, 0])
    c = math.atan2(np.sin(a).mean(), np.cos(a).mean())
    width = float(np.ptp(np.angle(np.exp(1j * (a - c)))))
    return 2 * rad * math.sin(width / 2)


def thread_tip(mesh, axis, pitch: float) -> dict:
    """The thinnest thread tip of a worm (mm, along its axis) in the plane through its axis, the
    threads within a pitch of the crest's ends left out (the thread's run-out)."""
    import manifold3d as m3d
    # the axis along X, the plane through it Z = 0
    swap = np.array([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    cs = _manifold(mesh, swap @ axis.frame()).slice(0.0)
    polys = [np.asarray(p) for p in cs.to_polygons()]
    if not polys:
        return {"tip_mm": math.nan}
    lo, hi = axis.crest[0] + pitch, axis.crest[1] - pitch
    r_tip = max(float(np.abs(p[:, 1]).max()) for p in polys)
    widths = {}
    for depth in TIP_DEPTHS_MM:
        rad = r_tip - depth
        got = []
        for sign in (1.0, -1.0):
            y0 = sign * rad - BAND_MM / 2
            band = m3d.CrossSection.square((hi - lo + 2 * pitch, BAND_MM)).translate((lo - pitch, y0))
            for piece in (cs ^ band).decompose():
                x = np.vstack([np.asarray(p) for p in piece.to_polygons()])[:, 0]
                if x.min() >= lo and x.max() <= hi:
                    got.append(float(np.ptp(x)))
        if got:
            widths[depth] = min(got)
    return {"tip_mm": _extrapolated(widths) if len(widths) >= 2 else math.nan}


def _manifold(mesh, frame: np.ndarray):
    from .meshes import to_manifold
    return to_manifold(mesh, frame)


def tip_checks(tips: dict, pair: WormPair, lay, min_wall: float, on: str) -> list[Check]:
    """``gear.tooth_tip`` and ``gear.thread_tip`` of the measured ``tips`` ({"wheel": ..., "worm":
    ...} of :func:`wheel_tip` and :func:`thread_tip`, on channel ``on``'s files; every channel has
    that gear) against the process's ``min_wall``, with their tried fixes."""
    common = {"channel": "all", "measured_on": on}
    floor = min_wall - TIP_TOL_MM
    out = []
    for cid, part, got, why in (("gear.tooth_tip", "wheel", tips["wheel"], "module"),
                                ("gear.thread_tip", "worm", tips["worm"], "module and pressure angle")):
        tip, model = got["tip_mm"], _model_tip(cid, pair)
        if not math.isfinite(tip):          # no section met a tooth: the file is not the gear the plan made
            out.append(Check(cid, "error", False, f"measured on channel {on}'s files: the {part}'s tips could not "
                                                  f"be cut from its file", None, floor, dict(common), fix=REBUILD))
            continue
        ok = bool(tip >= floor)
        where = "" if got.get("plane_mm") is None else f", {got['plane_mm']:+.2f} mm from mid-face"
        fixes = () if ok else _tip_fixes(cid, pair, lay, min_wall, tip)
        out.append(Check(
            cid, "error", ok,
            f"measured on channel {on}'s files: the {part}'s thinnest {'tooth' if part == 'wheel' else 'thread'} tip "
            f"{tip:.3f} mm{where} (the generated {part}: {model:.3f} mm, set by the gear's {why}), against "
            f"process.min_wall {min_wall:g} mm less {TIP_TOL_MM:g} mm for the files' tessellation", tip, floor,
            {**common, "model_mm": model}, fix="" if ok else fix_text(fixes), fixes=fixes))
    return out


def _model_tip(cid: str, pair: WormPair) -> float:
    return pair.thinnest_tip() if cid == "gear.tooth_tip" else pair.thread_tip


def _tip_fixes(cid: str, pair: WormPair, lay, min_wall: float, tip: float) -> tuple[Fix, ...]:
    """The least gear change that prints with ``min_wall`` (every rule of the pair, the hex socket);
    then, a relaxation, the thickest wall the built gear prints with (the wheel's outside radius
    follows the wall). Each tried on the model of the generated gear, its tip scaled as the built
    ``tip`` measured against the model's."""
    mu, hex_key = lay.friction_coefficient, lay.hex_key
    scale = tip / _model_tip(cid, pair)
    limit = min_wall - TIP_TOL_MM
    out = []
    choice = gear_choice.least_change(pair, mu, hex_key, min_wall)
    if choice.values:
        got = scale * _model_tip(cid, WormPair(**{**_fields(pair), **_renamed(choice.values), "min_tip": min_wall}))
        was = ", ".join(f"{getattr(pair, _PAIR[k]):g}" for k in choice.values)
        out.append(Fix({f"tensioner.{k}": v for k, v in choice.values.items()},
                       {"measured": got, "passed": got >= limit, "limit": limit},
                       note=f"from {was}: the least change of the gear that prints with this wall, self-locks and "
                            f"covers the wheel's reach (the search hwgen derives a gear with); the tip of that "
                            f"gear as generated, scaled as this one measured"))
    wall = gear_choice.thickest_wall(pair, mu, hex_key, min_wall)
    if wall is not None:
        got = scale * _model_tip(cid, WormPair(**{**_fields(pair), "min_tip": wall}))
        out.append(Fix({"process.min_wall": wall}, {"measured": got, "passed": got >= wall - TIP_TOL_MM,
                                                    "limit": wall - TIP_TOL_MM},
                       note=f"from {min_wall:g} mm: state that the printer holds {wall:g} mm walls, with which this "
                            f"gear prints (the wheel's outside radius cut for them)", relax=True))
    return tuple(out)


# the tensioner section's gear keys as the pair names them
_PAIR = {"module": "module", "worm_pitch_diameter": "worm_pitch_diameter", "worm_length": "worm_length",
         "worm_starts": "starts"}


def _renamed(values: dict) -> dict:
    return {_PAIR[k]: v for k, v in values.items()}


def _fields(pair: WormPair) -> dict:
    return {k: getattr(pair, k) for k in ("module", "starts", "teeth", "worm_pitch_diameter", "pressure_angle_deg",
                                          "face_width", "worm_length", "center_offset")}


# ---------------------------------------------------------------- on the plan alone

def _tip_screen(plan, cid: str) -> list[Screen]:
    lay = plan.tensioner_layout
    if lay is None:
        return []
    pair, floor = lay.pair, plan.min_wall - TIP_TOL_MM
    tip = _model_tip(cid, pair)
    part = "wheel's tooth" if cid == "gear.tooth_tip" else "worm's thread"
    return [Screen(cid, f"the {part} tip is {tip:.3f} mm as generated, under process.min_wall {plan.min_wall:g} mm",
                   "error", tip, floor)] if tip < floor else []


def tooth_tip_screen(plan) -> list[Screen]:
    """``gear.tooth_tip`` foreseen on the plan: the generated wheel's thinnest tip under the wall."""
    return _tip_screen(plan, "gear.tooth_tip")


def thread_tip_screen(plan) -> list[Screen]:
    """``gear.thread_tip`` foreseen on the plan: the generated worm's thread tip under the wall."""
    return _tip_screen(plan, "gear.thread_tip")
