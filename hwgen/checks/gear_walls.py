"""The worm gear's thinnest printed features, measured from its files against the process's wall:
the wheel's tooth tip across its face (``gear.tooth_tip``), the worm's thread tip
(``gear.thread_tip``), the worm's core round the bores on its axis (``gear.bore_wall``: the drive
shaft's hex end pressed in from its near face, the dowel it turns on at its far end) and the drive
shaft round the key's socket and its vent (``gear.drive_wall``).

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
the plane through its axis, the threads clear of its ends by a pitch. A bore's wall is the least
distance between the bore's outline and the worm's outline in sections normal to the worm's axis,
every :data:`BORE_STEP_MM` along it.
"""
from __future__ import annotations

import math

import numpy as np

from ..model import gear_choice
from ..model.gearing import WormPair
from ..model.tensioner_layout.sizes import DRIVE_HEX, DRIVE_SHAFT, KEY_SOCKET_CLEARANCE, VENT, key_socket
from .base import REBUILD, Check, Fix, Screen, fix_text
from .polygons import loop_gap, signed_area

TIP_TOL_MM = 0.02             # each flank of a tip tessellated up to 0.01 mm inside the solid
TIP_DEPTHS_MM = (0.05, 0.1, 0.15, 0.2)   # under the tip, where the width is cut, then extrapolated to it
BAND_MM = 0.002               # the ring's (band's) width
RING_SEGMENTS = 4096
BORE_TOL_MM = 0.01            # the core's round face tessellated up to 0.01 mm inside the solid (a hex bore is exact)
BORE_STEP_MM = 0.25           # the worm cut normal to its axis this often
END_CLEAR_MM = 1.2            # and not within this of its ends: the far end's 1 mm chamfer thins its wall by design
HEX_ROUNDNESS = 1.05          # a bore's perimeter² / (4π area): 1 round, 1.10 a hexagon


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


def bore_wall(mesh, axis) -> dict:
    """The thinnest wall of a worm's core round the bores on its axis (mm), where it is (mm from the
    worm's nearer end) and round which bore ("hex", or "round" with its diameter)."""
    solid = _manifold(mesh, axis.frame())
    _, along = axis.radial(np.asarray(mesh.vertices))
    lo, hi = float(along.min()), float(along.max())
    best = {"wall_mm": math.inf, "from_end_mm": None, "bore": None}
    for z in np.arange(lo + END_CLEAR_MM, hi - END_CLEAR_MM + 1e-9, BORE_STEP_MM):
        polys = [np.asarray(p, dtype=float) for p in solid.slice(float(z)).to_polygons()]
        area = [signed_area(p) for p in polys]
        outer = [p for p, a in zip(polys, area) if a > 0]
        for hole, a in zip(polys, area):
            if a >= 0 or not outer:
                continue
            wall = min(loop_gap(hole, o) for o in outer)
            if wall < best["wall_mm"]:
                perimeter = float(np.linalg.norm(np.roll(hole, -1, axis=0) - hole, axis=1).sum())
                kind = ("hex" if perimeter ** 2 / (4 * math.pi * -a) > HEX_ROUNDNESS else
                        f"round Ø{2 * math.sqrt(-a / math.pi):.2f} mm")
                best = {"wall_mm": wall, "from_end_mm": float(min(z - lo, hi - z)), "bore": kind}
    return best


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
        tip, model = got["tip_mm"], _model(cid, pair, lay)
        if not math.isfinite(tip):          # no section met a tooth: the file is not the gear the plan made
            out.append(Check(cid, "error", False, f"measured on channel {on}'s files: the {part}'s tips could not "
                                                  f"be cut from its file", None, floor, dict(common), fix=REBUILD))
            continue
        ok = bool(tip >= floor)
        where = "" if got.get("plane_mm") is None else f", {got['plane_mm']:+.2f} mm from mid-face"
        fixes = () if ok else _wall_fixes(cid, pair, lay, min_wall, tip)
        out.append(Check(
            cid, "error", ok,
            f"measured on channel {on}'s files: the {part}'s thinnest {'tooth' if part == 'wheel' else 'thread'} tip "
            f"{tip:.3f} mm{where} (the generated {part}: {model:.3f} mm, set by the gear's {why}), against "
            f"process.min_wall {min_wall:g} mm less {TIP_TOL_MM:g} mm for the files' tessellation", tip, floor,
            {**common, "model_mm": model}, fix="" if ok else fix_text(fixes), fixes=fixes))
    return out


