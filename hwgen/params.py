"""The parameter YAML: its schema (pydantic v2) and loading with clear errors.

Units are millimetres and degrees throughout; every field says so in its description.
Coordinates are the paper's: the backbone runs along +y from the base disk at y = 0,
x spans the backbone's height, z its thickness; positive curvature bends toward +z.

Reading (:func:`read`) takes the file and the bases it builds on (:mod:`hwgen.designfile`), then
two passes: pydantic checks each field's type and range, then :func:`design_problems` checks what
spans fields (station counts, channels, names). Every fault of a pass is reported at once, through
one :class:`InputError` that names, for each, the file that wrote the field, the field path and
what is wrong and allowed (an unknown key with the nearest known one; a rule over several fields
blames the one the design's own file wrote). What needs the model to decide (eyelets inside the
disk, gears that can be made) is checked next, by :mod:`hwgen.model.feasibility`;
:func:`hwgen.pipeline.load` runs both.
"""
from __future__ import annotations

import functools
import re
import types
import typing
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, Field, PrivateAttr, ValidationError, model_validator

from . import designfile, yamlfile
from .errors import InputError, Problem, clip, echo, nearest
from .fasteners import size as _fastener
from .params_base import _Model
from .params_bench import BaseFrame, Rig
from .params_experiment import Experiment

M3_CLEARANCE = _fastener("clearance hole", "M3", "normal")     # ISO 273 normal series (data/fasteners.csv)

SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$")
MAX_MM = 10_000.0        # no length or coordinate of a design is beyond 10 m
MAX_TENDONS = 64
MAX_CHANNELS = 16
SUGGESTED = 25           # unknown keys of one file matched against the whole schema (of 2 000: the first 25)
UNKNOWN_CHANNEL = "the unknown channel"       # a channel left with no tendon may follow from a misspelt one

