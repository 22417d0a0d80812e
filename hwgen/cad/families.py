"""Which parts a design has, in build order. Each family turns the plan into Parts."""
from __future__ import annotations

from collections.abc import Callable, Iterator

from ..model.fixtures import jig_layout
from ..model.plan import Plan
from . import Part


def _disks(plan: Plan) -> Iterator[Part]:
    from .disk import build_disk
    for spec in plan.disks:
        yield build_disk(spec)


def _backbone(plan: Plan) -> Iterator[Part]:
    from .backbone import build_backbone
    yield build_backbone(plan.backbone)


def _tensioner(plan: Plan) -> Iterator[Part]:
    from .tensioner_parts import build_tensioner
    yield from build_tensioner(plan)


def _mount(plan: Plan) -> Iterator[Part]:
    from .fixtures import build_mount
    yield from build_mount(plan)


def _jig(plan: Plan) -> Iterator[Part]:
    from .fixtures import build_jig
    yield from build_jig(plan)


def _jig_count(plan: Plan) -> int:
    return len(jig_layout(plan.design).pieces)


def _tensioner_count(plan: Plan) -> int:
    lay = plan.require_tensioner_layout()
    return sum(3 + len(u.clamps) for u in lay.units) + 1


# (family, how many parts it yields, builder); the builders import CadQuery only when they run
FAMILIES: list[tuple[str, Callable[[Plan], int], Callable[[Plan], Iterator[Part]]]] = [
    ("disks", lambda p: len(p.disks), _disks),
    ("backbone", lambda p: 1, _backbone),
    ("tensioner", _tensioner_count, _tensioner),
    ("base mount", lambda p: 2, _mount),
    ("jig", _jig_count, _jig),
]


def part_count(plan: Plan) -> int:
    return sum(count(plan) for _, count, _ in FAMILIES)


def build_parts(plan: Plan) -> Iterator[Part]:
    for _, _, build in FAMILIES:
        yield from build(plan)
