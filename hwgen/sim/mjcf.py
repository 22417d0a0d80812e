"""robot.xml: the printed robot as a MuJoCo model (MJCF), written from a build and the statics.

Bodies. The base mount, its clamp and the base disk are fixed to the world, and so is the strip
up to its first hinge. From there the strip is a chain of links (:mod:`hwgen.sim.chain`: a hinge
about x every few millimetres, one about y and one about z between each pair of disks, each
sprung as the statics springs it); each link carries its piece of strip (a box, its mass from
the strip's measured grams per millimetre). Each disk is a body fixed to the link that holds its
station, with its STL's mass, centre of mass and inertia, its mesh for looks, a cylinder to
collide with, and a site at each printed eyelet (centre and axis as measured). The tensioner's
parts are one body fixed to the tip, their masses and inertias summed with the bought metal
they carry (dowels, screws, nuts: :mod:`hwgen.model.steel`, each piece a small steel cylinder
where the layout puts it). The table is a box whose top is the mount's foot, ending at the
foot's front edge (the mount bolted at the table's edge, the robot overhanging it, as the
assembly guide says); the disks and the tensioner collide with it (contype 1 against its
conaffinity 1), the robot's own parts never with each other.

Joint damping is the strip's: stiffness-proportional, each hinge damped β times its stiffness,
β = η / ω₁ with η the laminate's loss factor (``backbone.loss_factor``) and ω₁ the first bending
mode of state N as this model has it (:mod:`hwgen.sim.modes`): a viscous hinge dissipates per
cycle at ω₁ what a material of loss factor η does. Tendons and gravity carry no damping, so a
mode's damping ratio is βω/2 times the share of its stiffness the strip holds (η/2 times it at
ω₁); sim.json's ``modes`` give each. MuJoCo's Euler step takes joint damping
implicitly, and a stiffness-proportional β of at least half the step keeps every hinge stable
however stiff (the stiff directions are 10⁴ times the flexible one): the step is
:data:`TIMESTEP`, or 2β where β is smaller.

Tendons. Each YAML tendon is a spatial tendon of its name through its sites: its seat (the knot
on the base disk's outer face), every eyelet in order, its exit on the tip face, the point where
its run meets the drum, and an anchor on the drum's take-up. It is a one-way spring
(``springlength="0 L0"``: it pulls when longer than L0, never pushes) of the statics' stiffness
(its free length over EA, in series with the tie-off). Each channel's drum is a take-up body on
a slide joint along its run, held by a position servo: the worm, which self-locks (its ctrl is
the line the drum has hauled in, m; kp :data:`SERVO_RATIO` times its tendons' springs, so the
servo adds 0.1 % to their compliance). A tendon's anchor lies beyond its run's end along the
slide, on the side its sense of winding says (the drum's far side pays out as the near side
hauls in), so a drum that winds its tendons the same way tensions them together and one that
winds them oppositely drives them antagonistically, as printed (``tensioner.winding``).

The drive. The paper's robot has no drive: its actuating channel is a worm that tensions A1 and
A2 together, and its bending range is a kinematic simulation (Fig. 6). To bend this model, the
actuating channel's drum, where it winds a pair the same way, gets a drive in series: each of
the pair on a take-up of its own, held by two servos on fixed tendons of the take-ups, the
tensioner's (``haul_<channel>``: the pair's mean haul-in, actuator <channel>) and the drive's
(``drive_<channel>``: half the difference, actuator <channel>_drive): a drum that winds the pair
oppositely, hauling the first in as it pays the second out, as a motor's capstan would. At ctrl
0 the drive holds the pair together and the model is the printed one.

States. A keyframe per tendon state (N, A, ... as ``hwgen stiffness`` names them): the robot
straight, each drum where the statics locks its tendons in that state (the mean over a drum's
tendons; sim.json gives what each tendon is left off by) or paid out as far as it goes (slack),
every drive at 0.
Units: m, kg, s, N.
"""
from __future__ import annotations

import os
import shutil
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..model.sag import G_ACC
from .chain import Hinge
from .parts import Body, Printed, tip_masses