Length = Annotated[float, Field(gt=0, le=MAX_MM, allow_inf_nan=False)]
NonNegLength = Annotated[float, Field(ge=0, le=MAX_MM, allow_inf_nan=False)]
Coord = Annotated[float, Field(ge=-MAX_MM, le=MAX_MM, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]   # a finite number; bounds given per field
Name = Annotated[str, Field(min_length=1, max_length=64)]
Angle = Annotated[float, Field(gt=0, le=360, allow_inf_nan=False)]   # a bending sweep ±deg


class Backbone(_Model):
    """The carbon-fibre strip (Table I)."""

    length: Length = Field(description="L: length between the base and tip disk mid-planes, mm")
    height: Length = Field(description="h: strip width along x, mm")
    thickness: Length = Field(description="t: strip thickness along z, mm")
    extra_base: NonNegLength | None = Field(None, description="strip length below the base disk's mid-plane for "
                                                              "the base mount's jaws, mm (default: the least the "
                                                              "jaws need)")
    extra_tip: NonNegLength = Field(0.0, description="strip length beyond the tip disk for the tensioner clamp, mm")
    density_g_cm3: Annotated[float, Field(gt=0.3, le=3.0, allow_inf_nan=False)] = Field(
        1.40, description="density of the strip's laminate, g/cm³")
    modulus_gpa: Finite = Field(50.0, gt=1, le=400,
                                description="E: the laminate's modulus in bending (thin direction), GPa")
    allowable_stress_mpa: Finite = Field(167.0, gt=0, le=3000,
                                         description="largest bending stress allowed in the strip, MPa")
    shear_modulus_gpa: Finite = Field(4.0, gt=0.1, le=200,
                                      description="G: the laminate's in-plane shear modulus, for the strip's "
                                                  "torsion (G·h·t³/3), GPa")
    loss_factor: Finite = Field(0.01, gt=0, lt=1, description="η: the laminate's loss factor in bending, for the sim's damping")


class Eyelets(_Model):
    """How eyelet holes are sized and shaped."""

    axis: Literal["bisector", "normal"] = Field(
        "bisector", description="hole axis: bisector of the tendon's straight segments, or normal to the disk")
    edge: Literal["chamfer", "none"] = Field("chamfer", description="edge break at both hole ends")
    edge_size: NonNegLength = Field(0.2, description="chamfer leg at the hole rim, mm")
    sweep_deg: Angle = Field(90.0, description="bending sweep ±deg over which the worst tendon angle is taken")


class Hub(_Model):
    """The hub around each disk's slot: it holds the disk square to the strip."""

    max_tilt_deg: Finite = Field(0.5, gt=0, le=10,
                                 description="largest tilt of a disk on the strip about x (pitch along the backbone) "
                                             "the slot's clearance may allow; sizes the hub and limits the check, deg")
    length: Length | None = Field(None, description="length along the backbone over which the slot holds the strip, "
                                                    "disk included, mm (default: from max_tilt_deg)")
    wall: Length = Field(1.2, description="wall of the hub around the slot, mm")
    glue_port_diameter: Length = Field(1.5, description="hole through the hub's wall into the slot for the adhesive, "
                                                        "mm")


class Anchors(_Model):
    """Where the tendons end at the base disk: a seat per tendon in a plate on its outer face."""

    plate: Length = Field(1.2, description="thickness of the seat plate on the base disk's outer face, mm")
    adhesive: str = Field("thin cyanoacrylate (low viscosity, wicks into the slot)",
                          description="what fixes each disk to the strip through its glue port")


class TipMount(_Model):
    """Bolt pattern on the tip disk that the tensioner housing fastens to."""

    hole_diameter: Length = Field(M3_CLEARANCE, description="clearance hole for the screws (M3 normal fit), mm")
    positions: tuple[tuple[Coord, Coord], ...] | None = Field(
        None, description="hole centres (x, z) on the tip disk, mm (default: four, placed clear of this "
                          "robot's tip eyelets, slot and hub)")


class Disks(_Model):
    """The tendon-support disks."""

    count: int = Field(ge=2, le=200, description="N: number of disks, base (i = 0) to tip (i = N-1)")
    spacing: Length | None = Field(None, description="ΔL: equal spacing between disks, mm (or give stations; "
                                                     "neither: backbone.length / (count - 1))")
    stations: tuple[Coord, ...] | None = Field(None, description="explicit y_i of every disk, mm, increasing")
    thickness: Length = Field(description="thickness of the inner disks along y, mm")
    end_thickness: Length = Field(description="thickness of the base and tip disks, mm")
    outer_diameter: Length = Field(description="outer diameter, mm")
    slot_clearance: NonNegLength = Field(description="clearance per side between strip and slot, mm")
    eyelets: Eyelets = Field(default_factory=Eyelets)
    hub: Hub = Field(default_factory=Hub)
    anchors: Anchors = Field(default_factory=Anchors)
    tip_mount: TipMount = Field(default_factory=TipMount)

    @model_validator(mode="after")
    def _one_station_rule(self):
        if self.spacing is not None and self.stations is not None:
            raise ValueError("give 'spacing' or 'stations', not both")
        return self


class RoutingFunction(_Model):
    """A fully supported path of eq. (3), sampled at the stations (s = y_i).

    straight: (x, z) = (x0, z0)
    cosine:   the `axis` coordinate is a·cos(kπs/L + φ); the other is its offset
    helix:    (x, z) = a·(sin(kπs/L + φ), cos(kπs/L + φ)) plus the offsets
    """

    kind: Literal["straight", "cosine", "helix"]
    a: Coord = Field(0.0, description="amplitude a, mm")
    k: Annotated[float, Field(ge=-1000, le=1000, allow_inf_nan=False)] = Field(
        1.0, description="number of half waves over L (the k in kπs/L)")
    axis: Literal["x", "z"] = Field("z", description="cosine only: the coordinate that varies")
    phase_deg: Annotated[float, Field(ge=-3600, le=3600, allow_inf_nan=False)] = Field(
        0.0, description="phase φ added to kπs/L, deg")
    x0: Coord = Field(0.0, description="constant offset in x, mm")
    z0: Coord = Field(0.0, description="constant offset in z, mm")


class Routing(_Model):
    table: tuple[tuple[Coord, Coord], ...] | None = Field(
        None, description="one (x, z) per station, mm, as in Table II; used for the geometry when given")
    function: RoutingFunction | None = Field(None, description="eq. (3) path; sampled at the stations")
    mirror: bool = Field(False, description="also route this tendon reflected through the backbone plane (z -> -z)")
    mirror_name: Name | None = Field(None, description="name of the mirrored tendon (default: <name>_m)")

    @model_validator(mode="after")
    def _has_a_path(self):
        if self.table is None and self.function is None:
            raise ValueError("give a 'table', a 'function' or both")
        return self


class Tendon(_Model):
    name: Name = Field(description="tendon name, used in reports and labels")
    channel: Name = Field(description="tensioner channel the tendon ends on")
    routing: Routing
    budget_mm: NonNegLength | None = Field(
        None, description="allowed length change over the sweep, mm (default: 0.2 unless on the actuating channel)")
    termination: Termination | None = Field(
        None, description="how this tendon ends at the base disk (default: tendon_material.termination)")
    pretension_n: Finite | None = Field(
        None, ge=0, le=10_000,
        description="tension the tendon is pulled to at its turn in the tensioning protocol, N (a mirrored tendon gets "
                    "the same); default: the paper's protocol finds it (hwgen.model.protocol: the tension that holds "
                    "the backbone straightest, not under check.taut_floor_n)")

    @property
    def names(self) -> tuple[str, ...]:
        """Its own name, and its mirror's when it is mirrored (``routing.mirror_name``, else the name + "_m")."""
        if not self.routing.mirror:
            return (self.name,)
        return (self.name, self.routing.mirror_name or f"{self.name}_m")


class Termination(_Model):
    """How a tendon ends at the base disk: a knot, or a crimp sleeve squeezed onto it."""

    kind: Literal["knot", "crimp"] = Field("knot", description="knot tied in the line, or a crimp sleeve")
    diameter: Length = Field(1.5, description="knot: its size across; crimp: the sleeve's outer diameter after "
                                              "crimping, mm")
    length: Length | None = Field(None, description="crimp: the sleeve's length, mm")
    name: str | None = Field(None, description="crimp: what to buy (maker, part number)")

    @model_validator(mode="after")
    def _crimp_has_size(self):
        if self.kind == "crimp" and self.length is None:
            raise ValueError("a crimp sleeve needs its 'length'")
        return self


class TendonMaterial(_Model):
    name: str = Field(description="what the tendon is")
    diameter: Length = Field(description="d: tendon diameter, mm")
    break_load: Length = Field(description="break load, N")
    termination: Termination = Field(default_factory=Termination,
                                     description="how every tendon ends at the base disk (a tendon may override it)")
    axial_stiffness_n: Finite = Field(2000.0, gt=1, le=1e7,
                                      description="EA: the line's effective axial stiffness at working loads "
                                                  "(force per unit strain), N")
    tie_off_compliance_mm_per_n: Finite = Field(0.05, ge=0, le=10,
                                                description="stretch per newton of a tendon's two ends together: "
                                                            "its knot in its seat and its wraps on the drum, "
                                                            "with the drive behind it, mm/N")
    eyelet_friction: Finite | None = Field(
        None, ge=0, le=2,
        description="coefficient of friction of the line in an eyelet (capstan: a segment slips once the tension "
                    "on one side exceeds e^(μθ) times the other's, θ the angle the line turns there); the "
                    "stiffness is then reported for it between the frictionless and the stuck bounds")


class Process(_Model):
    name: str = Field(description="printer and material")
    technology: Literal["SLA", "FDM"] = Field(
        description="SLA (resin: brittle, no heat-set inserts) or FDM (thermoplastic: heat-set inserts work)")
    material: str = Field(description="printed material, a row of hwgen/data/materials.csv (its density with "
                                      "its reason): standard_resin, tough_resin, PLA, PETG")
    density_g_cm3: Annotated[float, Field(gt=0.3, le=3.0, allow_inf_nan=False)] | None = Field(
        None, description="overrides the material's density from the table, g/cm³")
    fill_fraction: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = Field(
        1.0, description="share of a part's volume that is material (1 for SLA; an FDM part's effective fill)")
    min_wall: Length = Field(description="thinnest wall that prints reliably, mm")
    min_hole: Length = Field(description="smallest through hole that prints open, mm")
    hole_clearance: NonNegLength = Field(description="added to a hole's diameter over what passes through it, mm")
    build_volume: tuple[Length, Length, Length] = Field(description="printer build volume x, y, z, mm")
    position_sigma: Annotated[float, Field(ge=0, le=5, allow_inf_nan=False)] = Field(
        0.05, description="scatter of a printed hole's centre, per axis in the hole's plane (Gaussian σ), mm")
    diameter_sigma: Annotated[float, Field(ge=0, le=5, allow_inf_nan=False)] = Field(
        0.03, description="scatter of a printed hole's diameter (Gaussian σ), mm")


class Tensioner(_Model):
    """The tensioner at the tip: one channel per independently tensioned group."""

    channels: tuple[Name, ...] = Field(min_length=1, description="channel names, one worm drive each")
    actuating_channel: Name = Field(description="the channel of the actuating (antagonistic) tendons")
    module: Finite = Field(1.25, ge=0.3, le=3.0,
                          description="axial module of the worm = transverse module of the wheel, mm")
    worm_starts: int = Field(1, ge=1, le=4, description="thread starts z1 of the worm")
    wheel_teeth: int = Field(24, ge=6, le=120, description="teeth z2 of the worm wheel")
    worm_pitch_diameter: Finite = Field(14.0, gt=0, le=40, description="d1: pitch diameter of the worm, mm")
    pressure_angle_deg: Finite = Field(20.0, ge=10, le=30, description="axial pressure angle of the worm thread, deg")
    face_width: Finite = Field(8.0, gt=0, le=30, description="face width of the wheel, mm")
    worm_length: Finite = Field(24.0, gt=0, le=60, description="threaded length of the worm, mm")
    center_offset: Finite = Field(0.1, ge=0, le=0.5,
                                  description="added to the centre distance (d1 + d2)/2: the flanks' clearance "
                                              "(backlash) follows from it, mm")
    friction_coefficient: Finite = Field(0.1, gt=0, le=1,
                          description="μ of the worm/wheel material pair (self-locking needs lead angle < atan(μ / cos α_n))")
    spool_diameter: Finite = Field(10.0, gt=0, le=40,
                          description="diameter of the spool core the tendon winds on, mm")
    resin_strength: Finite = Field(35.0, gt=0, le=200, description="tensile strength of the printed resin, MPa")
    safety_factor: Finite = Field(2.0, ge=1, le=10,
                          description="required ratio of resin strength to the Lewis tooth stress, and of the "
                                      "Hertz allowable to the contact pressure, at the tendon break load")
    hex_key: Finite = Field(2.5, gt=0, le=6, description="across-flats of the hex key that turns each worm, mm")
    shaft_diameter: Finite = Field(3.0, gt=0, le=6,
                          description="diameter of the ISO 2338 dowel pins the wheels and worms turn on, mm")
    press_fit: Finite = Field(0.05, ge=0, le=0.3,
                          description="diametral interference of a pin pressed into a printed bore, mm")
    running_fit: Finite = Field(0.2, ge=0, le=0.6,
                          description="diametral clearance of a printed part turning on a pin or in a bore, mm")
    winding: dict[Name, Literal["same", "opposite"]] = Field(
        default_factory=dict,
        description="per channel with two or more tendons: 'same' winds them in one sense, so the worm "
                    "pre-tensions them together; 'opposite' hauls one in as it pays the other out, so the "
                    "worm bends the robot (default 'same')")
    tendon_clearance: Finite = Field(0.5, ge=0, le=5,
                                     description="least gap between a tendon's free span and any part it must "
                                                 "not touch, beyond the tendon's own diameter, mm")
    max_exit_deg: Finite = Field(20.0, gt=0, le=60,
                                 description="largest turn a tendon may make at its tip eyelet toward its "
                                             "spool, deg (the tip eyelet is sized for it)")


class BaseMount(_Model):
    """The printed clamp that holds the strip's base length; the base disk bolts to it, it bolts to a table."""

    bolt_pattern: Literal["M6_25mm", "quarter20_1in"] = Field(
        "M6_25mm", description="table holes: M6 on a 25 mm grid (metric breadboard) or 1/4-20 on a 1 in grid")
    disk_screws: tuple[tuple[Coord, Coord], ...] | None = Field(
        None, description="(x, z) of the screws that fasten the base disk to the mount, mm (default: four, "
                          "placed clear of this robot's eyelets, seats, slot and hub)")
    screw_hole: Length = Field(M3_CLEARANCE, description="clearance hole for those screws and the jaw screws (M3), mm")
    table_clearance: Length = Field(4.0, description="between the base disk's rim and the table, mm")
    max_tip_share: Finite = Field(0.01, gt=0, le=1,
                                  description="largest share of the own-weight tip sag the mount's give may add")


class Jig(_Model):
    """The assembly jig: holds every disk square at its station while the adhesive cures."""

    clearance: NonNegLength = Field(0.05, description="per side, between a disk and its slot in the jig, mm")
    wall: Length = Field(8.0, description="thickness of the jig's comb walls, mm")
    floor: Length = Field(6.0, description="thickness of the jig's floor, mm")
    station_tolerance_mm: Length = Field(0.15, description="how far from its station the jig may set a disk, mm")


class CheckSettings(_Model):
    """How `hwgen check` sweeps the bending angle and what it tolerates."""

    max_angle_deg: Angle | None = Field(
        None, description="tendon lengths are swept from -max to +max bending, deg (default: the eyelets' "
                          "disks.eyelets.sweep_deg; never more, or the eyelets fail the angle check by design)")
    step_deg: Annotated[float, Field(ge=0.1, le=90, allow_inf_nan=False)] = Field(
        1.0, description="step of the bending sweep, deg")
    position_tol_mm: Length = Field(0.01, description="largest eyelet offset from design intent, mm")
    interference_tol_mm3: Length = Field(0.01, description="largest intersection volume of two parts, mm³")
    overstress: Literal["error", "warning"] = Field(
        "error", description="what a strip stress over backbone.allowable_stress_mpa in the own-weight state is")
    samples: int = Field(10_000, ge=0, le=100_000,
                         description="most as-built samples of the tendon-length Monte Carlo (0: the nominal print "
                                     "only); it stops sooner when every budgeted tendon's statistic is known well "
                                     "enough (robust_confidence, robust_precision_mm)")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="seed of the Monte Carlo")
    robust: Literal["p50", "p90", "p95", "p99", "max"] = Field(
        "p95", description="statistic of the as-built samples' largest length change a budgeted tendon is judged on")
    robust_confidence: Annotated[float, Field(gt=0.5, lt=1, allow_inf_nan=False)] = Field(
        0.95, description="confidence of the interval on each budgeted tendon's statistic (order statistics, no "
                          "assumed distribution) that decides when the Monte Carlo has drawn enough samples")
    robust_precision_mm: NonNegLength = Field(
        0.01, description="the Monte Carlo stops once every budgeted tendon's interval lies clear of its budget "
                          "or is no wider than this, mm (0: only clear of the budget)")
    robust_severity: Literal["error", "warning"] = Field(
        "error", description="what a budgeted tendon over its budget at that statistic is")
    shared_sliding: Literal["error", "warning"] = Field(
        "error", description="what a tendon of the actuating channel sliding through one opening with another "
                             "tendon is (eyelet.shared_sliding): the lines rub there, and no model here says "
                             "what that does")
    taut_floor_n: Finite = Field(0.5, ge=0, le=1000,
                                 description="least tension a locked stiffening tendon may fall to over the "
                                             "bending sweep and still count as taut, N")
    tendon_safety_factor: Finite = Field(3.0, ge=1, le=20,
                                         description="required ratio of tendon_material.break_load to the "
                                                     "greatest tension a tendon reaches over the sweep")
    max_coupling: Finite = Field(0.2, ge=0, le=100,
                                 description="largest rise, as a share, of the actuating tension needed at the "
                                             "sweep's end when the stiffening tendons are locked, over the "
                                             "tension needed with them slack")
    working_tension_n: Finite = Field(5.0, gt=0, le=10_000,
                                      description="tension a tendon without pretension_n is locked at (a stiffening "
                                                  "tendon) or held at by the drive (an actuating one) in the tension "
                                                  "checks' bending sweep, N")
    straight_within_mm: Finite = Field(1.0, gt=0, le=100,
                                       description="tensioning protocol: a stiffening channel is pulled to the least "
                                                   "tension that brings the disks within this of the straightest it "
                                                   "can hold them (root mean square off the straight line), mm")
    stiffness_push_n: Finite = Field(1.0, gt=0, le=1000,
                                     description="the push the stiffness with eyelet friction (capstan) is taken "
                                                 "over, at the tip, N")
    min_stiffening: Finite = Field(
        1.5, ge=1, le=100,
        description="what the stiffening tendons are for: the least tip stiffness with every tendon locked over the "
                    "actuating pair's alone (gravity -z, frictionless, tensioned by the protocol) the design may have "
                    "(default 1.5: tendons, drums and tensioning that add less than half the pair's own stiffness do "
                    "not earn their place; the paper's robot measured 4.85)")
    min_torsion_stiffening: Finite = Field(
        1.0, ge=0, le=100,
        description="the least tip torsional stiffness with every tendon locked over the actuating pair's alone, "
                    "as min_stiffening (default 1.0: locking the stiffening tendons must not leave the tip softer in "
                    "torsion than the pair alone)")


