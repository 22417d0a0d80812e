"""``tendon.robust``'s design fix, tried: tighter eyelets (``process.hole_clearance``). The
as-built Monte Carlo run again (:func:`hwgen.model.scatter.run`, the build's seed and scatter) on
the holes the build measured, each made smaller by the clearance taken off and none under
``process.min_hole`` (the plan's rule): the model quantity the check measures, without a new
build. One run serves every failing tendon; where a hole at ``process.min_hole`` is what holds a
tendon's play, the fix says so."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..checks.base import Fix
from ..checks.taut import from_report
from ..model import scatter as mc
from .trial import MODEL_ERRORS, Trial, ident

SAMPLES = 500          # as-built samples of a trial (the build's own run draws up to check.samples): p95 within ~0.01 mm
TRIED_MM = (0.0,)      # the clearances tried: the least the schema allows, what no tighter hole improves on


def clearance_fixes(trial: Trial, failing: list[dict]) -> dict[tuple, Fix]:
    """{check identity: its fix} for the failing ``tendon.robust`` checks, from one Monte Carlo run
    per clearance tried."""
    tb = (trial.report.get("as_built") or {}).get("taut") or {}
    old = trial.current("process.hole_clearance")
    if not failing or "robot" not in tb or old is None or old <= 0:
        return {}
    try:
        rb, sc = from_report(trial.report)
    except (KeyError, TypeError, ValueError):
        return {}
    names = [r["name"] for r in tb["tendons"]]
    floor = trial.plan.process.min_hole
    robust = trial.plan.check.robust
    ang = np.asarray(tb["angles_deg"], float)
    n = min(SAMPLES, max(int(tb.get("samples") or 0), 1))
    out: dict[tuple, Fix] = {}
    for new in TRIED_MM:
        holes = np.maximum(rb.hole_diameter - (old - new), floor)
        try:
            res = mc.run(replace(rb, hole_diameter=holes), sc, ang, n, trial.plan.check.seed)
        except MODEL_ERRORS:
            return out
        for c in failing:
            name = c["where"].get("tendon")
            if name not in names or ident(c) in out:
                continue
            k = names.index(name)
            got = float(mc.percentile(res.worst[:, k], robust))
            own = rb.chain[k][rb.chain[k] >= 0]
            at_floor = int(np.sum(rb.hole_diameter[own] - (old - new) <= floor + 1e-6))
            note = (f"from {old:g} mm: the as-built Monte Carlo again ({n} samples) on the measured holes made "
                    f"{old - new:g} mm smaller, none under process.min_hole ({floor:g} mm)")
            if at_floor:
                note += (f"; {at_floor} of {name}'s {len(own)} holes then sit at process.min_hole, which no "
                         f"clearance shrinks: the printer's smallest hole dominates")
            out[ident(c)] = Fix({"process.hole_clearance": new},
                                {"measured": got, "passed": got <= c["limit"], "limit": c["limit"]}, (), note)
    return out