MM, KG, KGM2, NM = 1e-3, 1e-3, 1e-9, 1e-3       # per mm, g, g·mm², N·mm
TIMESTEP = 0.002            # s: MuJoCo's default step
TABLE_MM = (20.0, 400.0)    # the table's thickness and its reach behind its edge and to either side
SERVO_RATIO = 1000.0        # the drum servo's stiffness over its tendons' springs
CHORD_MARGIN_MM = 5.0       # the take-up's chord at full pay-out: it never shrinks to a point
TAKE_UP_MASS_KG = 1e-6      # the take-up body itself: the line; its inertia is the drum's (armature)
MESHES = "meshes"
CHANNEL_RGBA = ((0.85, 0.2, 0.15, 1), (0.15, 0.45, 0.85, 1), (0.2, 0.65, 0.25, 1), (0.75, 0.45, 0.1, 1),
                (0.55, 0.25, 0.7, 1), (0.1, 0.6, 0.6, 1))


@dataclass(frozen=True)
class Drum:
    """One channel's drum as the model drives it."""

    channel: str
    tendons: tuple[str, ...]
    senses: tuple[int, ...]
    travel_mm: float              # how far the take-up goes either way
    kp_n_per_m: float
    armature_kg: float
    drive: bool = False           # a take-up per tendon, with the drive in series (see the module's docstring)


@dataclass(frozen=True)
class Rig:
    """What robot.xml is made of besides the printed parts: the strip's hinges, the drums, the
    hinges' damping over stiffness β (s) and the step (s)."""

    hinges: list
    drums: list
    beta_s: float
    timestep_s: float = TIMESTEP

    def settled(self, beta_s: float) -> "Rig":
        """The rig damped at ``beta_s``, its step :data:`TIMESTEP` or 2β where that is smaller."""
        return Rig(self.hinges, self.drums, beta_s, min(TIMESTEP, 2.0 * beta_s))


@dataclass(frozen=True)
class Locks:
    """The tendon states the keyframes set: (name, channels) of each, and per state each locked
    tendon's haul-in, mm (the statics' lock: ℓ_straight − ℓ₀)."""

    states: list
    hauled: dict


@dataclass(frozen=True)
class Written:
    """What :func:`write_robot` wrote: the drums, each state's drum settings (m of line hauled in)
    and what each locked tendon is left off its lock by (mm), each tendon's rest length (mm)."""

    drums: list
    keyframes: dict               # state -> {channel: ctrl, m}
    residual_mm: dict             # state -> {tendon: lock missed by, mm}
    rest_mm: dict                 # tendon -> springlength L0 at ctrl 0, mm
    baked_mm: dict                # tendon -> haul-in built into its rest length (an opposite-wound drum's lock)
    notes: list


def _f(v: float) -> str:
    return f"{float(v):.10g}"


def _v(a) -> str:
    return " ".join(_f(x) for x in a)


def _quat(R: np.ndarray) -> str:
    x, y, z, w = Rotation.from_matrix(np.asarray(R, float)).as_quat()
    return _v((w, x, y, z))