class Render(_Model):
    """Pictures and drawing (`hwgen render`)."""

    explode_mm: NonNegLength = Field(20.0, description="exploded views: gap added between neighbouring disks; "
                                                       "other parts move this far from their assembly, mm")
    bend_deg: Annotated[float, Field(ge=-360, le=360, allow_inf_nan=False)] | None = Field(
        None, description="bending angle θ = κL of the bent picture, deg (default: the checks' sweep angle, "
                          "check.max_angle_deg, else disks.eyelets.sweep_deg: the design is drawn as far as it "
                          "is checked)")
    width_px: int = Field(1800, ge=400, le=8000, description="width of the PNG pictures, px")


class Bom(_Model):
    """The bill of materials: what is added to each tendon's rest length when it is cut."""

    tie_off_mm: NonNegLength = Field(60.0, description="tendon added at the base for the knot, mm")
    spool_mm: NonNegLength = Field(150.0, description="tendon added at the tip to reach and wrap the tensioner, mm")


class Plates(_Model):
    """Print plates (`hwgen plates`): how the printed parts are laid out on the printer's plate."""

    gap_mm: NonNegLength = Field(3.0, description="clear space between two parts on a plate, mm")
    edge_margin_mm: NonNegLength = Field(2.0, description="clear space between a part and the plate's edge, mm")
    sla_tilt_deg: Annotated[float, Field(ge=0, le=60, allow_inf_nan=False)] = Field(
        30.0, description="SLA: tilt of a part printed angled on supports, deg")
    flat_contact_fraction: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = Field(
        0.5, description="SLA: a part whose face on the plate covers at least this share of its footprint "
                         "prints flat on the plate; a smaller one prints tilted on supports")


