"""From parameters to a buildable plan: holes per disk, merges, backbone holes (numpy only).

The plan is everything the part builders need, as frozen plain data, plus the design report
(shared and overlapping eyelets, tendons crossing the backbone) and the YAML's settings the
checks and outputs read (:mod:`hwgen.model.settings`): the stages after the model see the design
only through it. Nothing here imports CadQuery.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import DesignError
from ..params import Design
from . import kinematics as kin
from . import screws
from . import steel
from .bench_frame import FrameLayout, frame_layout, robot_envelope, torque_estimate
from .bench_rig import RigLayout, rig_layout
from .crossings import crossing_angles, in_strip_plane, strip_crossings
from .holes import hole_diameter
from .fixtures import JigLayout, MountLayout, base_length, disk_screw_region, jig_layout, mount_layout
from .fixing import disk_role, disk_thicknesses, hub_lengths, hub_spec, seats_for
from .routing import TendonPath, tendon_paths
from .settings import (AnchorsSettings, BomSettings, CheckSettings, ExperimentSettings, HubSettings, PlatesSettings,
                       ProcessSettings, RenderSettings, TendonMaterialSettings, TensionerSettings, anchors_settings,
                       bom_settings, check_settings, experiment_settings, hub_settings, plates_settings,
                       process_settings, render_settings, tendon_material_settings, tensioner_settings)
from .specs import BackboneHole, BackboneSpec, DiskSpec, Hole, Merge, slot_size
from .tensioner_layout import TensionerLayout, layout

SAME_POSITION_MM = 1e-6  # eyelets closer than this share one hole
STRIP_HOLE_SHARE = 0.5   # a strip hole is never wider than this share of the strip (the rest carries its bending):
#                          one that a tendon crossing the strip almost edge-on would need wider is cut this wide,
#                          and backbone.hole_angle fails, measuring what it lets through
SWEEP_STEP_DEG = 1.0     # resolution of the bending sweep used to size eyelets
AXIS_SNAP = 1e-6         # an eyelet axis component this small is zero: it slants the bore by under a microradian,
#                          and OCCT, cutting a bore slanted by 0.004 along x and 2e-9 along z, cut nothing at all


@dataclass(frozen=True, kw_only=True)
class Plan:
    """Everything later stages build and check from, resolved from the design: frozen values.
    The schema stays behind in the model: the YAML's settings the checks and outputs read are
    here as their sections (:mod:`hwgen.model.settings`), the rest in the layouts."""

    stations: tuple[float, ...]                       # each disk's mid-plane along the backbone, mm
    paths: list[TendonPath]                           # every tendon, mirrors expanded, in YAML order
    disks: tuple[DiskSpec, ...]
    backbone: BackboneSpec
    merges: tuple[Merge, ...]
    findings: tuple[str, ...] = field(default=())
    mount: MountLayout                                # the base mount, around the base disk's screws
    jig: JigLayout                                    # the assembly jig
    check: CheckSettings
    process: ProcessSettings
    tendon_material: TendonMaterialSettings
    tensioner: TensionerSettings                      # the channels; where the parts go: tensioner_layout
    hub: HubSettings                                  # disks.hub
    anchors: AnchorsSettings                          # disks.anchors
    render: RenderSettings
    bom: BomSettings
    plates: PlatesSettings
    experiment: ExperimentSettings                    # the push test (hwgen experiment, compare)
    tensioner_layout: TensionerLayout | None = None   # where the worm drives go, when they can be laid out
    tensioner_error: str | None = None                # why not, otherwise
    slot_clearance: float = 0.0                       # disks.slot_clearance: the strip's play in each slot, each side, mm
    frame: FrameLayout | None = None                  # the rotating base frame (base_frame.enabled)
    rig: RigLayout | None = None                      # the stiffness rig (rig.enabled)

    @property
    def min_wall(self) -> float:
        """The process's thinnest wall, mm."""
        return self.process.min_wall

    @property
    def tendon_diameter(self) -> float:
        """mm"""
        return self.tendon_material.diameter

    def require_tensioner_layout(self) -> TensionerLayout:
        """The tensioner layout, or a DesignError saying why this design has none."""
        if self.tensioner_layout is None:
            raise DesignError("tensioner", self.tensioner_error or "no tensioner layout")
        return self.tensioner_layout