def combine(items) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre, inertia about it) of several (mass, centre, inertia) together."""
    m = sum(i[0] for i in items)
    c = sum(i[0] * np.asarray(i[1]) for i in items) / m
    inertia = np.zeros((3, 3))
    for mi, ci, Ii in items:
        r = np.asarray(ci) - c
        inertia += Ii + mi * (r @ r * np.eye(3) - np.outer(r, r))
    return m, c, inertia


def _inertial(parent, mass_g: float, com_mm, inertia_g_mm2, origin_mm) -> None:
    I = np.asarray(inertia_g_mm2) * KGM2
    ET.SubElement(parent, "inertial", pos=_v((np.asarray(com_mm) - origin_mm) * MM), mass=_f(mass_g * KG),
                  fullinertia=_v((I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])))


def _mesh_geom(parent, body: Body, assets: dict, origin_mm) -> None:
    P = body.placement
    ET.SubElement(parent, "geom", name=f"{body.name}_mesh", type="mesh", mesh=assets[body.sha256],
                  pos=_v((P[:3, 3] - origin_mm) * MM), quat=_quat(P[:3, :3]), rgba=_v(body.color))


def _box_geom(parent, name: str, lo, hi, origin_mm, cls: str | None = "collision", rgba=None) -> None:
    kw = {"class": cls} if cls else {}
    if rgba is not None:
        kw["rgba"] = _v(rgba)
    ET.SubElement(parent, "geom", name=name, type="box", pos=_v(((np.asarray(lo) + hi) / 2 - origin_mm) * MM),
                  size=_v((np.asarray(hi) - lo) / 2 * MM), **kw)


def _part_body(parent, body: Body, assets: dict, origin_mm, name: str | None = None):
    el = ET.SubElement(parent, "body", name=name or body.name, pos=_v(np.asarray(origin_mm) * MM))
    _inertial(el, body.mass_g, body.com_mm, body.inertia_g_mm2, origin_mm)
    _mesh_geom(el, body, assets, origin_mm)
    return el


def _strip_piece(parent, name: str, a: float, b: float, strip: dict, origin_s: float, mass: bool) -> None:
    """The strip from arc length a to b as a box in the link whose origin is at origin_s."""
    h, t = strip["height_mm"], strip["thickness_mm"]
    lo, hi = np.array([-h / 2, a, -t / 2]), np.array([h / 2, b, t / 2])
    _box_geom(parent, name, lo, hi, np.array([0.0, origin_s, 0.0]), cls=None, rgba=(0.12, 0.12, 0.12, 1))
    if mass:
        m, ell = strip["g_per_mm"] * (b - a), b - a
        inertia = np.diag([m * (ell ** 2 + t ** 2), m * (h ** 2 + t ** 2), m * (h ** 2 + ell ** 2)]) / 12
        _inertial(parent, m, [0.0, (a + b) / 2, 0.0], inertia, np.array([0.0, origin_s, 0.0]))


def _hinge_joints(el, k: int, hinge: Hinge, beta: float) -> None:
    for axis, name, stiff in (("1 0 0", "flex", hinge.flex), ("0 1 0", "twist", hinge.twist),
                              ("0 0 1", "side", hinge.side)):
        if stiff is not None:
            ET.SubElement(el, "joint", name=f"{name}_{k:02d}", type="hinge", axis=axis, stiffness=_f(stiff * NM),
                          damping=_f(beta * stiff * NM))


def _disk(parent, printed: Printed, station: int, assets: dict, link_s: float) -> None:
    body = printed.disks[station]
    y = printed.stations_mm[station]
    origin = np.array([0.0, y, 0.0])
    el = ET.SubElement(parent, "body", name=body.name, pos=_v((origin - [0.0, link_s, 0.0]) * MM))
    _inertial(el, body.mass_g, body.com_mm, body.inertia_g_mm2, origin)
    _mesh_geom(el, body, assets, origin)
    radius = max(abs(body.box_min[0]), abs(body.box_max[0]), abs(body.box_min[2]), abs(body.box_max[2]))
    half = printed.disk_thickness_mm[station] / 2
    ET.SubElement(el, "geom", name=f"{body.name}_collision", type="cylinder", size=_v((radius * MM, half * MM)),
                  quat=_quat(Rotation.from_euler("x", -90, degrees=True).as_matrix()), **{"class": "collision"})
    for e in printed.eyelets:
        if e.station == station:
            R = Rotation.align_vectors([e.axis], [[0.0, 0.0, 1.0]])[0].as_matrix()
            ET.SubElement(el, "site", name=eyelet_site(e), pos=_v((e.centre_mm - origin) * MM), quat=_quat(R),
                          size=_v((e.diameter_mm / 2 * MM, half * MM)), **{"class": "eyelet"})
    if station == 0:
        for t, (x, z, face) in printed.seats.items():
            ET.SubElement(el, "site", name=f"{t}_seat", pos=_v((np.array([x, face, z]) - origin) * MM),
                          size=_v((0.75 * MM,)), **{"class": "route"})
    if station == max(printed.disks):
        ET.SubElement(el, "site", name="tip", pos="0 0 0", size=_v((1.5 * MM,)), rgba="1 0 0 1")


def eyelet_site(e) -> str:
    """An eyelet's site name: its station and the tendons through it (e03_C1; e00_C1+C2+H)."""
    return f"e{e.station:02d}_{'+'.join(e.tendons)}"