class Coupon(_Model):
    """The calibration coupon: the design's eyelet hole and strip slot in steps around their values."""

    steps: int = Field(2, ge=1, le=5, description="steps on each side of the design value (2: five sizes)")
    hole_step_mm: Annotated[float, Field(gt=0, le=0.5, allow_inf_nan=False)] = Field(
        0.05, description="change of the hole diameter from one step to the next, mm")
    slot_step_mm: Annotated[float, Field(gt=0, le=0.5, allow_inf_nan=False)] = Field(
        0.025, description="change of the slot's clearance a side from one step to the next, mm")
    slot_length_mm: Annotated[float, Field(ge=3, le=60, allow_inf_nan=False)] = Field(
        10.0, description="length of each test slot (the strip's edge goes in), mm")
    text_mm: Annotated[float, Field(ge=1.5, le=10, allow_inf_nan=False)] = Field(
        2.5, description="height of the engraved labels, mm")
    engrave_mm: Annotated[float, Field(gt=0, le=2, allow_inf_nan=False)] = Field(
        0.4, description="depth of the engraved labels, mm")


class Design(_Model):
    design: Name = Field(description="design name; names the output folder")
    backbone: Backbone
    disks: Disks
    tendon_material: TendonMaterial
    process: Process
    tensioner: Tensioner
    tendons: tuple[Tendon, ...] = Field(min_length=1, max_length=MAX_TENDONS)
    base_mount: BaseMount = Field(default_factory=BaseMount, description="the clamp the robot is held by")
    jig: Jig = Field(default_factory=Jig, description="the assembly jig")
    check: CheckSettings = Field(default_factory=CheckSettings, description="validation sweep and tolerances")
    render: Render = Field(default_factory=Render, description="pictures and drawing")
    bom: Bom = Field(default_factory=Bom, description="bill of materials: tendon cut allowances")
    plates: Plates = Field(default_factory=Plates, description="print plates: spacing and SLA orientation")
    coupon: Coupon = Field(default_factory=Coupon, description="the calibration coupon's steps and labels")
    experiment: Experiment = Field(default_factory=Experiment, description="the push test: hwgen experiment, compare")
    base_frame: BaseFrame = Field(default_factory=BaseFrame, description="the rotating base frame (Fig. 3)")
    rig: Rig = Field(default_factory=Rig, description="the stiffness rig: load-cell bracket, push block, support")

    @property
    def stations(self) -> tuple[float, ...]:
        d = self.disks
        if d.stations is not None:
            return tuple(d.stations)
        if d.spacing is None:            # equal gaps over the backbone's length
            return tuple(i * self.backbone.length / (d.count - 1) for i in range(d.count))
        return tuple(i * d.spacing for i in range(d.count))

    @property
    def check_angle_deg(self) -> float:
        """±deg of `hwgen check`'s bending sweep: check.max_angle_deg, else the eyelets' sweep."""
        if self.check.max_angle_deg is not None:
            return self.check.max_angle_deg
        return self.disks.eyelets.sweep_deg


