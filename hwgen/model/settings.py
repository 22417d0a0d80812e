"""The YAML's settings the checks and outputs read, resolved into frozen values (no schema objects).

One class per YAML section, each field under the YAML's own word; where the model resolves a
value (a default taken from another section, a density from the materials table) the field says
so. :func:`hwgen.model.plan.make_plan` fills them in from the design; the stages after the
model read these and never the schema. The part layouts that already hold their section's
values carry the rest: :class:`~hwgen.model.specs.BackboneSpec` (backbone),
:class:`~hwgen.model.fixtures.MountLayout` (base_mount), :class:`~hwgen.model.fixtures.JigLayout`
(jig), :class:`~hwgen.model.tensioner_layout.TensionerLayout` (the worm pair, μ, the spool).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..params import Design, Termination as TerminationSchema
from .materials import contact_elasticity, printed_density, printed_modulus


@dataclass(frozen=True, kw_only=True)
class CheckSettings:
    """check: how `hwgen check` sweeps the bending angle and what it tolerates."""

    max_angle_deg: float          # the sweep's ±angle: check.max_angle_deg, else disks.eyelets.sweep_deg (resolved)
    step_deg: float
    position_tol_mm: float
    interference_tol_mm3: float
    overstress: str               # "error" or "warning"
    samples: int
    seed: int
    robust: str                   # "p50", "p90", "p95", "p99" or "max"
    robust_confidence: float
    robust_precision_mm: float
    robust_severity: str          # "error" or "warning"
    shared_sliding: str           # "error" or "warning"
    taut_floor_n: float
    tendon_safety_factor: float
    max_coupling: float
    working_tension_n: float
    straight_within_mm: float
    stiffness_push_n: float
    min_stiffening: float         # all tendons locked over the actuating pair alone, at the tip (what the stiffening tendons are for)
    min_torsion_stiffening: float     # the same for the tip's torsion


@dataclass(frozen=True, kw_only=True)
class ProcessSettings:
    """process: the printer and its material, with the material's figures from data/materials.csv."""

    name: str
    technology: str               # "SLA" or "FDM"
    material: str
    min_wall: float
    min_hole: float
    build_volume: tuple[float, float, float]
    position_sigma: float
    diameter_sigma: float
    density_g_cm3: float          # of a printed part, fill included: process.density_g_cm3, else the table's (resolved)
    density_reason: str
    modulus_gpa: float            # the printed material's, fill included (resolved from the table)
    modulus_reason: str
    contact_modulus_mpa: float    # for the gears' Hertz contact: solid material (from the table)
    poisson: float
    contact_reason: str


@dataclass(frozen=True, kw_only=True)
class Termination:
    """tendon_material.termination (or a tendon's own): how a tendon ends at the base disk."""

    kind: str                     # "knot" or "crimp"
    diameter: float
    length: float | None
    name: str | None


@dataclass(frozen=True, kw_only=True)
class TendonMaterialSettings:
    """tendon_material: the line every tendon is cut from."""

    name: str
    diameter: float
    break_load: float
    termination: Termination      # the material's; a tendon's own is its path's (TendonPath.termination)
    axial_stiffness_n: float
    tie_off_compliance_mm_per_n: float
    eyelet_friction: float | None     # μ of the line in an eyelet; None: the bounds only


@dataclass(frozen=True, kw_only=True)
class TensionerSettings:
    """tensioner: the channels and the strength figures; where its parts go is the TensionerLayout."""

    channels: tuple[str, ...]
    actuating_channel: str
    resin_strength: float
    safety_factor: float


@dataclass(frozen=True, kw_only=True)
class HubSettings:
    """disks.hub: the hubs' wall and the tilt their slots may allow."""

    max_tilt_deg: float
    wall: float


@dataclass(frozen=True, kw_only=True)
class AnchorsSettings:
    """disks.anchors: what fixes each disk to the strip."""

    adhesive: str


@dataclass(frozen=True, kw_only=True)
class RenderSettings:
    """render: the pictures."""

    explode_mm: float
    bend_deg: float
    width_px: int


@dataclass(frozen=True, kw_only=True)
class BomSettings:
    """bom: what is added to each tendon's rest length when it is cut."""

    tie_off_mm: float
    spool_mm: float


@dataclass(frozen=True, kw_only=True)
class PlatesSettings:
    """plates: how the printed parts are laid out on the printer's plate."""

    gap_mm: float
    edge_margin_mm: float
    sla_tilt_deg: float
    flat_contact_fraction: float


@dataclass(frozen=True, kw_only=True)
class ExperimentSettings:
    """experiment: the push test, and the ranges of the values its prediction spans."""

    orientation: str              # a key of hwgen.model.stiffness.ORIENTATIONS
    push_toward: str              # "+z" or "-z"
    first_disk: int               # counted from 1 at the clamped base
    load_cell_range_n: float
    load_fraction: float
    max_push_mm: float
    displacement_rate_mm_s: float
    sample_rate_hz: float
    fit_window_samples: int
    repetitions: int
    ranges: tuple[tuple[str, float, float], ...]     # (the design's dotted field, low, high) of each value given