def bore_check(got: dict, pair: WormPair, lay, min_wall: float, on: str) -> Check:
    """``gear.bore_wall`` of the measured ``got`` (:func:`bore_wall`, on channel ``on``'s worm; every
    channel has that worm) against the process's ``min_wall``, with its tried fixes."""
    cid, common, floor = "gear.bore_wall", {"channel": "all", "measured_on": on}, min_wall - BORE_TOL_MM
    wall = got["wall_mm"]
    if not math.isfinite(wall):             # no section met a bore: the file is not the worm the plan made
        return Check("gear.bore_wall", "error", False, f"measured on channel {on}'s files: no bore could be cut from the "
                                          f"worm's file", None, floor, dict(common), fix=REBUILD)
    model = _model(cid, pair, lay)
    what = "the drive shaft's hex end" if got["bore"] == "hex" else f"a {got['bore']} bore"
    ok = bool(wall >= floor)
    fixes = () if ok else _wall_fixes(cid, pair, lay, min_wall, wall)
    return Check("gear.bore_wall", "error", ok,
                 f"measured on channel {on}'s files: the worm's core is {wall:.3f} mm thick round {what}, "
                 f"{got['from_end_mm']:.1f} mm from its end (the generated worm: {model:.3f} mm, its root Ø"
                 f"{2 * pair.rf1:.3f} mm round the {DRIVE_HEX:g} mm hex and the Ø{gear_choice.pin_bore(lay):g} mm "
                 f"dowel bore), against process.min_wall {min_wall:g} mm less {BORE_TOL_MM:g} mm for the files' "
                 f"tessellation", wall, floor, {**common, "model_mm": model},
                 fix="" if ok else fix_text(fixes), fixes=fixes)


def drive_wall_model(hex_key: float) -> float:
    """The drive shaft's thinnest wall as generated, mm: round the key's socket in its Ø shaft, or round
    the vent in its hex end (the vent's wall to the hexagon's flats)."""
    socket = (DRIVE_SHAFT - key_socket(hex_key)) / 2
    return min(socket, (DRIVE_HEX - VENT) / 2)


def drive_check(got: dict, hex_key: float, min_wall: float, on: str) -> Check:
    """``gear.drive_wall`` of the measured ``got`` (:func:`bore_wall` of channel ``on``'s drive shaft,
    along its file Z; every channel has that shaft) against the process's ``min_wall``, with its tried
    fixes: the largest key whose socket leaves the wall, then (a relaxation) the wall it prints with."""
    common, floor = {"channel": "all", "measured_on": on}, min_wall - BORE_TOL_MM
    wall = got["wall_mm"]
    if not math.isfinite(wall):
        return Check("gear.drive_wall", "error", False, f"measured on channel {on}'s files: no bore could be cut from the "
                                          f"drive shaft's file", None, floor, dict(common), fix=REBUILD)
    model = drive_wall_model(hex_key)
    what = "the key's socket" if got["bore"] == "hex" else "the vent in its hex end"
    ok = bool(wall >= floor)
    fixes = () if ok else _drive_fixes(hex_key, min_wall, wall, model)
    return Check("gear.drive_wall", "error", ok,
                 f"measured on channel {on}'s files: the drive shaft is {wall:.3f} mm thick round {what}, "
                 f"{got['from_end_mm']:.1f} mm from its end (as generated: {model:.3f} mm; a {hex_key:g} mm key's "
                 f"socket in its Ø{DRIVE_SHAFT:g} mm shaft, a Ø{VENT:g} mm vent in its {DRIVE_HEX:g} mm hex end), "
                 f"against process.min_wall {min_wall:g} mm less {BORE_TOL_MM:g} mm for the files' tessellation",
                 wall, floor, {**common, "model_mm": model}, fix="" if ok else fix_text(fixes), fixes=fixes)


def _drive_fixes(hex_key: float, min_wall: float, measured: float, model: float) -> tuple[Fix, ...]:
    scale, limit = measured / model, min_wall - BORE_TOL_MM
    out = []
    key = math.floor(((DRIVE_SHAFT - 2 * min_wall) * math.sqrt(3) / 2 - KEY_SOCKET_CLEARANCE) * 10 + 1e-9) / 10
    if 0 < key < hex_key:
        got = scale * drive_wall_model(key)
        out.append(Fix({"tensioner.hex_key": key}, {"measured": got, "passed": got >= limit, "limit": limit},
                       note=f"from {hex_key:g} mm: the largest key (to 0.1 mm) whose socket leaves the wall in the "
                            f"shaft; the shaft's walls as generated, scaled as this one measured"))
    wall = math.floor(measured * 100 + 1e-9) / 100
    if 0 < wall < min_wall:
        out.append(Fix({"process.min_wall": wall}, {"measured": measured, "passed": measured >= wall - BORE_TOL_MM,
                                                    "limit": wall - BORE_TOL_MM},
                       note=f"from {min_wall:g} mm: state that the printer holds {wall:g} mm walls, with which this "
                            f"shaft prints", relax=True))
    return tuple(out)