def _sweep(design: Design) -> np.ndarray:
    a = design.disks.eyelets.sweep_deg
    n = int(round(2 * a / SWEEP_STEP_DEG)) + 1
    return kin.kappas_for_angles(np.linspace(-a, a, n), design.backbone.length)


def _rest_axes(design: Design, path: TendonPath) -> np.ndarray:
    """(N, 3) eyelet axes for one tendon in the straight robot."""
    n = len(path.points)
    if design.disks.eyelets.axis == "normal":
        return np.tile([0.0, 1.0, 0.0], (n, 1))
    into, out = kin.segment_directions_local(design.stations, path.points, 0.0)
    s = np.nan_to_num(into[0]) + np.nan_to_num(out[0])
    size = np.linalg.norm(s, axis=1, keepdims=True)         # no segment of any length at a disk: its normal
    return np.divide(s, size, out=np.tile([0.0, 1.0, 0.0], (n, 1)), where=size > 0)


Sweep = tuple[np.ndarray, np.ndarray]   # a tendon's (into, out_of) directions per disk over the sweep


def _sweeps(design: Design, paths: list[TendonPath]) -> dict[str, Sweep]:
    """Each tendon's segment directions at every disk over the bending sweep; they do not
    depend on any eyelet axis, so they are computed once per plan."""
    kappa = _sweep(design)
    return {p.name: kin.segment_directions_local(design.stations, p.points, kappa) for p in paths}


def _worst_angles(sweep: Sweep, axes: np.ndarray) -> np.ndarray:
    """(N,) largest angle between the tendon and the given axes over the sweep, rad."""
    into, out = sweep
    least = np.full(into.shape[1], np.inf)          # the smallest |cos|: arccos falls, so the largest angle
    for seg in (into, out):
        cos = np.abs(np.einsum("kni,ni->kn", seg, axes))
        least = np.fmin(least, np.min(np.where(np.isnan(cos), np.inf, cos), axis=0))
    return np.where(np.isinf(least), 0.0, np.arccos(np.clip(least, -1, 1)))


def _disk_spec(d: Design, i: int, paths: list[TendonPath], rest_axes: dict[str, np.ndarray],
               exits: dict[str, np.ndarray] | None = None, sweeps: dict[str, Sweep] | None = None,
               hubs: tuple[float, ...] | None = None) -> tuple[DiskSpec, list[Merge]]:
    """Disk i with a hole per eyelet position, and its shared and overlapping eyelets.

    ``exits`` (tip disk only): each tendon's direction onward from the disk in its frame,
    toward the tensioner, which is fixed to the tip and so does not turn with bending.
    ``sweeps``: the tendons' directions over the sweep, when the caller already has them; ``hubs``:
    every disk's hub length (:func:`hwgen.model.fixing.hub_lengths`), likewise.
    """
    sweeps = sweeps if sweeps is not None else _sweeps(d, paths)
    dk = d.disks
    slot_w, slot_h = slot_size(d.backbone.height, d.backbone.thickness, dk.slot_clearance)
    role, thick = disk_role(i, len(d.stations)), disk_thicknesses(d)[i]
    groups, holes = _eyelet_holes(d, i, paths, rest_axes, sweeps, exits)
    # a hole around tendons at one position is shared by design; one around several, an overlap
    merges = [Merge(i, h.tendons, "overlap" if _centre(g, i)[1] >= SAME_POSITION_MM else "shared")
              for g, h in zip(groups, holes) if len(g) > 1]
    seats, chambers = (), ()
    if role == "base":
        leaving = {p.name: rest_axes[p.name][i] for p in paths}
        found = [seats_for(d, h, thick, leaving) for h in holes if not h.in_slot]
        seats = tuple(s for group, _ in found for s in group)
        chambers = tuple(c for _, c in found if c is not None)
    hubs = hubs if hubs is not None else hub_lengths(d)
    hub = hub_spec(d, role, hubs[i], thick, (slot_w, slot_h), tuple(holes), {p.name: p.points[i] for p in paths},
                   {p.name: (sweeps[p.name][0][:, i], sweeps[p.name][1][:, i]) for p in paths})
    mounts = _mount_holes(d, role, holes, seats, chambers, (slot_w, slot_h), hub)
    spec = DiskSpec(index=i, y=float(d.stations[i]), role=role, thickness=thick, outer_diameter=dk.outer_diameter,
                    slot_width=slot_w, slot_height=slot_h, holes=tuple(holes),
                    edge_size=dk.eyelets.edge_size if dk.eyelets.edge == "chamfer" else 0.0, mount_holes=mounts,
                    hub=hub, seats=seats, seat_plate=dk.anchors.plate if seats else 0.0, seat_chambers=chambers)
    return spec, merges


