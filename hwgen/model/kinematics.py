"""Constant-curvature kinematics, eq. (1), and chord-sum tendon lengths, eq. (2) (numpy only).

The backbone bends in the y-z plane with curvature κ = [κx, 0, 0]; positive κx bends it
toward +z. Disk i sits at arc length y_i with frame T_i = exp(y_i ξ^), ξ = [e2; κ]:
rotation R_x(κ y_i) and origin (0, sin(κ y_i)/κ, (1 - cos(κ y_i))/κ).
Everything is vectorised over a sweep of bending angles θ = κ L.
"""
from __future__ import annotations

import numpy as np


def frames(stations, kappa) -> tuple[np.ndarray, np.ndarray]:
    """Disk frames for each curvature: rotations (K, N, 3, 3) and origins (K, N, 3)."""
    s = np.asarray(stations, dtype=float)[None, :]
    k = np.atleast_1d(np.asarray(kappa, dtype=float))[:, None]
    th = k * s
    c, sn = np.cos(th), np.sin(th)
    K, N = th.shape
    R = np.zeros((K, N, 3, 3))
    R[..., 0, 0] = 1.0
    R[..., 1, 1], R[..., 1, 2] = c, -sn
    R[..., 2, 1], R[..., 2, 2] = sn, c
    small = np.abs(k) < 1e-12
    ks = np.where(small, 1.0, k)
    k0 = np.where(small, k, 0.0)        # the series' curvature (k² of a huge k, unused, would overflow)
    # sin(ks)/k and (1-cos(ks))/k, with their limits s and 0 at k -> 0 (series to 3rd order)
    y = np.where(small, s - k0**2 * s**3 / 6, sn / ks)
    z = np.where(small, k0 * s**2 / 2, (1 - c) / ks)
    p = np.stack([np.zeros_like(y), y, z], axis=-1)
    return R, p


def points_in_space(stations, xz: np.ndarray, kappa) -> np.ndarray:
    """Eyelet points (N, 2) in their disk frames mapped to robot coordinates: (K, N, 3)."""
    R, p = frames(stations, kappa)
    xz = np.asarray(xz, dtype=float)
    r = np.column_stack([xz[:, 0], np.zeros(len(xz)), xz[:, 1]])  # (N, 3)
    return p + np.einsum("knij,nj->kni", R, r)


def tendon_lengths(stations, xz: np.ndarray, kappa) -> np.ndarray:
    """eq. (2): sum of straight segments between consecutive eyelets, for each curvature (K,)."""
    P = points_in_space(stations, xz, kappa)
    return np.linalg.norm(np.diff(P, axis=1), axis=2).sum(axis=1)


def kappas_for_angles(angles_deg, length: float) -> np.ndarray:
    """Curvatures that bend a backbone of this length by the given total angles."""
    return np.radians(np.asarray(angles_deg, dtype=float)) / length


def segment_directions_local(stations, xz: np.ndarray, kappa) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions of each tendon segment seen from the disks at both its ends.

    Returns (into, out_of), each (K, N, 3): ``into[k, i]`` is the direction of the segment
    arriving at disk i (from i-1) in frame i, ``out_of[k, i]`` that of the segment leaving
    disk i (toward i+1) in frame i. Missing segments at the ends, and segments of no length (two
    eyelets at one point: the centre of the bend, or a gap too small for a double's square), are NaN.
    """
    R, _ = frames(stations, kappa)
    P = points_in_space(stations, xz, kappa)
    seg = np.diff(P, axis=1)
    length = np.linalg.norm(seg, axis=2, keepdims=True)
    seg = np.divide(seg, length, out=np.full_like(seg, np.nan), where=length > 0)
    K, N = P.shape[:2]
    into = np.full((K, N, 3), np.nan)
    out = np.full((K, N, 3), np.nan)
    Rt = np.swapaxes(R, -1, -2)
    into[:, 1:] = np.einsum("knij,knj->kni", Rt[:, 1:], seg)
    out[:, :-1] = np.einsum("knij,knj->kni", Rt[:, :-1], seg)
    return into, out
