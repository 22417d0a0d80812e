"""Worm and worm-wheel geometry and the gear formulas (numpy only, no CAD kernel).

The pair is a cylindrical worm (ZA type: straight flanks in the axial section, a
trapezoid thread) and a helical involute wheel whose helix angle equals the worm's lead
angle. In the wheel's mid-plane (the plane through the worm axis, normal to the wheel
axis) the worm's axial section is a rack and the wheel is the involute gear that rolls on
it; off the mid-plane the helix keeps the wheel's teeth parallel to the thread.

Conventions (the "mesh frame", mm): the wheel axis is +Z with the wheel's mid-plane at
Z = 0 and a tooth centred on +X; the worm axis is parallel to +Y through (a, 0, 0) where a
is the centre distance. Angles are radians inside, degrees in field names that say so.

Everything a solid needs (the thread's axial profile, the wheel's transverse tooth
outline, the twist per mm of face width) and every formula check (ratio, lead angle,
self-locking, undercut, Lewis bending stress, worm torque) is computed here, so it can be
tested without building a solid.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

ADDENDUM = 1.0            # addendum / module (worm and wheel), standard full depth
DEDENDUM = 1.25           # dedendum / module: 0.25 m tip clearance
PROFILE_SAMPLES = 48      # radii sampled on each wheel flank
TROCHOID_SAMPLES = 400    # positions of the worm's tip corner used to generate the wheel root
# Effective face width of a worm wheel does not exceed 2/3 of the worm pitch diameter
# (AGMA practice, Shigley's Mechanical Engineering Design, worm gearing).
EFFECTIVE_FACE_FRACTION = 2.0 / 3.0


# Worm file coordinates (axis = file Z, a right-hand thread whose tooth is centred at file
# angle 0) to the mesh frame: file X -> mesh -X (toward the wheel), file Y -> +Z, file Z -> +Y.
WORM_TO_MESH = np.array([[-1.0, 0.0, 0.0],
                         [0.0, 0.0, 1.0],
                         [0.0, 1.0, 0.0]])


class GearDesignError(ValueError):
    """A worm pair that must not be built: not self-locking, undercut, too weak, ..."""


def inv(a):
    """Involute function tan(a) - a."""
    return np.tan(a) - a


@dataclass(frozen=True)
class WormPair:
    """One worm and its wheel.

    module: axial module of the worm = transverse module of the wheel, mm
    starts: number of thread starts z1
    teeth: wheel teeth z2
    worm_pitch_diameter: d1, mm
    pressure_angle_deg: axial pressure angle of the worm = transverse pressure angle of the wheel, deg
    face_width: wheel face width, mm
    worm_length: threaded length of the worm, mm
    backlash: added to the centre distance (d1 + d2)/2, mm
    """

    module: float
    starts: int
    teeth: int
    worm_pitch_diameter: float
    pressure_angle_deg: float
    face_width: float
    worm_length: float
    backlash: float

    # ---- basic dimensions -------------------------------------------------------------
    @property
    def alpha(self) -> float:
        return math.radians(self.pressure_angle_deg)

    @property
    def pitch(self) -> float:
        """Axial pitch p = π m, mm."""
        return math.pi * self.module

    @property
    def lead(self) -> float:
        """Axial advance per worm turn z1 · p, mm."""
        return self.starts * self.pitch

    @property
    def lead_angle(self) -> float:
        """γ = atan(z1 m / d1), rad."""
        return math.atan(self.starts * self.module / self.worm_pitch_diameter)

    @property
    def ratio(self) -> float:
        return self.teeth / self.starts

    @property
    def r1(self) -> float:
        return self.worm_pitch_diameter / 2

    @property
    def ra1(self) -> float:
        return self.r1 + ADDENDUM * self.module

    @property
    def rf1(self) -> float:
        return self.r1 - DEDENDUM * self.module

    @property
    def r2(self) -> float:
        return self.module * self.teeth / 2

    @property
    def ra2(self) -> float:
        return self.r2 + ADDENDUM * self.module

    @property
    def rf2(self) -> float:
        return self.r2 - DEDENDUM * self.module

    @property
    def rb2(self) -> float:
        return self.r2 * math.cos(self.alpha)

    @property
    def center_distance(self) -> float:
        """(d1 + d2)/2 + backlash, mm."""
        return self.r1 + self.r2 + self.backlash

    @property
    def twist_per_mm(self) -> float:
        """Wheel rotation per mm along its axis (rad/mm) so its teeth follow the thread.

        A right-hand worm laid by :data:`WORM_TO_MESH` meshes on its -X side, where its
        thread climbs toward +Y by tan γ per mm of Z; the wheel tooth at the pitch radius
        follows it: dθ/dZ = +tan γ / r2 (a right-hand helical wheel).
        """
        return math.tan(self.lead_angle) / self.r2

    # ---- worm --------------------------------------------------------------------------
    def thread_half_width(self, r):
        """Axial half-thickness of the thread at radius r (trapezoid, p/2 thick at r1), mm."""
        return self.pitch / 4 - (np.asarray(r) - self.r1) * math.tan(self.alpha)

    def worm_axial_profile(self, overlap: float = 0.0) -> np.ndarray:
        """(4, 2) trapezoid (radius, axial offset) of one thread tooth, centred on 0.

        ``overlap`` sinks the root corners into the core so the fused solid has no seam.
        """
        r0, r1 = self.rf1 - overlap, self.ra1
        w0, w1 = self.thread_half_width(r0), self.thread_half_width(r1)
        return np.array([[r0, -w0], [r1, -w1], [r1, w1], [r0, w0]])

    # ---- wheel -------------------------------------------------------------------------
    def _involute_half_angle(self, r):
        """Half-angle of the tooth at radius r: involute above the base circle, radial below."""
        r = np.asarray(r, dtype=float)
        a_r = np.arccos(np.clip(self.rb2 / np.maximum(r, self.rb2), -1, 1))
        return math.pi / (2 * self.teeth) + inv(self.alpha) - inv(a_r)

    def _trochoid(self) -> np.ndarray:
        """Path (radius, polar angle) of the worm thread's tip corner in the wheel frame.

        In the mid-plane the worm is a rack; its tip corner next to the tooth on +X sits at
        depth ADDENDUM·m below the pitch line. Rolling the rack over the pitch circle traces
        the trochoid that bounds the wheel's root (what a hob of this worm would cut).
        """
        m, r2 = self.module, self.r2
        yc = self.pitch / 4 + ADDENDUM * m * math.tan(self.alpha)   # corner offset along the rack
        xc = r2 - ADDENDUM * m
        span = 2.5 * self.pitch / r2
        th = np.linspace(-span, span, TROCHOID_SAMPLES) - yc / r2
        # rack point (xc, yc + r2 θ) seen from the wheel rotated by θ
        x = xc * np.cos(th) + (yc + r2 * th) * np.sin(th)
        y = -xc * np.sin(th) + (yc + r2 * th) * np.cos(th)
        return np.column_stack([np.hypot(x, y), np.arctan2(y, x)])

    @cached_property
    def _flank(self) -> tuple[np.ndarray, np.ndarray]:
        """(radii, half-angles) of one flank from the root circle to the tip, generated.

        The half-angle at each radius is the smaller of the involute (radial below the base
        circle) and the angle at which the worm's tip corner passes: the flank the worm would
        leave if it cut the wheel.
        """
        r = np.linspace(self.rf2, self.ra2, PROFILE_SAMPLES)
        half = self._involute_half_angle(r)
        tr = self._trochoid()
        k = int(np.argmin(tr[:, 0]))
        for branch in (tr[:k + 1][::-1], tr[k:]):          # each branch rises in radius
            rr, ang = branch[:, 0], branch[:, 1]
            inside = (r >= rr[0]) & (r <= rr[-1])
            if inside.any():
                half = np.where(inside, np.minimum(half, np.interp(r, rr, ang)), half)
        return r, half

    def flank_points(self) -> np.ndarray:
        """(n, 2) x, y of the tooth centred on +X, its +y flank from root to tip, mm."""
        r, half = self._flank
        return np.column_stack([r * np.cos(half), r * np.sin(half)])

    @property
    def tip_half_angle(self) -> float:
        return float(self._flank[1][-1])

    @property
    def root_half_angle(self) -> float:
        return float(self._flank[1][0])

    @property
    def tip_thickness(self) -> float:
        """Chordal tooth thickness at the tip circle, mm."""
        return 2 * self.ra2 * math.sin(self.tip_half_angle)

    @property
    def root_space(self) -> float:
        """Chordal width of the tooth space at the root circle, mm."""
        return 2 * self.rf2 * math.sin(math.pi / self.teeth - self.root_half_angle)

    @property
    def min_teeth_no_undercut(self) -> float:
        """Fewest teeth a rack of addendum 1·m generates without undercut: 2 / sin²α."""
        return 2 * ADDENDUM / math.sin(self.alpha) ** 2

    @property
    def undercut_depth(self) -> float:
        """How far the generated root eats into the involute above the base circle, rad of half-angle."""
        r, half = self._flank
        above = r > self.rb2
        if not above.any():
            return 0.0
        return float(np.max(self._involute_half_angle(r[above]) - half[above]))

    # ---- strength ----------------------------------------------------------------------
    def lewis_form_factor(self) -> float:
        """Lewis form factor Y of the wheel tooth as built (load at the tip, no stress factor).

        The tooth is a cantilever loaded at the tip circle by the tangential force; at every
        section below the tip the bending stress is 6 F l / (b s²) with s the chordal
        thickness and l the distance to the load. Y = min s² / (6 l m), so σ = F / (b m Y).
        """
        r, half = self._flank
        s = 2 * r * np.sin(half)
        h = r * np.cos(half)
        h_load = self.ra2 * math.cos(self.tip_half_angle)
        lever = h_load - h
        ok = lever > 1e-9
        return float(np.min(s[ok] ** 2 / (6 * lever[ok] * self.module)))

    @property
    def effective_face_width(self) -> float:
        return min(self.face_width, EFFECTIVE_FACE_FRACTION * self.worm_pitch_diameter)

    def wheel_tangential_force(self, wheel_torque_nmm: float) -> float:
        return wheel_torque_nmm / self.r2

    def lewis_stress(self, wheel_torque_nmm: float) -> float:
        """Tooth root bending stress σ = F_t / (b_eff m Y) for a wheel torque, MPa."""
        return self.wheel_tangential_force(wheel_torque_nmm) / (
            self.effective_face_width * self.module * self.lewis_form_factor())

    def friction_angle(self, mu: float) -> float:
        """Thread friction angle φ' = atan(μ / cos α_n), rad."""
        alpha_n = math.atan(math.tan(self.alpha) * math.cos(self.lead_angle))
        return math.atan(mu / math.cos(alpha_n))

    def self_locking(self, mu: float) -> bool:
        """The wheel cannot drive the worm when γ < atan μ (the issue's criterion)."""
        return self.lead_angle < math.atan(mu)

    def worm_torque(self, wheel_torque_nmm: float, mu: float) -> float:
        """Torque on the worm to raise the wheel torque (tightening against the tendon), N·mm.

        T1 = F_t2 · r1 · tan(γ + φ'): the thread is a screw lifting the wheel's tangential force.
        """
        ft2 = self.wheel_tangential_force(wheel_torque_nmm)   # = axial force on the worm
        return ft2 * self.r1 * math.tan(self.lead_angle + self.friction_angle(mu))

    def efficiency(self, mu: float) -> float:
        g = self.lead_angle
        return math.tan(g) / math.tan(g + self.friction_angle(mu))

    # ---- what must not be built --------------------------------------------------------
    def problems(self, mu: float, min_wall: float = 0.0) -> list[tuple[str, str]]:
        """(field, message) for every reason this pair must not be built; empty when fine."""
        out = []
        if not self.self_locking(mu):
            out.append(("worm_pitch_diameter",
                        f"lead angle {math.degrees(self.lead_angle):.2f}° is not below the friction angle "
                        f"atan({mu:g}) = {math.degrees(math.atan(mu)):.2f}°: the tendon would turn the worm "
                        f"back (not self-locking); use a larger worm_pitch_diameter or fewer starts"))
        if self.teeth < self.min_teeth_no_undercut:
            out.append(("wheel_teeth",
                        f"{self.teeth} teeth is below {math.ceil(self.min_teeth_no_undercut)}, the minimum "
                        f"without undercut at {self.pressure_angle_deg:g}° pressure angle"))
        if self.rf1 <= 0 or self.rf1 < 1.5 * self.module:
            out.append(("worm_pitch_diameter",
                        f"worm root radius {self.rf1:.2f} mm leaves no core for a {self.module:g} mm module"))
        if self.thread_half_width(self.ra1) * 2 < min_wall:
            out.append(("pressure_angle_deg",
                        f"worm thread tip {2 * self.thread_half_width(self.ra1):.3f} mm is thinner than the "
                        f"process minimum wall {min_wall:g} mm"))
        if self.tip_thickness < min_wall:
            out.append(("module", f"wheel tooth tip {self.tip_thickness:.3f} mm is thinner than the process "
                                  f"minimum wall {min_wall:g} mm; use a larger module"))
        need = max(2 * self.pitch, engagement_length(self) + self.pitch)
        if self.worm_length < need:
            out.append(("worm_length", f"{self.worm_length:g} mm of thread does not cover the "
                                       f"{engagement_length(self):.1f} mm the wheel's teeth reach plus a pitch "
                                       f"({need:.1f} mm needed)"))
        return out

    def summary(self) -> dict:
        return {
            "module_mm": self.module, "starts": self.starts, "teeth": self.teeth,
            "worm_pitch_diameter_mm": self.worm_pitch_diameter, "wheel_pitch_diameter_mm": 2 * self.r2,
            "pressure_angle_deg": self.pressure_angle_deg, "lead_angle_deg": math.degrees(self.lead_angle),
            "ratio": self.ratio, "center_distance_mm": self.center_distance, "backlash_mm": self.backlash,
            "face_width_mm": self.face_width, "worm_length_mm": self.worm_length,
            "lewis_form_factor": self.lewis_form_factor(),
        }


def engagement_length(pair: WormPair) -> float:
    """Length of worm along its axis that the wheel's tip circle reaches, mm."""
    depth = pair.ra2 - (pair.center_distance - pair.ra1)
    if depth <= 0:
        return 0.0
    return 2 * math.sqrt(pair.ra2 ** 2 - (pair.ra2 - depth) ** 2)


def worm_pair(t) -> WormPair:
    """The pair described by a :class:`hwgen.params.Tensioner` section."""
    return WormPair(module=t.module, starts=t.worm_starts, teeth=t.wheel_teeth,
                    worm_pitch_diameter=t.worm_pitch_diameter, pressure_angle_deg=t.pressure_angle_deg,
                    face_width=t.face_width, worm_length=t.worm_length, backlash=t.center_offset)