def _eyelet_holes(d: Design, i: int, paths: list[TendonPath], rest_axes: dict[str, np.ndarray],
                  sweeps: dict[str, Sweep], exits: dict[str, np.ndarray] | None = None,
                  ) -> tuple[list[list[TendonPath]], list[Hole]]:
    """Disk i's eyelet holes and the tendons of each: one per position, sized for the worst angle
    over the sweep (and the exit, on the tip disk), holes that would run into each other merged."""
    proc = d.process
    slot_w, slot_h = slot_size(d.backbone.height, d.backbone.thickness, d.disks.slot_clearance)
    thick = disk_thicknesses(d)[i]
    exits = exits or {}
    groups: list[list[TendonPath]] = []
    for p in paths:
        for g in groups:
            if np.linalg.norm(g[0].points[i] - p.points[i]) < SAME_POSITION_MM:
                g.append(p)
                break
        else:
            groups.append([p])

    def hole(g: list[TendonPath]) -> Hole:
        own = [rest_axes[p.name][i] + exits.get(p.name, 0.0) for p in g]
        ax = np.sum([v / np.linalg.norm(v) for v in own], axis=0)
        ax /= np.linalg.norm(ax)
        tiny = (np.abs(ax) < AXIS_SNAP) & (ax != 0.0)
        if tiny.any():                  # (normalised again only then: the same bits as before otherwise)
            ax = np.where(tiny, 0.0, ax)
            ax /= np.linalg.norm(ax)
        alpha = max(_worst_angles((sweeps[p.name][0][:, i:i + 1], sweeps[p.name][1][:, i:i + 1]), ax[None])[0]
                    for p in g)
        for p in g:
            if p.name in exits:
                alpha = max(alpha, float(np.arccos(np.clip(abs(exits[p.name] @ ax), 0, 1))))
        (x, z), spread = _centre(g, i)
        dia = hole_diameter(d.tendon_material.diameter, thick, alpha, proc.hole_clearance, proc.min_hole) + 2 * spread
        in_slot = abs(x) <= slot_w / 2 and abs(z) <= slot_h / 2
        return Hole(x=x, z=z, axis=tuple(float(a) for a in ax), diameter=float(dia), tendons=tuple(p.name for p in g),
                    worst_angle_deg=float(np.degrees(alpha)), in_slot=in_slot)

    # Holes that would run into each other become one opening around all their tendons: two bores
    # that nearly coincide leave slivers no mesh closes, and the tendons could not be held apart anyway
    # (``eyelet.overlap`` reports it as the routing's fault, from the "overlap" merge recorded here).
    holes = [hole(g) for g in groups]
    while True:
        pair = next(((a, b) for a in range(len(holes)) for b in range(a + 1, len(holes))
                     if np.hypot(holes[a].x - holes[b].x, holes[a].z - holes[b].z)
                     < (holes[a].diameter + holes[b].diameter) / 2), None)
        if pair is None:
            break
        a, b = pair
        groups[a] += groups.pop(b)
        holes[a] = hole(groups[a])
        holes.pop(b)
    return groups, holes


