"""The worm and the drive shaft that turns it: solids along file Z from
:class:`hwgen.model.gearing.WormPair` and the tensioner layout."""
from __future__ import annotations

import cadquery as cq

from ..model.gearing import GearDesignError, WormPair
from ..model.tensioner_layout.sizes import (AXIAL_PLAY, DRIVE_FLANGE, DRIVE_HEX, DRIVE_HEX_LENGTH, DRIVE_SHAFT,
                                            KEY_SOCKET_CLEARANCE, KEY_SOCKET_DEPTH, VENT, WORM_END)
from .primitives import TOOL, hex_prism, one, wire

ROOT_OVERLAP = 0.05      # thread root sunk into the worm core so the fuse has no seam, mm
FAR_CHAMFER = 1.0        # 45° chamfer on the worm's far end, mm


def worm_solid(pair: WormPair, near_end: float, hex_bore: float, pin_bore: float, pin_depth: float) -> cq.Solid:
    """Worm along file Z: plain core from Z = 0 (the face that bears on the spine) to the
    thread, the threaded length, a plain far end bored for the dowel it turns on. A hex bore
    from Z = 0 takes the drive shaft; a small vent joins it to the dowel bore, so no blind
    hole traps resin. The thread is the trapezoid axial profile swept along a helix (right
    hand), one sweep per start."""
    L = pair.worm_length
    z0 = near_end
    length = near_end + L + WORM_END
    prof = pair.worm_axial_profile(ROOT_OVERLAP)
    start = z0 + pair.pitch / 2
    profile = wire([(r, 0, start + dz) for r, dz in prof])
    helix = cq.Wire.makeHelix(pair.lead, L - pair.pitch, pair.r1, center=cq.Vector(0, 0, start))
    thread = cq.Solid.sweep(profile, [], helix, makeSolid=True, isFrenet=True)
    threads = [thread] + [thread.rotate(cq.Vector(), cq.Vector(0, 0, 1), 360.0 * j / pair.starts)
                          for j in range(1, pair.starts)]
    # the far end is chamfered: it bears on the post, and the face that prints on the plate
    # (Z = 0) stays the largest flat face
    c = FAR_CHAMFER
    core = cq.Solid.makeCylinder(pair.rf1, length - c, cq.Vector(0, 0, 0)).fuse(
        cq.Solid.makeCone(pair.rf1, pair.rf1 - c, c, cq.Vector(0, 0, length - c)))
    body = core.fuse(*threads)
    socket = hex_prism(hex_bore, (0, 0, -TOOL), (0, 0, DRIVE_HEX_LENGTH + 0.5), (1, 0, 0))
    bore = cq.Solid.makeCylinder(pin_bore / 2, pin_depth + TOOL, cq.Vector(0, 0, length - pin_depth))
    vent = cq.Solid.makeCylinder(VENT / 2, length, cq.Vector(0, 0, 0))
    return one(body.cut(socket, bore, vent), GearDesignError)


def drive_solid(spine_length: float, hex_key: float) -> cq.Solid:
    """The drive shaft, file Z from its flange's outer face: the flange (it stops the shaft
    against the spine, ``spine_length`` thick, mm) with the socket of a ``hex_key`` mm key, the
    shaft that turns in the spine's hole, and the hex end pressed into the worm."""
    fd, ft = DRIVE_FLANGE
    shaft_len = spine_length + AXIAL_PLAY / 2
    # pieces overlap 0.01 mm inside each other so they fuse into one solid, never past the worm's face
    flange = cq.Solid.makeCylinder(fd / 2, ft, cq.Vector(0, 0, 0))
    shaft = cq.Solid.makeCylinder(DRIVE_SHAFT / 2, shaft_len + 0.01, cq.Vector(0, 0, ft - 0.01))
    hexa = hex_prism(DRIVE_HEX, (0, 0, ft + shaft_len - 0.01), (0, 0, ft + shaft_len + DRIVE_HEX_LENGTH), (1, 0, 0))
    socket = hex_prism(hex_key + KEY_SOCKET_CLEARANCE, (0, 0, -TOOL), (0, 0, KEY_SOCKET_DEPTH), (1, 0, 0))
    vent = cq.Solid.makeCylinder(VENT / 2, ft + shaft_len + DRIVE_HEX_LENGTH + TOOL, cq.Vector(0, 0, 0))
    return one(flange.fuse(shaft, hexa).cut(socket, vent), GearDesignError)

