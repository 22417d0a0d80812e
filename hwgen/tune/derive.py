"""`hwgen tune DESIGN.yaml --goal stiffness|torsion|pass`: the search space derived from the design.

No tune file: what is free, and within what, follows from the design and a stated rule each, never
from an earlier search's answers.

- **Fixed**: everything structural (strip, disks, process, material, tensioner) and the actuating
  channel's tendons (``tensioner.actuating_channel``): the search is over how the robot is
  stiffened, not over what it is.
- **Free, per stiffening tendon with an eq. (3) function** (a tendon routed by a table stays as it is):

  - the amplitude ``a``, from the least that keeps its eyelet clear of the strip's slot (the slot's
    half thickness, the tendon's widest hole's radius and ``process.min_wall``) to the most the
    disk's rim allows (its radius less that hole's radius and ``process.min_wall``), on a
    :data:`LENGTH_STEP` grid (what the printer holds); the actuating pair and the other tendons are
    its neighbours, and the checks (walls, overlap, ``eyelet.shared_sliding``) keep it off them;
  - a cosine's half waves ``k``: odd whole numbers up to :data:`K_MAX` (eq. (1)-(2) to first order: a
    whole k keeps its length over the bend; a push at the tip bends the strip with a curvature growing as
    (L - s), and ∫ a·cos(kπs/L)(L - s) ds is 2aL²/(kπ)² at odd k and nothing at even k: an even k adds no
    stiffness); its phase 0 or 180° (eq. (2): at odd k, ∫ a·cos(kπs/L + φ) ds = -2aL·sin φ/(kπ)
    vanishes only there); its offset (``x0`` across the strip, within it less the crossing's hole and
    a wall; ``z0`` for a cosine along x, within the disk's rim), on the same grid;
  - a helix's half turns ``k``: even whole numbers up to :data:`K_MAX`, and its phase over the whole
    circle, on a :data:`PHASE_STEP_DEG` grid (eq. (2) in the plane the robot bends: the helix's part
    across the strip, ∫ a·cos(kπs/L + φ) ds = aL[sin(kπ + φ) - sin φ]/(kπ), vanishes at every phase only
    at even k, at odd k at 0 and 180° alone: over the whole circle of phases, an odd k draws 2 of the 72
    phases that keep the tendon's length, and the first derived tune lost four trials in five to eq. (2),
    most of them such; a push at the tip then has the lever ∫ a·cos(kπs/L + φ)(L - s) ds = -aL² sin φ/(kπ)
    at even k, largest across the circle's quarter turns, where odd k and a phase of 0 or 180° give
    2aL²/(kπ)²);
  - its pre-tension ``pretension_n``, from the design's own floor (``check.taut_floor_n``, what
    ``tendon.taut`` holds every locked tendon to, on the grid) up to the allowable load
    (``tendon_material.break_load`` / ``check.tendon_safety_factor``), on a :data:`TENSION_STEP_N` grid
    (a floor of its own above the check's left the prototype's base, H at 0.5 N, outside its space);
  - its termination's size ``termination.diameter``, from the material's up to :data:`BEAD_MM` more
    (a bead or a sleeve on the line: a lab's ordinary remedy for a seat that is too wide).
  A base value the rule leaves out (an even cosine k) is kept among the choices: the base is a trial.
- **The goal** (:data:`GOALS`): ``stiffness`` maximizes the tip's stiffness with every tendon locked,
  ``torsion`` the tip's torsional stiffness, ``pass`` finds the passing design nearest the base; each
  subject to every check of the coupling level passing, to ``actuation.coupling``, ``tendon.taut``
  and ``eyelet.shared_sliding`` even where the design states them as warnings, and to the tip's
  torsion (or stiffness) and the least disk stiffness no lower than the base's own.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path

from .. import designfile, params
from ..errors import InputError
from ..model.plan import make_plan
from . import spec as tune_spec

GOALS = ("stiffness", "torsion", "pass")
LENGTH_STEP = 0.1           # mm: amplitudes and offsets, a little over the ±0.05 mm a resin printer holds
PHASE_STEP_DEG = 5.0        # deg: a helix's phase; 5° moves an eyelet at r = 25 mm by 2.2 mm around the disk
TENSION_STEP_N = 0.5        # N: what a lab sets by hand on a spring scale
BEAD_MM = 1.5               # mm: a bead or sleeve up to this much wider than the knot
K_MAX = 7                   # half waves: beyond it a stiffening tendon's lever (1/k²) is under 2 % of one at k 1
REQUIRE = ("actuation.coupling", "tendon.taut", "eyelet.shared_sliding")
DEFAULT_BUDGET = 200
ROBUST_SAMPLES = 200


def _grid(v: float, step: float, up: bool) -> float:
    f = math.ceil if up else math.floor
    return round(f(v / step - 1e-9 * (1 if up else -1)) * step, 6)


def fixed_terminations(design: params.Design, free: list[tune_spec.Free]) -> dict:
    """``set`` for each tendon whose termination is free and which the design leaves to the
    material's: its own copy of it, so the base has a value there (written into best.yaml)."""
    out = {}
    for f in free:
        if f.path.endswith(".termination.diameter"):
            i = designfile.parse_path(f.path)[1]
            if design.tendons[i].termination is None:
                out[f"tendons[{i}].termination"] = design.tendon_material.termination.model_dump(exclude_none=True)
    return out


