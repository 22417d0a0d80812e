"""Which parts a design has, in build order. Each family turns the plan into Parts.

Each family is built in units (:class:`Unit`): a disk each, the strip, each channel of the
tensioner and its housing, each fixture. A unit names the frozen values its builder reads (its
``inputs``), so the part cache (:mod:`hwgen.cache`, used by :mod:`hwgen.engine.units`) can key its
files by them: a unit whose inputs did not change is not built again. A builder that starts to
read something new must name it in its unit's inputs.

The CAD kernel can fail on parameters that passed every earlier check (a boolean that leaves
nothing, a sweep that does not close). :func:`build_parts` and :func:`kernel_errors` turn any
such failure, and any solid that comes out empty or null, into a
:class:`hwgen.errors.DesignError` that names the part, the YAML section it comes from and the
parameters that made it, so the user reads what to change instead of a traceback.
"""
from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import NamedTuple

from ..errors import DesignError, InputError, clip
from ..model.plan import Plan
from . import Part, mass_properties

MIN_VOLUME_MM3 = 1e-6       # a solid with less than this is an empty result, not a part


def _disks(plan: Plan) -> Iterator[Part]:
    from .disk import build_disk
    for spec in plan.disks:
        yield build_disk(spec)


def _backbone(plan: Plan) -> Iterator[Part]:
    from .backbone import build_backbone
    yield build_backbone(plan.backbone)


def _tensioner(plan: Plan) -> Iterator[Part]:
    from .tensioner_parts import build_tensioner
    tip = plan.disks[-1]
    yield from build_tensioner(plan.require_tensioner_layout(),
                               tendon_diameter=plan.tendon_diameter, tip_screws=len(tip.mount_holes),
                               tip_thickness=tip.thickness)


def _mount(plan: Plan) -> Iterator[Part]:
    from .fixtures import build_mount
    yield from build_mount(plan.mount)


def _jig(plan: Plan) -> Iterator[Part]:
    from .fixtures import build_jig
    yield from build_jig(plan.jig, [s.name for s in plan.disks] + [plan.backbone.name])


FRAME_PARTS = 7             # cradle, front, back, base, wheel, worm, drive shaft (hwgen.cad.bench)
RIG_PARTS = 3               # bracket, push block, support


def _frame(plan: Plan) -> Iterator[Part]:
    from .bench import frame_parts
    if plan.frame is not None:
        yield from frame_parts(plan.frame)


def _rig(plan: Plan) -> Iterator[Part]:
    from .bench import rig_parts
    if plan.rig is not None:
        yield from rig_parts(plan.rig)


class Unit(NamedTuple):
    """Parts built together: what they are made from (frozen values, hashed for the cache), how
    many there are and the builder."""
    inputs: tuple
    count: int
    build: Callable[[], Iterator[Part]]


def _disk_units(plan: Plan) -> list[Unit]:
    def one(spec):
        def run():
            from .disk import build_disk
            yield build_disk(spec)
        return Unit((spec,), 1, run)
    return [one(spec) for spec in plan.disks]


def _backbone_units(plan: Plan) -> list[Unit]:
    return [Unit((plan.backbone,), 1, lambda: _backbone(plan))]


def _tensioner_units(plan: Plan) -> list[Unit]:
    """A unit per channel (its worm, drive shaft, wheel and clamps: they share the kept worm and
    gear, so the channels can be made in several processes at once), then the housing."""
    lay = plan.require_tensioner_layout()
    tip = plan.disks[-1]

    def channel(u):
        def run():
            from .tensioner_parts import channel_parts
            yield from channel_parts(lay, u, tendon_diameter=plan.tendon_diameter)
        # what channel_parts reads: the layout (with the tensioner section's values it needs; its pair
        # carries the printer's wall) and the tendon; and which channel
        return Unit((lay, plan.tendon_diameter, "channel", u.channel), 3 + len(u.clamps), run)

    def housing():
        from .tensioner_parts import housing_part
        yield housing_part(lay, tip_screws=len(tip.mount_holes), tip_thickness=tip.thickness)
    # what housing_part reads: the layout and the tip disk's screws and thickness
    return [channel(u) for u in lay.units] + [Unit((lay, len(tip.mount_holes), tip.thickness, "housing"), 1,
                                                    housing)]


def _mount_units(plan: Plan) -> list[Unit]:
    inputs = (plan.mount,)      # what build_mount reads
    return [Unit(inputs, 2, lambda: _mount(plan))]


def _jig_units(plan: Plan) -> list[Unit]:
    inputs = (plan.jig, [s.name for s in plan.disks], plan.backbone.name)   # what build_jig reads
    return [Unit(inputs, _jig_count(plan), lambda: _jig(plan))]