class LoadedDesign(_Model):
    """A validated design, where it came from (the file, and the bases it builds on), and what
    the reader warns about (deprecated keys, values far off their usual range)."""

    design: Design
    source: str
    sha256: str
    warnings: tuple[str, ...] = ()
    bases: tuple[str, ...] = ()           # the file's base, its base's base, ... (empty: no base)
    _layers: designfile.Layers | None = PrivateAttr(None)

    @property
    def name(self) -> str:
        """The design's name (the YAML's ``design`` key): it names the output folder."""
        return self.design.design

    @property
    def layers(self) -> designfile.Layers:
        """The merged document and where each of its values came from."""
        if self._layers is None:
            return designfile.single(self.design.model_dump(mode="json", exclude_defaults=True), self.source)
        return self._layers


def _path(loc) -> str:
    out = ""
    for part in loc:
        out = yamlfile.join(out, part if isinstance(part, int) else clip(str(part)))
    return out


# ---------------------------------------------------------------- reading a design

def read(path: str | Path) -> LoadedDesign:
    """Read a design YAML (and the bases it builds on) and check it against the schema; raise
    :class:`InputError` naming every fault at once."""
    path = Path(path)
    layers = designfile.read_layers(path)
    design = validate(layers.doc, path, layers)
    hinted = designfile.hints(layers.doc)
    warnings = list(layers.warnings) + [f"{layers.file_of(p)}: {p}: {h}" for p, h in hinted.items()]
    loaded = LoadedDesign(design=design, source=str(path), sha256=layers.sha256, warnings=tuple(warnings),
                          bases=tuple(str(f) for f in layers.files[1:]))
    loaded._layers = layers
    return loaded


