"""Every check a sweep or a tune can foresee on the plan alone, in one list: each screen lives
beside the check that owns its id (:class:`hwgen.checks.base.Screen`) and reads only the plan.
A screen fires where its check, on the built files, fails (``tests/test_screens.py``)."""
from __future__ import annotations

from .anchors import seat_screen
from .base import Screen
from .clearances import crossing_screen, rubbing_screen, wall_screen
from .eyelets import overlap_screen
from .gear_walls import bore_wall_screen, drive_wall_screen, thread_tip_screen, tooth_tip_screen
from .sliding import sliding_screen

# in the order a sweep's row lists them
SCREENS = (overlap_screen, wall_screen, crossing_screen, sliding_screen, rubbing_screen, seat_screen, tooth_tip_screen,
           thread_tip_screen, bore_wall_screen, drive_wall_screen)


def plan_screens(plan) -> list[Screen]:
    """What the full plan says that the lengths level cannot, and ``hwgen check`` fails each."""
    return [s for screen in SCREENS for s in screen(plan)]