def _model(cid: str, pair: WormPair, lay) -> float:
    """The figure of the generated gear that check ``cid`` measures, mm."""
    if cid == "gear.bore_wall":
        return pair.bore_wall(DRIVE_HEX, gear_choice.pin_bore(lay))
    return pair.thinnest_tip() if cid == "gear.tooth_tip" else pair.thread_tip


def _tol(cid: str) -> float:
    return BORE_TOL_MM if cid == "gear.bore_wall" else TIP_TOL_MM


def _wall_fixes(cid: str, pair: WormPair, lay, min_wall: float, measured: float) -> tuple[Fix, ...]:
    """The least gear change that prints with ``min_wall`` (every rule of the pair, the walls round the
    worm's bores); then, a relaxation, the thickest wall the built gear prints with (the wheel's
    outside radius follows the wall). Each tried on the model of the generated gear, its figure
    scaled as the built one ``measured`` against the model's."""
    scale = measured / _model(cid, pair, lay)
    limit = min_wall - _tol(cid)
    out = []
    choice = gear_choice.least_change(pair, lay, min_wall)
    if choice.values:
        got = scale * _model(cid, WormPair(**{**_fields(pair), **_renamed(choice.values), "min_tip": min_wall}), lay)
        was = ", ".join(f"{getattr(pair, _PAIR[k]):g}" for k in choice.values)
        out.append(Fix({f"tensioner.{k}": v for k, v in choice.values.items()},
                       {"measured": got, "passed": got >= limit, "limit": limit},
                       note=f"from {was}: the least change of the gear that prints with this wall, self-locks and "
                            f"covers the wheel's reach (the search hwgen derives a gear with); the {_FIGURE[cid]} of "
                            f"that gear as generated, scaled as this one measured"))
    wall = gear_choice.thickest_wall(pair, lay, min_wall)
    if wall is not None:
        got = scale * _model(cid, WormPair(**{**_fields(pair), "min_tip": wall}), lay)
        out.append(Fix({"process.min_wall": wall}, {"measured": got, "passed": got >= wall - _tol(cid),
                                                    "limit": wall - _tol(cid)},
                       note=f"from {min_wall:g} mm: state that the printer holds {wall:g} mm walls, with which this "
                            f"gear prints (the wheel's outside radius cut for them)", relax=True))
    return tuple(out)


_FIGURE = {"gear.tooth_tip": "tooth tip", "gear.thread_tip": "thread tip", "gear.bore_wall": "worm's bore wall"}


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
    tip = _model(cid, pair, lay)
    part = "wheel's tooth" if cid == "gear.tooth_tip" else "worm's thread"
    return [Screen(cid, f"the {part} tip is {tip:.3f} mm as generated, under process.min_wall {plan.min_wall:g} mm",
                   "error", tip, floor)] if tip < floor else []


def tooth_tip_screen(plan) -> list[Screen]:
    """``gear.tooth_tip`` foreseen on the plan: the generated wheel's thinnest tip under the wall."""
    return _tip_screen(plan, "gear.tooth_tip")


def thread_tip_screen(plan) -> list[Screen]:
    """``gear.thread_tip`` foreseen on the plan: the generated worm's thread tip under the wall."""
    return _tip_screen(plan, "gear.thread_tip")


def bore_wall_screen(plan) -> list[Screen]:
    """``gear.bore_wall`` foreseen on the plan: the generated worm's core round its bores under the wall."""
    lay = plan.tensioner_layout
    if lay is None:
        return []
    wall, floor = _model("gear.bore_wall", lay.pair, lay), plan.min_wall - BORE_TOL_MM
    return [Screen("gear.bore_wall", f"the worm's core is {wall:.3f} mm round its bores as generated, under "
                                     f"process.min_wall {plan.min_wall:g} mm", "error", wall, floor)] if wall < floor else []


def drive_wall_screen(plan) -> list[Screen]:
    """``gear.drive_wall`` foreseen on the plan: the generated drive shaft's walls under the process's."""
    lay = plan.tensioner_layout
    if lay is None:
        return []
    wall, floor = drive_wall_model(lay.hex_key), plan.min_wall - BORE_TOL_MM
    return [Screen("gear.drive_wall", f"the drive shaft is {wall:.3f} mm round its key's socket or vent as generated, "
                                      f"under process.min_wall {plan.min_wall:g} mm", "error", wall, floor)] if wall < floor else []