RANGED = {"axial_stiffness_n": "tendon_material.axial_stiffness_n",
          "tie_off_compliance_mm_per_n": "tendon_material.tie_off_compliance_mm_per_n",
          "eyelet_friction": "tendon_material.eyelet_friction", "modulus_gpa": "backbone.modulus_gpa"}


def termination(t: TerminationSchema) -> Termination:
    return Termination(kind=t.kind, diameter=t.diameter, length=t.length, name=t.name)


def check_settings(d: Design) -> CheckSettings:
    c = d.check
    return CheckSettings(max_angle_deg=d.check_angle_deg, step_deg=c.step_deg, position_tol_mm=c.position_tol_mm,
                         interference_tol_mm3=c.interference_tol_mm3, overstress=c.overstress, samples=c.samples,
                         seed=c.seed, robust=c.robust, robust_confidence=c.robust_confidence,
                         robust_precision_mm=c.robust_precision_mm, robust_severity=c.robust_severity,
                         shared_sliding=c.shared_sliding,
                         taut_floor_n=c.taut_floor_n, tendon_safety_factor=c.tendon_safety_factor,
                         max_coupling=c.max_coupling, working_tension_n=c.working_tension_n,
                         straight_within_mm=c.straight_within_mm,
                         stiffness_push_n=c.stiffness_push_n, min_stiffening=c.min_stiffening,
                         min_torsion_stiffening=c.min_torsion_stiffening)


def process_settings(d: Design) -> ProcessSettings:
    p = d.process
    density, density_why = printed_density(p)
    modulus, modulus_why = printed_modulus(p)
    contact, poisson, contact_why = contact_elasticity(p)
    return ProcessSettings(name=p.name, technology=p.technology, material=p.material, min_wall=p.min_wall,
                           min_hole=p.min_hole, build_volume=tuple(p.build_volume), position_sigma=p.position_sigma,
                           diameter_sigma=p.diameter_sigma, density_g_cm3=density, density_reason=density_why,
                           modulus_gpa=modulus, modulus_reason=modulus_why, contact_modulus_mpa=contact,
                           poisson=poisson, contact_reason=contact_why)


def tendon_material_settings(d: Design) -> TendonMaterialSettings:
    tm = d.tendon_material
    return TendonMaterialSettings(name=tm.name, diameter=tm.diameter, break_load=tm.break_load,
                                  termination=termination(tm.termination), axial_stiffness_n=tm.axial_stiffness_n,
                                  tie_off_compliance_mm_per_n=tm.tie_off_compliance_mm_per_n,
                                  eyelet_friction=tm.eyelet_friction)


def tensioner_settings(d: Design) -> TensionerSettings:
    ts = d.tensioner
    return TensionerSettings(channels=tuple(ts.channels), actuating_channel=ts.actuating_channel,
                             resin_strength=ts.resin_strength, safety_factor=ts.safety_factor)


def hub_settings(d: Design) -> HubSettings:
    return HubSettings(max_tilt_deg=d.disks.hub.max_tilt_deg, wall=d.disks.hub.wall)


def anchors_settings(d: Design) -> AnchorsSettings:
    return AnchorsSettings(adhesive=d.disks.anchors.adhesive)


def render_settings(d: Design) -> RenderSettings:
    r = d.render
    bend = r.bend_deg if r.bend_deg is not None else d.check_angle_deg     # drawn as far as it is checked
    return RenderSettings(explode_mm=r.explode_mm, bend_deg=bend, width_px=r.width_px)


def bom_settings(d: Design) -> BomSettings:
    return BomSettings(tie_off_mm=d.bom.tie_off_mm, spool_mm=d.bom.spool_mm)


def plates_settings(d: Design) -> PlatesSettings:
    p = d.plates
    return PlatesSettings(gap_mm=p.gap_mm, edge_margin_mm=p.edge_margin_mm, sla_tilt_deg=p.sla_tilt_deg,
                          flat_contact_fraction=p.flat_contact_fraction)


def experiment_settings(d: Design) -> ExperimentSettings:
    x = d.experiment
    ranges = tuple((field, *getattr(x.ranges, key)) for key, field in RANGED.items()
                   if getattr(x.ranges, key) is not None)
    return ExperimentSettings(orientation=x.orientation, push_toward=x.push_toward, first_disk=x.first_disk,
                              load_cell_range_n=x.load_cell_range_n, load_fraction=x.load_fraction,
                              max_push_mm=x.max_push_mm, displacement_rate_mm_s=x.displacement_rate_mm_s,
                              sample_rate_hz=x.sample_rate_hz, fit_window_samples=x.fit_window_samples,
                              repetitions=x.repetitions, ranges=ranges)