def _frame_units(plan: Plan) -> list[Unit]:
    # what frame_parts reads: the frame's layout
    return [] if plan.frame is None else [Unit((plan.frame, "base frame"),
                                               FRAME_PARTS, lambda: _frame(plan))]


def _rig_units(plan: Plan) -> list[Unit]:
    return [] if plan.rig is None else [Unit((plan.rig, "rig"), RIG_PARTS, lambda: _rig(plan))]


def _frame_made_from(plan: Plan, index: int) -> tuple[str, str]:
    f = plan.frame
    names = ("cradle", "front upright", "back upright", "base plate", "worm wheel", "worm", "drive shaft")
    return (f"base frame {names[min(index, len(names) - 1)]}",
            f"module {f.pair.module:g} mm, {f.pair.teeth} teeth, {f.bearing} bearings on Ø{f.shaft_d:g} shafts, "
            f"GT2 belt {f.belt_length:g} mm, axis {-f.z_base:.1f} mm over the plate")


def _rig_made_from(plan: Plan, index: int) -> tuple[str, str]:
    r = plan.rig
    return (("rig bracket", "push block", "support")[min(index, 2)],
            f"{r.cell_name} {r.cell[0]:g} × {r.cell[1]:g} × {r.cell[2]:g} mm on {r.flange}; disk {r.station + 1}")


def _jig_count(plan: Plan) -> int:
    return len(plan.jig.pieces)


def _tensioner_count(plan: Plan) -> int:
    lay = plan.require_tensioner_layout()
    return sum(3 + len(u.clamps) for u in lay.units) + 1


def _disk_made_from(plan: Plan, index: int) -> tuple[str, str]:
    spec = plan.disks[min(index, len(plan.disks) - 1)]
    holes = [h.diameter for h in spec.holes]
    sizes = f", {len(holes)} eyelet(s) Ø{min(holes):.3g}–{max(holes):.3g} mm" if holes else ""
    return spec.name, (f"{spec.role} disk at y = {spec.y:g} mm: thickness {spec.thickness:g} mm, "
                       f"Ø{spec.outer_diameter:g} mm, slot {spec.slot_width:g} × {spec.slot_height:g} mm{sizes}"
                       f"{f', {len(spec.seats)} tendon seat(s)' if spec.seats else ''}"
                       f"{f', {len(spec.mount_holes)} mount hole(s)' if spec.mount_holes else ''}")


def _backbone_made_from(plan: Plan, index: int) -> tuple[str, str]:
    b = plan.backbone
    holes = [h[2] for h in b.merged_holes()]
    sizes = f", {len(holes)} hole(s) up to Ø{max(holes):.3g} mm" if holes else ""
    return b.name, f"strip {b.height:g} × {b.thickness:g} mm, {b.y_end - b.y_start:g} mm long{sizes}"


def _tensioner_made_from(plan: Plan, index: int) -> tuple[str, str]:
    lay = plan.require_tensioner_layout()
    t = lay.pair
    return (f"tensioner part {index + 1}", f"module {t.module:g} mm, {t.starts} start(s), {t.teeth} teeth, "
            f"worm Ø{t.worm_pitch_diameter:g} × {t.worm_length:g} mm, face width {t.face_width:g} mm, "
            f"spool Ø{2 * lay.spool_radius:g} mm, {len(lay.units)} channel(s)")


def _mount_made_from(plan: Plan, index: int) -> tuple[str, str]:
    m = plan.mount
    return (("base mount", "upper jaw")[min(index, 1)],
            f"clamps {-plan.backbone.y_start:g} mm of strip; bolt pattern {m.bolt_pattern}, "
            f"{len(m.disk_screws)} disk screw(s) Ø{m.screw_hole:g} mm")


def _jig_made_from(plan: Plan, index: int) -> tuple[str, str]:
    j = plan.jig
    return f"jig piece {index + 1}", (f"{len(plan.disks)} disk slots; {len(j.pieces)} piece(s), walls "
                                      f"{j.x_outer - j.x_inner:g} mm, floor {j.z_floor_top - j.z_floor_bottom:g} mm")


class Family(NamedTuple):
    name: str
    section: str                                          # the YAML section its parts come from
    count: Callable[[Plan], int]                          # how many parts it yields
    build: Callable[[Plan], Iterator[Part]]               # the builder; imports CadQuery only when run
    made_from: Callable[[Plan, int], tuple[str, str]]     # (part name, its parameters) of the index-th part
    units: Callable[[Plan], list[Unit]]                   # the same parts, in units the cache keys


