"""Where a tendon meets the backbone strip's plane (z = 0), and at what angle (numpy only).

Used twice over: the plan puts a hole in the strip at every crossing of the designed
eyelets; the checks find the crossings again from the eyelets measured in the files.
"""
from __future__ import annotations

import numpy as np

from . import kinematics as kin

STRIP_NORMAL = np.array([0.0, 0.0, 1.0])


def strip_crossings(stations, xz: np.ndarray, half_height: float,
                    in_slot: set[int] = frozenset()) -> list[tuple[float, float, float]]:
    """(station, x, y) wherever the straight robot's tendon path crosses the strip within its height.

    ``in_slot``: stations whose eyelet lies inside the backbone slot (the tendon passes through
    the strip there). Between two stations the path crosses where z changes sign strictly; the
    station is then fractional.
    """
    ys = np.asarray(stations, dtype=float)
    x, z = xz[:, 0], xz[:, 1]
    out = [(float(i), float(x[i]), float(ys[i])) for i in sorted(in_slot)]
    for i in range(len(ys) - 1):
        if z[i] * z[i + 1] < 0:
            f = z[i] / (z[i] - z[i + 1])
            xc = x[i] + f * (x[i + 1] - x[i])
            if abs(xc) < half_height:
                out.append((i + f, float(xc), float(ys[i] + f * (ys[i + 1] - ys[i]))))
    return out


def in_strip_plane(xz: np.ndarray, half_height: float) -> list[int]:
    """Bays (i, i + 1) in which the tendon runs inside the strip's plane and height."""
    x, z = xz[:, 0], xz[:, 1]
    return [i for i in range(len(xz) - 1)
            if z[i] == 0 and z[i + 1] == 0 and (abs(x[i]) < half_height or abs(x[i + 1]) < half_height)]


def crossing_angles(stations, xz: np.ndarray, station: float, kappa) -> np.ndarray:
    """(K,) angle between the tendon and the strip's normal where it crosses, per curvature, rad.

    At a disk both the incoming and the outgoing segment count; between disks the chord is
    compared with the bent strip's normal at that arc length. The strip is thin, but the line
    crosses it steeply (C1 at the prototype's middle disk meets it at about 75° to its normal),
    so this sets the strip hole's size.
    """
    ys = np.asarray(stations, dtype=float)
    xz = np.asarray(xz, dtype=float)
    kappa = np.atleast_1d(np.asarray(kappa, dtype=float))
    i = int(station)
    # only the disks either side count: the kinematics of those alone (each disk's point and frame
    # depend on its own arc length only: the same numbers, bit for bit, as over the whole robot)
    if float(station).is_integer():
        lo = max(i - 1, 0)
        into, outof = kin.segment_directions_local(ys[lo:i + 2], xz[lo:i + 2], kappa)
        c = np.fmin(np.abs(np.nan_to_num(into[:, i - lo] @ STRIP_NORMAL, nan=1.0)),
                    np.abs(np.nan_to_num(outof[:, i - lo] @ STRIP_NORMAL, nan=1.0)))
    else:
        P = kin.points_in_space(ys[i:i + 2], xz[i:i + 2], kappa)
        seg = P[:, 1] - P[:, 0]
        seg /= np.linalg.norm(seg, axis=1, keepdims=True)
        R, _ = kin.frames([ys[i] + (station - i) * (ys[i + 1] - ys[i])], kappa)
        c = np.abs(np.einsum("ki,ki->k", seg, R[:, 0] @ STRIP_NORMAL))
    return np.arccos(np.clip(c, 0, 1))