def tendon_sites(printed: Printed, name: str) -> list[str]:
    """A tendon's sites, seat to drum."""
    eyelets = sorted((e for e in printed.eyelets if name in e.tendons), key=lambda e: e.station)
    out = [f"{name}_seat"] if name in printed.seats else []
    out += [eyelet_site(e) for e in eyelets]
    if name in printed.runs:
        out += [f"{name}_exit", f"{name}_run", f"{name}_drum"]
    return out


def site_positions(printed: Printed, drums: list) -> dict:
    """Every routing site's position in the straight robot with every drum at ctrl 0, mm (robot frame)."""
    pos = {eyelet_site(e): e.centre_mm for e in printed.eyelets}
    for t, (x, z, face) in printed.seats.items():
        pos[f"{t}_seat"] = np.array([x, face, z])
    for d in drums:
        axis, _ = _drum_axis(printed, d)
        for t, sense in zip(d.tendons, d.senses):
            r = printed.runs[t]
            pos[f"{t}_exit"], pos[f"{t}_run"] = r.start_mm, r.end_mm
            pos[f"{t}_drum"] = r.end_mm + sense * (d.travel_mm + CHORD_MARGIN_MM) * axis
    return pos


def _drum_axis(printed: Printed, d: Drum) -> tuple[np.ndarray, np.ndarray]:
    """The take-up's slide direction (the drum's runs' mean direction) and its origin (their ends' mean)."""
    runs = [printed.runs[t] for t in d.tendons]
    v = sum((r.end_mm - r.start_mm) / np.linalg.norm(r.end_mm - r.start_mm) for r in runs)
    return v / np.linalg.norm(v), np.mean([r.end_mm for r in runs], axis=0)


def _tensioner(parent, printed: Printed, rig: Rig, assets: dict, link_s: float, tip_y: float) -> None:
    origin = np.array([0.0, tip_y, 0.0])
    el = ET.SubElement(parent, "body", name="tensioner", pos=_v((origin - [0.0, link_s, 0.0]) * MM))
    m, c, inertia = combine(tip_masses(printed))
    _inertial(el, m, c, inertia, origin)
    for b in printed.tip:
        _mesh_geom(el, b, assets, origin)
    housing = [b for b in printed.tip if b.role == "tensioner_housing"]
    if housing:
        _box_geom(el, "tensioner_collision", housing[0].box_min, housing[0].box_max, origin)
    pos = site_positions(printed, rig.drums)
    for d in rig.drums:
        for t in d.tendons:
            for k in ("exit", "run"):
                ET.SubElement(el, "site", name=f"{t}_{k}", pos=_v((pos[f"{t}_{k}"] - origin) * MM),
                              size=_v((0.75 * MM,)), **{"class": "route"})
        axis, centre = _drum_axis(printed, d)
        groups = [(t,) for t in d.tendons] if d.drive else [d.tendons]
        for ts in groups:
            name = take_up(d, ts[0])
            de = ET.SubElement(el, "body", name=name, pos=_v((centre - origin) * MM))
            ET.SubElement(de, "inertial", pos="0 0 0", mass=_f(TAKE_UP_MASS_KG), diaginertia="1e-12 1e-12 1e-12")
            ET.SubElement(de, "joint", name=name, type="slide", axis=_v(axis),
                          range=_v((-(d.travel_mm + CHORD_MARGIN_MM / 2) * MM, (d.travel_mm + CHORD_MARGIN_MM / 2) * MM)),
                          armature=_f(d.armature_kg / len(groups)),
                          damping=_f(d.kp_n_per_m / len(groups) * rig.timestep_s))
            for t in ts:
                ET.SubElement(de, "site", name=f"{t}_drum", pos=_v((pos[f"{t}_drum"] - centre) * MM),
                              size=_v((0.75 * MM,)), **{"class": "route"})