def document(raw: bytes, path: str | Path) -> tuple[dict, list[str]]:
    """A design file's bytes as its mapping of sections (:func:`hwgen.designfile.document`)."""
    return designfile.document(raw, path)


def unwrap(ann):
    """The type inside Optional / Annotated: (kind, inner) with kind "model", "seq", "dict" or "leaf"."""
    while True:
        origin = typing.get_origin(ann)
        if origin is Annotated:
            ann = typing.get_args(ann)[0]
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(ann) if a is not type(None)]
            ann = args[0] if len(args) == 1 else ann
            if len(args) != 1:
                return "leaf", ann
        else:
            break
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return "model", ann
    if typing.get_origin(ann) in (tuple, list):
        args = typing.get_args(ann)
        return "seq", (args[0] if args else typing.Any)
    if typing.get_origin(ann) is dict:
        return "dict", ann
    return "leaf", ann


def _field_at(model: type[BaseModel], loc) -> tuple[type[BaseModel] | None, object]:
    """(the model whose field ``loc`` ends in, that field's FieldInfo) walking the schema; None where
    the path leaves it."""
    kind, cur, info, parent = "model", model, None, None
    for key in loc:
        if kind == "model" and isinstance(key, str) and key in cur.model_fields:
            parent, info = cur, cur.model_fields[key]
            kind, cur = unwrap(info.annotation)
        elif kind == "seq" and isinstance(key, int):
            kind, cur = unwrap(cur)
        else:
            return (cur if kind == "model" and key is loc[-1] else None), None
    return parent, info


@functools.cache
def _fields_everywhere(model: type[BaseModel], prefix: str = "") -> dict[str, list[str]]:
    """key -> every dotted path of the schema that ends in it (a list's items marked ``[]``)."""
    out: dict[str, list[str]] = {}
    for name, info in model.model_fields.items():
        name = info.alias or name                 # as a file writes it (a tune's goal: pass)
        path = f"{prefix}.{name}" if prefix else name
        out.setdefault(name, []).append(path)
        kind, inner = unwrap(info.annotation)
        if kind == "seq":
            kind, inner = unwrap(inner)
            path += "[]"
        if kind == "model":
            for k, v in _fields_everywhere(inner, path).items():
                out.setdefault(k, []).extend(v)
    return out


def _unknown_key(model: type[BaseModel], loc, missing: set[str], far: bool = True) -> tuple[str, str | None]:
    """What to say of an unknown key: a key of its mapping it is a slip of (difflib), the full path
    of a field of that name in another section, or of one it is a slip of (``far``); else the keys
    its mapping takes. (The message, the suggested key when it is a required one that is missing.)"""
    key = loc[-1] if loc else ""
    parent, _ = _field_at(model, loc)
    where = _path(loc[:-1]) or "the design"
    if parent is None or not isinstance(key, str):
        return "unknown key", None
    names = [info.alias or name for name, info in parent.model_fields.items()]
    close = nearest(key, names)
    sibling = _path([*loc[:-1], close]) if close else None
    if sibling in missing:
        return f"unknown key; did you mean {close} (required, and missing)?", sibling
    everywhere = _fields_everywhere(model)
    elsewhere = everywhere.get(key, [])
    if elsewhere:
        return f"unknown key here; did you mean {' or '.join(elsewhere[:3])}?", None
    if close:
        return f"unknown key; did you mean {close}?", None
    near = nearest(key, everywhere, cutoff=0.75) if far else None
    if near:
        return f"unknown key here; did you mean {' or '.join(everywhere[near][:3])}?", None
    return f"unknown key; {where} takes {clip(', '.join(names), 300)}", None


# pydantic's tag for each member of a union of plain types, and the words for it
UNION_TAGS = {"str": "a string", "int": "an integer", "float": "a number", "bool": "a boolean", "none": "null"}