def _centre(group: list[TendonPath], i: int) -> tuple[tuple[float, float], float]:
    """Where one hole for these tendons goes at station i, and how far the farthest tendon lies from
    it: the middle of their positions, or the first's when they all stand within SAME_POSITION_MM."""
    pts = np.array([p.points[i] for p in group], dtype=float)
    centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
    spread = float(np.max(np.linalg.norm(pts - centre, axis=1)))
    x, z = (float(v) for v in (centre if spread >= SAME_POSITION_MM else pts[0]))
    return (x, z), spread


def _mount_holes(d: Design, role: str, holes, seats, chambers, slot: tuple[float, float],
                 hub) -> tuple[tuple[float, float, float], ...]:
    """(x, z, diameter) of an end disk's screws: as the YAML gives them, else placed clear of the
    disk's eyelets, seats, slot and hub (:mod:`hwgen.model.screws`): in the base mount's jaws on
    the base disk, above and below the strip on the tip disk."""
    if role == "inner":
        return ()
    wall = d.process.min_wall
    if role == "base":
        dia, given = d.base_mount.screw_hole, d.base_mount.disk_screws
    else:
        dia, given = d.disks.tip_mount.hole_diameter, d.disks.tip_mount.positions
    if given is not None:
        return tuple((float(x), float(z), dia) for x, z in given)
    hub_half = None if hub is None else (slot[0] / 2 + hub.wall, slot[1] / 2 + hub.wall)
    keep = screws.disk_keepout(holes, d.disks.eyelets.edge_size, seats, chambers, (slot[0] / 2, slot[1] / 2),
                               hub_half, dia, wall)
    rim = screws.head_rim(d.disks.outer_diameter, dia, wall)
    if role == "base":
        bands, x_max = disk_screw_region(d)
    else:
        low = slot[1] / 2 + (hub.wall if hub is not None else 0.0) + screws.WASHER_OD / 2
        bands, x_max = ((low, rim), (-rim, -low)), rim
    return tuple((x, z, dia) for x, z in screws.place(keep, bands, x_max, rim))


def make_plan(design: Design, tensioner_record: dict | None = None) -> Plan:
    """Disks, strip and tensioner layout of a design, all as plain data.

    ``tensioner_record``: the tensioner layout's ``search`` record from a build of this very design
    (its manifest's): the arrangement it names is laid out again instead of searched for.

    The tip disk is planned twice: once to lay the tensioner out on it, then again with each
    tendon's exit toward its spool, so the tip eyelets follow the bisector of the incoming
    segment and the exit and are sized for both.
    """
    d = design
    paths = tendon_paths(d)
    rest_axes = {p.name: _rest_axes(d, p) for p in paths}
    sweeps = _sweeps(d, paths)
    hubs = hub_lengths(d)
    disks, merges = [], []
    for i in range(len(d.stations)):
        spec, m = _disk_spec(d, i, paths, rest_axes, sweeps=sweeps, hubs=hubs)
        disks.append(spec)
        merges += m
    bb_holes, findings = _backbone_holes(d, paths, disks)
    bb = d.backbone
    backbone = BackboneSpec(height=bb.height, thickness=bb.thickness, y_start=-base_length(d),
                            y_end=bb.length + bb.extra_tip, holes=tuple(bb_holes), density_g_cm3=bb.density_g_cm3,
                            length=bb.length, extra_tip=bb.extra_tip, modulus_gpa=bb.modulus_gpa,
                            shear_modulus_gpa=bb.shear_modulus_gpa, allowable_stress_mpa=bb.allowable_stress_mpa,
                            loss_factor=bb.loss_factor)
    first = Plan(stations=tuple(d.stations), paths=paths, disks=tuple(disks), backbone=backbone,
                 merges=tuple(merges), findings=tuple(findings),
                 mount=mount_layout(d, [(x, z) for x, z, _ in disks[0].mount_holes]), jig=jig_layout(d),
                 check=check_settings(d), process=process_settings(d), tendon_material=tendon_material_settings(d),
                 tensioner=tensioner_settings(d), hub=hub_settings(d), anchors=anchors_settings(d),
                 render=render_settings(d), bom=bom_settings(d), plates=plates_settings(d),
                 experiment=experiment_settings(d), slot_clearance=d.disks.slot_clearance)
    try:
        lay = layout(d, paths, disks[-1], tensioner_record)
    except ValueError as e:
        return _bench(d, replace(first, tensioner_error=str(e)))
    exits = {r.tendon: np.subtract(r.end, r.start) / r.length for r in lay.runs}
    tip, tip_merges = _disk_spec(d, len(disks) - 1, paths, rest_axes, exits, sweeps, hubs)
    merges = [m for m in merges if m.station != tip.index] + tip_merges
    return _bench(d, replace(first, disks=(*disks[:-1], tip), merges=tuple(merges), tensioner_layout=lay))