def take_up(d: Drum, tendon: str) -> str:
    """The name of the take-up body and slide joint that carries ``tendon`` of drum ``d``."""
    return f"drum_{d.channel}_{tendon}" if d.drive else f"drum_{d.channel}"


def _assets(root, printed: Printed, folder: Path, out: Path) -> dict:
    """One mesh asset per distinct STL (identical parts share one file), linked into out/meshes/."""
    asset = ET.SubElement(root, "asset")
    names = {}
    (out / MESHES).mkdir(parents=True, exist_ok=True)
    for b in [*printed.base, *printed.disks.values(), *printed.tip]:
        if b.sha256 in names:
            continue
        names[b.sha256] = b.name
        target = out / MESHES / f"{b.name}.stl"
        target.unlink(missing_ok=True)
        try:
            os.link(folder / b.stl, target)
        except OSError:
            shutil.copyfile(folder / b.stl, target)
        ET.SubElement(asset, "mesh", name=b.name, file=f"{MESHES}/{b.name}.stl", scale=_v((MM, MM, MM)))
    return names


def _defaults(root) -> None:
    d = ET.SubElement(root, "default")
    ET.SubElement(d, "geom", contype="0", conaffinity="0", group="1")
    c = ET.SubElement(d, "default", **{"class": "collision"})
    ET.SubElement(c, "geom", contype="1", conaffinity="0", group="3", rgba="0.5 0.5 0.5 0.25")
    e = ET.SubElement(d, "default", **{"class": "eyelet"})
    ET.SubElement(e, "site", type="cylinder", group="2", rgba="0.9 0.8 0.1 1")
    r = ET.SubElement(d, "default", **{"class": "route"})
    ET.SubElement(r, "site", type="sphere", group="4", rgba="0.9 0.8 0.1 1")
    t = ET.SubElement(d, "default", **{"class": "table"})
    ET.SubElement(t, "geom", contype="0", conaffinity="1", group="0", rgba="0.55 0.45 0.35 1")


def _table(world, printed: Printed) -> None:
    """The table the mount stands on (see the module's docstring)."""
    if printed.table is None:
        return
    z, x0, x1, _, y1 = printed.table
    thick, reach = TABLE_MM
    lo, hi = np.array([min(x0, 0.0) - reach, y1 - reach, z - thick]), np.array([max(x1, 0.0) + reach, y1, z])
    _box_geom(world, "table", lo, hi, np.zeros(3), cls="table")


def _links(world, printed: Printed, rig: Rig, assets: dict) -> ET.Element:
    """The strip's chain with its disks; returns the last link (the tip's)."""
    hinges = rig.hinges
    strip = printed.strip
    y0, y1 = strip["y_mm"]
    origins = [0.0] + [h.s for h in hinges]
    ends = [h.s for h in hinges] + [y1]
    stations = sorted(printed.disks)
    parent = world
    for i, (o, b) in enumerate(zip(origins, ends)):
        el = ET.SubElement(parent, "body", name=f"strip_{i:02d}",
                           pos=_v((0.0, (o - (origins[i - 1] if i else 0.0)) * MM, 0.0)))
        if i:
            _hinge_joints(el, i, hinges[i - 1], rig.beta_s)
        _strip_piece(el, f"strip_{i:02d}_box", y0 if i == 0 else o, b, strip, o, mass=i > 0)
        for s in stations:
            y = printed.stations_mm[s]
            if o <= y < b:
                _disk(el, printed, s, assets, o)
        parent = el
    return parent