def _union_merged(errs: list[tuple[tuple, dict]]) -> list[tuple[tuple, dict]]:
    """A value that fits no member of a union of plain types (``str | int | float | bool``) is one
    problem, not one a member: pydantic gives an error for each, under the member's tag."""
    def tag(loc):
        return loc[-1] if loc and isinstance(loc[-1], str) and loc[-1] in UNION_TAGS else None
    count: dict[tuple, int] = {}
    for loc, _ in errs:
        if tag(loc):
            count[loc[:-1]] = count.get(loc[:-1], 0) + 1
    out, done = [], set()
    for loc, err in errs:
        if not tag(loc) or count[loc[:-1]] < 2:
            out.append((loc, err))
            continue
        if loc[:-1] in done:
            continue
        done.add(loc[:-1])
        kinds = [UNION_TAGS[lc[-1]] for lc, _ in errs if lc[:-1] == loc[:-1] and tag(lc)]
        words = ", ".join(kinds[:-1]) + f" or {kinds[-1]}"
        out.append((loc[:-1], {"type": "union", "msg": f"Input should be {words} (got {echo(err.get('input'))})"}))
    return out


def schema_problems(e: ValidationError, model: type[BaseModel] = None) -> list[tuple[str, str]]:
    """Every error pydantic found, each as (field path, what is wrong and what is allowed): a
    missing field with what it holds, an unknown key with the nearest known one."""
    model = model or Design
    errs = []
    for err in e.errors():
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-")))
        errs.append((loc, err))
    errs = _union_merged(errs)
    missing = {_path(loc) for loc, err in errs if err["type"] == "missing"}
    extra = [i for i, (_, err) in enumerate(errs) if err["type"] == "extra_forbidden"]
    unknown = {i: _unknown_key(model, errs[i][0], missing, n < SUGGESTED) for n, i in enumerate(extra)}
    covered = {meant for _, meant in unknown.values() if meant}       # a misspelt key says its missing one
    itemised = {loc[:k] for loc, _ in errs for k in range(len(loc)) if isinstance(loc[k], int)}  # lists with bad items
    out = []
    for i, (loc, err) in enumerate(errs):
        typ, path = err["type"], _path(loc)
        msg = err["msg"].removeprefix("Value error, ")
        if i in unknown:
            msg = unknown[i][0]
        elif path in covered or (typ == "too_short" and loc in itemised):    # short: its bad items dropped
            continue
        elif typ == "missing":
            _, info = _field_at(model, loc)
            what = getattr(info, "description", None)
            msg = f"missing (required): {what}" if what else "missing (required)"
        elif "input" in err and typ != "value_error":
            msg = "Input should be a list (items written - ..., or [a, b])" if typ == "tuple_type" else msg
            msg += f" (got {echo(err['input'])})"
        out.append((path, msg))
    return list(dict.fromkeys(out))


def validation_error(e: ValidationError, path: str | Path, model: type[BaseModel] = None) -> InputError:
    """Pydantic's errors as one :class:`InputError` carrying each (the field path and what is wrong)."""
    return InputError.of([InputError(path, p, m) for p, m in schema_problems(e, model)])


def refuse(problems: list, layers: designfile.Layers) -> InputError:
    """``problems`` ((field path, message), or a :class:`hwgen.errors.Problem`; a rule over several
    fields gives their paths, the one to change first; or an :class:`InputError` named already) as
    one :class:`InputError`, each named in the file that wrote the field it blames: of a rule's
    fields, one the design's own file wrote, else one whose value is far off its usual range, else
    one a base wrote, else the first. A field far off its usual range says so in the message of its
    problem, or as a note."""
    hinted = designfile.hints(layers.doc)
    used, out = set(), []
    for problem in problems:
        if isinstance(problem, InputError):           # named already
            out.append(problem)
            continue
        paths, message, *why = problem               # why: a Problem's cause and what it follows
        paths = (paths,) if isinstance(paths, str) else tuple(paths)

        def rank(p):
            o = layers.origin(designfile.keys_of(p))
            return (o == 0, p in hinted, o is not None)
        best = max(paths, key=rank)          # max keeps the first of equals
        if best in hinted and best not in used:
            message = f"{message}; {hinted[best]}"
            used.add(best)
        out.append(InputError(layers.file_of(best), best, message, *why))
    errored = {e.path for e in out}
    notes = [f"{layers.file_of(p)}: {p}: {h}" for p, h in hinted.items() if p not in used and p not in errored]
    return InputError.of(out, notes)


def validate(data: dict, path: str | Path, layers: designfile.Layers | None = None) -> Design:
    """A design document (as read from YAML, its bases merged) checked against the schema and the
    checks that span fields, exactly as a design file is; every fault is raised at once as one
    :class:`InputError`, each named in the file that wrote it (``layers``; else ``path``)."""
    layers = layers or designfile.single(data, path)
    problems: list = []
    if len(layers.files) > 1 and layers.origin(("design",)) != 0:
        problems.append(InputError(path, "design", f"a design built on a base needs a name of its own: the base's "
                                                   f"{echo(data.get('design'))} would write over that design's "
                                                   f"outputs (e.g. design: {clip(Path(path).stem)})"))
    try:
        design = Design.model_validate(data)
    except ValidationError as e:
        raise refuse(problems + schema_problems(e), layers) from None
    problems += design_problems(design)
    if problems:
        raise refuse(problems, layers)
    return design