def _bench(d: Design, plan: Plan) -> Plan:
    """The plan with the base frame and the rig laid out where the design asks for them."""
    frame = rig = None
    if d.base_frame.enabled:
        metal = steel.total(steel.tip_pieces(plan))
        torque = torque_estimate(d, plan.tensioner_layout, metal[:2], plan.process.density_g_cm3)
        frame = frame_layout(d, plan.mount, robot_envelope(d.disks.outer_diameter / 2, plan.tensioner_layout), torque)
    if d.rig.enabled:
        k = min(d.experiment.first_disk, len(plan.disks)) - 1
        rig = rig_layout(d, plan.stations, plan.disks[k].thickness, frame)
    return replace(plan, frame=frame, rig=rig) if frame or rig else plan


def _backbone_holes(d: Design, paths: list[TendonPath], disks: list[DiskSpec]):
    """Holes the strip needs where tendons cross its plane (z = 0) within its height,
    each sized for the steepest angle the tendon meets the strip at over the sweep, at most
    STRIP_HOLE_SHARE of the strip (never less than the straight hole the tendon passes)."""
    half_h = d.backbone.height / 2
    kappa = _sweep(d)
    out, findings = [], []
    for p in paths:
        in_slot = {i for i, disk in enumerate(disks)
                   if any(p.name in h.tendons and h.in_slot for h in disk.holes)}
        for station, x, y in strip_crossings(d.stations, p.points, half_h, in_slot):
            beta = float(crossing_angles(d.stations, p.points, station, kappa).max())
            dia = hole_diameter(d.tendon_material.diameter, d.backbone.thickness, beta,
                                d.process.hole_clearance, d.process.min_hole)
            least = hole_diameter(d.tendon_material.diameter, d.backbone.thickness, 0.0,
                                  d.process.hole_clearance, d.process.min_hole)
            dia = max(least, min(dia, STRIP_HOLE_SHARE * d.backbone.height))
            out.append(BackboneHole(p.name, float(station), float(x), float(y), float(dia)))
        findings += [f"{p.name}: runs in the backbone plane between stations {i} and {i + 1}"
                     for i in in_strip_plane(p.points, half_h)]
    return out, findings


def eyelet_holes(design: Design, paths: list[TendonPath], disks, rest_axes: dict[str, np.ndarray] | None = None,
                 sweeps: dict[str, Sweep] | None = None) -> dict[int, tuple[Hole, ...]]:
    """The eyelet holes of the given disks as :func:`make_plan` makes them (shared ones one hole,
    holes that would run into each other merged), without the tip disk's turn toward the
    tensioner: for callers that size most holes their own, faster way and need the plan's answer
    where tendons run into each other. ``rest_axes`` and ``sweeps`` (by tendon name), when the
    caller has them."""
    rest_axes = rest_axes or {p.name: _rest_axes(design, p) for p in paths}
    sweeps = sweeps or _sweeps(design, paths)
    return {int(i): tuple(_eyelet_holes(design, int(i), paths, rest_axes, sweeps)[1]) for i in disks}