FAMILIES: list[Family] = [
    Family("disks", "disks", lambda p: len(p.disks), _disks, _disk_made_from, _disk_units),
    Family("backbone", "backbone", lambda p: 1, _backbone, _backbone_made_from, _backbone_units),
    Family("tensioner", "tensioner", _tensioner_count, _tensioner, _tensioner_made_from, _tensioner_units),
    Family("base mount", "base_mount", lambda p: 2, _mount, _mount_made_from, _mount_units),
    Family("jig", "jig", _jig_count, _jig, _jig_made_from, _jig_units),
    Family("base frame", "base_frame", lambda p: 0 if p.frame is None else FRAME_PARTS, _frame, _frame_made_from,
           _frame_units),
    Family("rig", "rig", lambda p: 0 if p.rig is None else RIG_PARTS, _rig, _rig_made_from, _rig_units),
]


def part_count(plan: Plan) -> int:
    return sum(f.count(plan) for f in FAMILIES)


def _failure(family: Family, plan: Plan, index: int, what: str, part_name: str | None = None) -> DesignError:
    name, params = family.made_from(plan, index)
    return DesignError(family.section, f"the CAD kernel could not make {part_name or name} ({params}): "
                                       f"{clip(what, 160)}; change these parameters")


def _sound(part: Part) -> None:
    """Raise ValueError for a solid the kernel returned but that is no part: null or empty."""
    solid = part.solid
    if solid is None or getattr(solid, "wrapped", None) is None or solid.wrapped.IsNull():
        raise ValueError("it came out null")
    volume = mass_properties(solid)[0]
    if not volume > MIN_VOLUME_MM3:
        raise ValueError(f"it came out empty ({volume:.3g} mm³)")


def build_parts(plan: Plan) -> Iterator[Part]:
    """Every part of the design, family by family; a failure of the kernel is a DesignError."""
    for family, first, unit in units(plan):
        yield from build_unit(plan, family, first, unit)


def units(plan: Plan) -> Iterator[tuple[Family, int, Unit]]:
    """Every unit of the design in build order, with its family and the index of its first part
    in the family."""
    for family in FAMILIES:
        first = 0
        try:
            family_units = family.units(plan)
        except (DesignError, InputError):
            raise
        except Exception as e:     # a layout its builder would have failed on
            raise _failure(family, plan, 0, f"{type(e).__name__}: {e}") from None
        for unit in family_units:
            yield family, first, unit
            first += unit.count


def build_unit(plan: Plan, family: Family, first: int, unit: Unit) -> Iterator[Part]:
    """The parts of one unit; a failure of the kernel is a DesignError naming the part."""
    parts = unit.build()
    index = first
    sound = []                  # the solids found sound so far (a unit's parts often share one)
    while True:
        try:
            part = next(parts)
            if not any(part.solid is s for s in sound):
                _sound(part)
                sound.append(part.solid)
        except StopIteration:
            break
        except (DesignError, InputError):
            raise
        except Exception as e:     # OCCT's Standard_Failure, CadQuery's ValueError, ...
            raise _failure(family, plan, index, f"{type(e).__name__}: {e}") from None
        index += 1
        yield part


@contextmanager
def kernel_errors(plan: Plan, part: Part | None, doing: str) -> Iterator[None]:
    """Writing a part's files (or the assembly, ``part`` None): a kernel failure is a DesignError."""
    try:
        yield
    except (DesignError, InputError, OSError):
        raise
    except Exception as e:
        if part is None:
            raise DesignError("", f"the CAD kernel could not {doing}: {clip(f'{type(e).__name__}: {e}', 160)}") \
                from None
        family = next((f for f in FAMILIES if f.name == _family_of(part)), FAMILIES[0])
        raise DesignError(family.section, f"the CAD kernel could not {doing} {part.name}: "
                                          f"{clip(f'{type(e).__name__}: {e}', 160)}") from None


# the roles of the bench the robot stands in and is pushed by (issue 46): the base frame's and the rig's
FRAME_ROLES = ("base_frame", "base_frame_gear")
BENCH_ROLES = (*FRAME_ROLES, "rig")


def _family_of(part: Part) -> str:
    """The family a part comes from, by its role."""
    if part.role == "disk":
        return "disks"
    if part.role in ("base_mount", "base_clamp"):
        return "base mount"
    if part.role == "jig":
        return "jig"
    if part.role in FRAME_ROLES:
        return "base frame"
    if part.role == "rig":
        return "rig"
    return "backbone" if part.role == "backbone" else "tensioner"