def build_xml(name: str, printed: Printed, rig: Rig, folder: Path, out: Path) -> ET.Element:
    """The MJCF tree (tendons, actuators and keyframes added by :func:`write_robot`)."""
    hinges = rig.hinges
    root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    ET.SubElement(root, "option", timestep=_f(rig.timestep_s), integrator="Euler", gravity=_v((0.0, 0.0, -G_ACC)))
    L = printed.strip["y_mm"][1]
    ET.SubElement(root, "statistic", center=_v((0.0, L / 2 * MM, 0.0)), extent=_f(L * 1.4 * MM))
    _defaults(root)
    assets = _assets(root, printed, folder, out)
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos=_v((0.0, L / 2 * MM, 0.6)), dir="0 0 -1", directional="true")
    for b in printed.base:
        el = _part_body(world, b, assets, np.zeros(3))
        _box_geom(el, f"{b.name}_collision", b.box_min, b.box_max, np.zeros(3))
    _table(world, printed)
    last = _links(world, printed, rig, assets)
    if printed.tip:                   # a design whose tensioner could not be laid out has none
        _tensioner(last, printed, rig, assets, hinges[-1].s if hinges else 0.0,
                   printed.stations_mm[max(printed.disks)])
    return root


def path_length(points: list) -> float:
    return float(sum(np.linalg.norm(np.subtract(b, a)) for a, b in zip(points[:-1], points[1:])))


def drums_of(printed: Printed, channels: list, springs: dict, reach: dict, break_load: float,
             armature: dict, order: list, driven: str | None = None) -> list[Drum]:
    """Each channel's drum: its tendons in order, their senses, how far it travels (the most any
    of its tendons' length changes, ``reach`` (over the check's sweep, or hauled in to a state's
    lock), plus its stretch at the line's break load), the servo's stiffness and the drum's
    inertia seen along the line. ``order``: the tendons in the YAML's order; ``driven``: the
    channel that gets a drive where it winds a pair the same way (see the module's docstring)."""
    out = []
    for c in channels:
        ts = tuple(t for t in order if t in printed.runs and printed.runs[t].channel == c)
        if not ts:
            continue
        travel = max(reach.get(t, 0.0) + break_load / springs[t] for t in ts)
        kp = SERVO_RATIO * sum(springs[t] for t in ts) / MM
        senses = tuple(printed.runs[t].sense for t in ts)
        drive = c == driven and len(ts) == 2 and len(set(senses)) == 1
        out.append(Drum(c, ts, senses, travel, kp, armature.get(c, 0.0), drive))
    return out


def _servos(root, tendon, drums: list) -> None:
    """The drums' servos: on the take-up's slide, or for a drum with a drive on the fixed tendons
    (into ``tendon``) that haul its pair together and drive it apart (see the module's docstring)."""
    act = ET.SubElement(root, "actuator")
    for d in drums:
        span = _v((-d.travel_mm * MM, d.travel_mm * MM))
        if not d.drive:
            ET.SubElement(act, "position", name=d.channel, joint=take_up(d, d.tendons[0]), kp=_f(d.kp_n_per_m),
                          ctrlrange=span)
            continue
        (a, b), (sa, sb) = d.tendons, d.senses
        for name, coefs in ((f"haul_{d.channel}", (0.5, 0.5)), (f"drive_{d.channel}", (0.5 * sa, -0.5 * sb))):
            f = ET.SubElement(tendon, "fixed", name=name)
            for t, c in zip((a, b), coefs):
                ET.SubElement(f, "joint", joint=take_up(d, t), coef=_f(c))
        ET.SubElement(act, "position", name=d.channel, tendon=f"haul_{d.channel}", kp=_f(d.kp_n_per_m),
                      ctrlrange=span)
        ET.SubElement(act, "position", name=f"{d.channel}_drive", tendon=f"drive_{d.channel}", kp=_f(d.kp_n_per_m),
                      ctrlrange=span)


def _state_setting(d: Drum, locked: dict, hauled: dict, baked: dict) -> tuple[float, dict]:
    """(ctrl in mm, each tendon's miss in mm) of one drum in one state."""
    if all(t in locked for t in d.tendons):
        u = float(np.mean([s * (hauled[t] - baked[t]) for t, s in zip(d.tendons, d.senses)]))
        return u, {t: hauled[t] - baked[t] - s * u for t, s in zip(d.tendons, d.senses)}
    if len(set(d.senses)) == 1:
        return -d.senses[0] * d.travel_mm, {}
    return 0.0, {}