def free_space(design: params.Design) -> list[tune_spec.Free]:
    """The free parameters of the design's stiffening tendons, each bounded by its stated rule."""
    plan = make_plan(design)
    act = design.tensioner.actuating_channel
    R = design.disks.outer_diameter / 2
    mw = design.process.min_wall
    slot_h = plan.disks[0].slot_height / 2
    height = design.backbone.height / 2
    allowable = design.tendon_material.break_load / design.check.tendon_safety_factor
    floor = max(_grid(design.check.taut_floor_n, TENSION_STEP_N, True), TENSION_STEP_N)
    knot = design.tendon_material.termination.diameter
    out: list[tune_spec.Free] = []
    for i, t in enumerate(design.tendons):
        fn = t.routing.function
        if t.channel == act or fn is None or t.routing.table is not None or fn.kind == "straight":
            continue
        r = max((h.diameter for dk in plan.disks for h in dk.holes if t.name in h.tendons), default=1.0) / 2
        a_lo, a_hi = _grid(slot_h + r + mw, LENGTH_STEP, True), _grid(R - r - mw, LENGTH_STEP, False)
        at = f"tendons[{i}]"
        if a_hi > a_lo:
            out.append(tune_spec.Free(path=f"{at}.routing.function.a", low=a_lo, high=a_hi, step=LENGTH_STEP))
        if fn.kind == "cosine":
            out.append(tune_spec.Free(path=f"{at}.routing.function.k",
                                      choices=sorted({*range(1, K_MAX + 1, 2), fn.k})))
            out.append(tune_spec.Free(path=f"{at}.routing.function.phase_deg", choices=sorted({0.0, 180.0,
                                                                                              fn.phase_deg})))
            off = _grid((height if fn.axis == "z" else R) - r - mw, LENGTH_STEP, False)
            if off > 0:
                out.append(tune_spec.Free(path=f"{at}.routing.function.{'x0' if fn.axis == 'z' else 'z0'}",
                                          low=-off, high=off, step=LENGTH_STEP))
        else:
            out.append(tune_spec.Free(path=f"{at}.routing.function.k",
                                      choices=sorted({*range(2, K_MAX + 1, 2), fn.k})))
            out.append(tune_spec.Free(path=f"{at}.routing.function.phase_deg", low=0, high=360 - PHASE_STEP_DEG,
                                      step=PHASE_STEP_DEG))
        hi = _grid(allowable, TENSION_STEP_N, False)
        if hi > floor:
            out.append(tune_spec.Free(path=f"{at}.pretension_n", low=floor, high=hi, step=TENSION_STEP_N))
        own = t.termination.diameter if t.termination is not None else knot
        out.append(tune_spec.Free(path=f"{at}.termination.diameter", low=min(own, knot),
                                  high=round(max(own, knot) + BEAD_MM, 6), step=LENGTH_STEP))
    return out


def goal(kind: str) -> tune_spec.Goal:
    bounds = {"tip_torsion": "base", "least_stiffness": "base"}
    if kind == "stiffness":
        return tune_spec.Goal(maximize="tip_stiffness", at_least=bounds, require=list(REQUIRE))
    if kind == "torsion":
        return tune_spec.Goal(maximize="tip_torsion", at_least={"tip_stiffness": "base", "least_stiffness": "base"},
                              require=list(REQUIRE))
    return tune_spec.Goal(**{"pass": True}, at_least=bounds, require=list(REQUIRE))


def load(path: str | Path, kind: str, budget: int | None = None, seed: int = 0,
         sampler: str = "auto") -> tune_spec.Loaded:
    """The tune of a design file with the space :func:`free_space` derives and the goal ``kind``."""
    path = Path(path)
    if kind not in GOALS:
        raise InputError(path, "--goal", f"{kind!r} is not a goal: {', '.join(GOALS)}")
    layers = designfile.read_layers(path)
    design = params.validate(copy.deepcopy(layers.doc), path, layers)
    free = free_space(design)
    if not free:
        raise InputError(path, "tendons", "no stiffening tendon routed by an eq. (3) function: nothing to tune "
                                          "(write a tune file to free other parameters)")
    name = f"{design.design}-{kind}"
    if not params.SAFE_NAME.match(name):
        name = f"design-{kind}"
    t = tune_spec.Tune(tune=name, base=str(path), level="coupling", free=free, goal=goal(kind),
                       set=fixed_terminations(design, free),
                       budget=budget or DEFAULT_BUDGET, seed=seed, sampler=sampler, robust_samples=ROBUST_SAMPLES)
    return tune_spec.resolve(path, t, path, designfile.document_of(layers))


def is_design(path: str | Path) -> bool:
    """Whether a YAML file is a design (its top level names ``design``), not a tune file."""
    try:
        data, _ = params.document(designfile.read_bytes(Path(path), "design"), Path(path))
    except InputError:
        return False
    return isinstance(data, dict) and "design" in data and "tune" not in data