def design_problems(d: Design) -> list[tuple[str | tuple[str, ...], str]]:
    """Checks that span fields: (the field path, or the paths of the fields the rule involves with
    the one to change first; what is wrong), every one found."""
    out: list = []
    if not SAFE_NAME.match(d.design):
        out.append(("design", f"{echo(d.design)} is not a safe file name (letters, digits, _ and -)"))
    n = d.disks.count
    if d.disks.stations is not None:
        st = d.disks.stations
        if len(st) != n:
            out.append((("disks.stations", "disks.count"), f"has {len(st)} stations, disks.count is {n}"))
        if any(b <= a for a, b in zip(st, st[1:])):
            out.append(("disks.stations", "stations must increase strictly"))
        if abs(st[0]) > 1e-9 or abs(st[-1] - d.backbone.length) > 1e-6:
            out.append((("disks.stations", "backbone.length"),
                        f"disks.stations must run from 0 to backbone.length = {d.backbone.length} mm "
                        f"(they run from {st[0]:g} to {st[-1]:g} mm)"))
    elif d.disks.spacing is not None and abs(d.disks.spacing * (n - 1) - d.backbone.length) > 1e-6:
        out.append((("disks.spacing", "backbone.length", "disks.count"),
                    f"{n - 1} gaps of disks.spacing {d.disks.spacing:g} mm give {d.disks.spacing * (n - 1):g} mm, "
                    f"backbone.length is {d.backbone.length:g} mm (leave disks.spacing out and the disks are "
                    f"spaced equally over the length)"))
    if d.disks.eyelets.edge_size >= d.disks.thickness / 2:
        out.append((("disks.eyelets.edge_size", "disks.thickness"),
                    f"the eyelets' chamfers (disks.eyelets.edge_size {d.disks.eyelets.edge_size:g} mm at each end) "
                    f"must be less than half the disk thickness (disks.thickness {d.disks.thickness:g} mm): a "
                    f"smaller edge_size, or disks thicker than {2 * d.disks.eyelets.edge_size:g} mm"))
    if d.disks.anchors.plate >= d.disks.end_thickness / 2:
        out.append((("disks.anchors.plate", "disks.end_thickness"),
                    f"the seat plate (disks.anchors.plate {d.disks.anchors.plate:g} mm) must be less than half "
                    f"the end disks' thickness (disks.end_thickness {d.disks.end_thickness:g} mm)"))
    sweep, checked = d.disks.eyelets.sweep_deg, d.check.max_angle_deg
    if checked is not None and checked > sweep:
        out.append((("check.max_angle_deg", "disks.eyelets.sweep_deg"),
                    f"±{checked:g}° is beyond the ±{sweep:g}° the eyelets are sized for "
                    f"(disks.eyelets.sweep_deg): they would fail the angle check by design; "
                    f"raise the sweep or leave check.max_angle_deg out"))
    out += _channel_problems(d)
    out += _tendon_problems(d)
    return out


def _channel_problems(d: Design) -> list:
    out: list = []
    channels = d.tensioner.channels
    if len(channels) > MAX_CHANNELS:
        out.append(("tensioner.channels", f"{len(channels)} channels; at most {MAX_CHANNELS}"))
    for i, c in enumerate(channels[:MAX_CHANNELS]):
        if not SAFE_NAME.match(c):
            out.append((f"tensioner.channels[{i}]", f"{echo(c)} is not a safe file name"))
        if c in channels[:i]:
            out.append((f"tensioner.channels[{i}]", f"duplicate channel {echo(c)}"))
    if d.tensioner.actuating_channel not in channels:
        out.append((("tensioner.actuating_channel", "tensioner.channels"),
                    f"{echo(d.tensioner.actuating_channel)} is not one of the channels {echo(list(channels), 80)}"))
    for c in d.tensioner.winding:
        if c not in channels:
            out.append(((f"tensioner.winding.{clip(c)}", "tensioner.channels"),
                        f"{echo(c)} is not one of the channels {echo(list(channels), 80)}"))
    used = {t.channel for t in d.tendons}
    out += [Problem(f"tensioner.channels[{i}]", f"channel {echo(c)} has no tendon: give it one (tendons[].channel) "
                                                f"or drop it from tensioner.channels", follows=UNKNOWN_CHANNEL)
            for i, c in enumerate(channels[:MAX_CHANNELS]) if c not in used and c not in channels[:i]]
    return out


def _tendon_problems(d: Design) -> list:
    out: list = []
    channels, n = d.tensioner.channels, d.disks.count
    names: dict[str, str] = {}
    for i, t in enumerate(d.tendons):
        where = f"tendons[{i}]"
        own = list(zip(t.names, (f"{where}.name", f"{where}.routing.mirror_name")))
        for name, p in own:
            if not SAFE_NAME.match(name):
                out.append((p, f"{echo(name)} is not a safe file name (letters, digits, _ and -)"))
            elif name in names:
                out.append((p, f"duplicate tendon name {echo(name)} (also at {names[name]})"))
            else:
                names[name] = p
        if t.channel not in channels:
            close = nearest(t.channel, channels)
            meant = f"; did you mean {close}?" if close else ""
            out.append(Problem((f"{where}.channel", "tensioner.channels"), f"{t.name}: unknown channel "
                               f"{echo(t.channel)}{meant}; tensioner.channels are {echo(list(channels), 80)}",
                               UNKNOWN_CHANNEL))
        if t.routing.table is not None and len(t.routing.table) != n:
            out.append(((f"{where}.routing.table", "disks.count"),
                        f"{t.name}'s table has {len(t.routing.table)} rows, there are {n} stations (disks.count)"))
    return out


def json_schema() -> dict:
    """The JSON Schema of a design file: the design's fields, and ``base``."""
    schema = Design.model_json_schema()
    schema.setdefault("properties", {})[designfile.BASE_KEY] = {
        "type": "string", "title": "Base",
        "description": "a design file this one builds on (relative to this file): its values, with this file's "
                       "merged over them (mappings key by key, lists whole; null removes a value)"}
    return schema