def _keyframes(root, rig: Rig, locks: Locks, baked: dict) -> tuple[dict, dict]:
    """A keyframe per state (see the module's docstring): (state -> {channel: ctrl m}, state ->
    {tendon: what its drum's setting misses its lock by, mm})."""
    keys, miss = {}, {}
    n_hinges = sum((h.flex is not None) + (h.twist is not None) + (h.side is not None) for h in rig.hinges)
    frames = ET.SubElement(root, "keyframe")
    for s, ch in locks.states:
        ctrl, qpos, keys[s], miss[s] = [], [], {}, {}
        for d in rig.drums:
            u, m = _state_setting(d, [t for t in d.tendons if d.channel in ch], locks.hauled.get(s, {}), baked)
            ctrl += [u * MM, 0.0] if d.drive else [u * MM]          # a drive at 0
            qpos += [u * MM] * (len(d.tendons) if d.drive else 1)
            keys[s][d.channel] = u * MM
            miss[s].update(m)
        ET.SubElement(frames, "key", name=s, qpos=_v([0.0] * n_hinges + qpos), **({"ctrl": _v(ctrl)} if ctrl else {}))
    return keys, miss


def write_robot(name: str, printed: Printed, rig: Rig, locks: Locks, springs: dict, folder: Path,
                out: Path) -> Written:
    """robot.xml and its meshes into ``out`` (see the module's docstring); ``springs``: tendon -> N/mm."""
    states, hauled, drums = locks.states, locks.hauled, rig.drums
    root = build_xml(name, printed, rig, folder, out)
    notes, baked = [], {}
    for d in drums:
        first = next((hauled[s] for s, ch in states if d.channel in ch), {})
        opposite = len(set(d.senses)) > 1
        for t in d.tendons:
            baked[t] = first.get(t, 0.0) if opposite else 0.0
        if opposite:
            notes.append(f"drum {d.channel} winds {', '.join(d.tendons)} in opposite senses: its lock is built into "
                         f"their rest lengths, and no keyframe can slacken them both")
    pos = site_positions(printed, drums)
    tendon = ET.SubElement(root, "tendon")
    rest = {}
    for i, d in enumerate(drums):
        for t in d.tendons:
            sites = tendon_sites(printed, t)
            rest[t] = path_length([pos[s] for s in sites]) - baked[t]
            sp = ET.SubElement(tendon, "spatial", name=t, stiffness=_f(springs[t] / MM),
                               springlength=_v((0.0, rest[t] * MM)), width=_f(0.4 * MM),
                               rgba=_v(CHANNEL_RGBA[i % len(CHANNEL_RGBA)]))
            for s in sites:
                ET.SubElement(sp, "site", site=s)
    if not drums:
        notes.append("no drums (the tensioner has no layout): every tendon stays just taut at the straight robot, "
                     "and the keyframes cannot lock or slacken them")
    _servos(root, tendon, drums)
    keys, miss = _keyframes(root, rig, locks, baked)
    ET.indent(root)
    ET.ElementTree(root).write(out / "robot.xml", encoding="unicode", xml_declaration=False)
    return Written(drums, keys, miss, rest, baked, notes)


def reflected_inertia(printed: Printed, ratio: float) -> dict:
    """channel -> the drum's inertia felt along its line, kg: (I_wheel + ratio² I_worm) / r², each
    turned part's moment about its own axis (its file's z, as the tensioner's parts are built)."""
    out = {}
    for b in printed.tip:
        if b.role != "tensioner_wheel":
            continue
        c = b.entry.get("channel")
        r = printed.winding_radius_mm[b.name]

        def axial(part: Body) -> float:
            a = part.placement[:3, :3] @ np.array([0.0, 0.0, 1.0])
            return float(a @ part.inertia_g_mm2 @ a)

        worm = sum(axial(p) for p in printed.tip if p.role in ("tensioner_worm", "tensioner_drive")
                   and p.entry.get("channel") == c)
        out[c] = (axial(b) + ratio ** 2 * worm) / r ** 2 * KG
    return out
