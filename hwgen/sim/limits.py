"""The sim's gates, written once: sim.json, `hwgen sim`'s help, the docs and the tests read them here."""
from __future__ import annotations

STATICS = 0.02       # MuJoCo's tip stiffness within 2 % of the statics' (it is sprung from them: 0.05 % seen)
REFERENCE = 0.02     # MuJoCo's tip within 2 % of the robot's length of the independent Cosserat rod's
RING_DOWN = 0.20     # a ring-down reproduces each mode's frequency and damping ratio within 20 %


def words() -> dict:
    """The gates as the help and the docs print them."""
    return {"statics": f"{STATICS * 100:g} %", "reference": f"{REFERENCE * 100:g} %",
            "ring_down": f"{RING_DOWN * 100:g} %"}
