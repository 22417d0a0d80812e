"""What each level of a sweep computes for a batch of variants, on a worker: one
:class:`~hwgen.sweep.records.Row` per variant.

``lengths`` (:mod:`.lengths`): the plan's eyelets, eq. (2) and the nominal taut path, many
variants at once. ``robust``: the full plan (:func:`hwgen.model.plan.make_plan`: its tip disk's
eyelets turned toward the drums and the base disk's seats, which the lengths level cannot see;
:func:`hwgen.checks.screens.plan_screens`, each beside its check) and the as-built Monte Carlo of :mod:`hwgen.model.scatter` on the plan's holes, seats and tensioner runs, judged at
``check.robust`` like ``hwgen check``'s ``tendon.robust``. ``coupling``: the tendon statics of
:mod:`hwgen.checks.tension` on that plan (tautness, overload, the actuating tension's rise).
``build``: the whole pipeline (:mod:`.build`), with ``hwgen check``'s report. Each level includes
the ones before it.

A variant that is bad input, or whose plan is refused, is a row with verdict ``bad input`` and
the message ``hwgen build`` would print; one that makes hwgen fail is a row with verdict
``error``; neither stops the batch. Each row's ``failures`` lists what fails (and what only warns)
one :class:`~hwgen.sweep.records.Failure` a rule (``id``, ``severity``, ``message``, ``measured``,
``limit``: what a tune's constraints read; the sweep's Parquet keeps the message), and whether one
fails the design is :attr:`Failure.fails`, the checks' one predicate.

How a batch is evaluated is an :class:`~hwgen.sweep.records.EvalOptions`. ``screen``: a variant that fails at the lengths level (eq. (2), the walls) goes no
further than ``with_plan``'s figures (its row says ``screened``): a tune's trial that cannot be
feasible costs no more than its statics;
``stop``, called with the row once ``with_plan``'s figures are in, does the same for
a trial those figures rule out (a tune's bound on the statics), and so does a plan that fails its
screens (:func:`_plan_screens`: the Monte Carlo and the tensions' statics are not run for it).
``with_plan``, when given, is called with each valid variant's plan (made for it at the
lengths level too) and returns more figures for its row: a tune's objectives
(:mod:`hwgen.tune.results`), and, as ``statics_failures``, the failure records of the checks those
figures judge (``stiffening.tip``): added to the row's failures, so they screen as the plan's do.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import replace

import numpy as np

from ..checks.screens import plan_screens
from ..errors import DesignError, InputError
from ..model import feasibility, scatter as mc
from ..model.plan import Plan, make_plan
from . import lengths
from .records import EvalOptions, Failure, Row
from .spec import Resolved, Variant, resolve



def evaluate_batch(batch: list[tuple[int, tuple]], base: dict, names: tuple[str, ...], level: str,
                   done: frozenset | set = frozenset(), options: EvalOptions | None = None) -> list[Row]:
    """Rows for the variants of ``batch`` ((index, values) pairs) whose hash is not in ``done``."""
    options = options or EvalOptions()
    if options.numba_threads:
        # a Dask worker already has a core of its own: the taut kernel's threads would only contend
        import numba
        numba.set_num_threads(options.numba_threads)
    t0 = time.process_time()
    todo = [r for r in (resolve(base, names, Variant(i, tuple(v))) for i, v in batch) if r.hash not in done]
    rows = {r.index: _row(r, level) for r in todo}
    good = [r for r in todo if r.design is not None]
    figures = _lengths(good)
    for r in good:
        row = rows[r.index]
        fig = figures[r.index]
        if isinstance(fig, str):
            row.set(verdict="error", message=fig, failures=[Failure(id="error", message=fig)])
            continue
        row.verdict, row.message, f = lengths.verdict(fig)
        row.set(**f)
        row.failures = lengths.failures(fig)
    share = (time.process_time() - t0) / max(len(todo), 1)
    for r in todo:
        rows[r.index].cpu_s = share
    if level != "lengths" or options.with_plan:
        for r in good:
            row = rows[r.index]
            if row.verdict == "error":
                continue
            screened = options.screen and any(f.fails for f in row.failures)
            if screened and not options.with_plan:
                row.screened = True             # a tune's trial that fails already: the levels after it not run
                continue
            t1 = time.process_time()
            try:
                if screened:
                    _figures_only(r, row, options)
                else:
                    _deeper(r, row, level, options)
            except (InputError, DesignError) as e:
                row.set(verdict="bad input", message=f"{e.path or '<document>'}: {e.message}")
                row.failures = [Failure(id="input", message=row.message)]
            except Exception as e:      # a variant that makes hwgen fail is a row, never the end of the sweep
                row.set(verdict="error", message=f"internal error: {type(e).__name__}: {e}"[:400])
                row.failures = [Failure(id="error", message=row.message)]
            row.cpu_s += time.process_time() - t1
    return [rows[r.index] for r in todo]


def warm() -> None:
    """Load what every batch needs (the taut kernel compiled on disk, numba's import) in this worker."""
    from ..model import taut_kernels  # noqa: F401


def _row(r: Resolved, level: str) -> Row:
    bad = r.design is None
    return Row(variant=r.index, hash=r.hash, level=level, values=r.values, verdict="bad input" if bad else "pass",
               message=r.message, failures=[Failure(id="input", message=r.message)] if bad else [])


def _lengths(good: list[Resolved]) -> dict[int, dict | str]:
    """The lengths level for the batch at once; should that fail, one at a time, so that only the
    variant that makes it fail is an error row."""
    try:
        return {r.index: f for r, f in zip(good, lengths.evaluate([r.design for r in good]))}
    except Exception:
        out: dict[int, dict | str] = {}
        for r in good:
            try:
                out[r.index] = lengths.evaluate([r.design])[0]
            except Exception as e:
                out[r.index] = f"internal error: {type(e).__name__}: {e}"[:400]
        return out


# ---------------------------------------------------------------- robust, coupling, build

def _figures_only(r: Resolved, row: Row, options: EvalOptions) -> None:
    """A screened trial's ``with_plan`` figures (a tune's statics, a fraction of the checks after
    them): every bound of its goal is then measured, so the optimiser learns how far the trial is
    from each, not only that it failed eq. (2) or a wall. A plan that is refused leaves them out."""
    row.screened = True
    try:
        plan = make_plan(r.design)
    except (InputError, DesignError):
        return
    _with_plan(row, plan, options)


def _with_plan(row: Row, plan: Plan, options: EvalOptions) -> None:
    """``with_plan``'s figures into the row, and its ``statics_failures`` into the row's failures
    (an error among them fails the row, its message added to the row's)."""
    got = dict(options.with_plan(plan))
    more = got.pop("statics_failures", [])
    row.figures.update(got)
    row.failures = list(row.failures) + more
    errors = [f.message for f in more if f.fails]
    if errors:
        row.verdict = "fail"
        row.message = "; ".join(([row.message] if row.message else []) + errors)[:2000]


def _deeper(r: Resolved, row: Row, level: str, options: EvalOptions) -> None:
    d = r.design
    plan = make_plan(d)
    feasibility.check_plan(plan, d)
    if options.with_plan:
        _with_plan(row, plan, options)
    if level == "lengths":
        return
    if options.stop and options.stop(row):
        row.screened = True            # a tune's trial its figures already rule out: the checks after them not run
        return
    centre = {t["name"]: t["centre_mm"] for t in json.loads(row.per_tendon)}
    fails = [row.message] if row.message else []
    warns = []
    failures = list(row.failures)
    for f in _plan_screens(plan):
        if not any(g.id == f.id for g in failures):
            (fails if f.fails else warns).append(f.message)
            failures.append(f)
    if options.screen and any(f.fails for f in failures):
        # a tune's trial the plan already fails: the Monte Carlo and the statics of the tensions not run
        row.set(screened=True, failures=failures, verdict="fail",
                   message="; ".join([f for f in fails if f] + [f"warning: {w}" for w in warns])[:2000])
        return
    taut_rows = robust(plan, plan.slot_clearance, options.robust_samples)
    budgeted = [t for t in taut_rows if t["budget_mm"] is not None]
    for t in budgeted:
        if t["robust_mm"] > t["budget_mm"]:
            text = (f"{t['name']} changes {t['robust_mm']:.3f} mm at {plan.check.robust} as built, "
                    f"budget {t['budget_mm']:g} mm")
            f = Failure(id="tendon.robust", message=text, severity=plan.check.robust_severity,
                        measured=t["robust_mm"], limit=t["budget_mm"], where=t["name"])
            (fails if f.fails else warns).append(text)
            failures.append(f)
    tendons = json.loads(row.per_tendon)
    for t in tendons:
        t.update({k: v for k, v in next(x for x in taut_rows if x["name"] == t["name"]).items()
                  if k in ("robust_mm", "taut_built_mm")})
    row.robust_mm = max((t["robust_mm"] for t in budgeted), default=None)
    if level in ("coupling", "build"):
        report = coupling(plan, taut_rows, centre)
        if "skipped" in report:
            warns.append(f"statics skipped: {report['skipped']}")
        for c in report.get("failed", []):
            f = Failure.of_check(c)
            (fails if f.fails else warns).append(f"{f.id}: {f.message}")
            failures.append(f)
        row.coupling = report.get("coupling")
        row.least_tension_n = report.get("least_tension_n")
    if level == "build":
        from .build import build_and_check       # CadQuery: only a build-level worker imports it, once
        failed, kept = build_and_check(r, options)
        row.checks_failed = len(failed)
        row.kept = kept
        # the build's verdict is hwgen check's, which runs every rule above on the built files (eq. (2)
        # through the centres only as information): the screening figures stay on record as warnings
        failures = [replace(f, severity="warning") for f in failures]
        failures += [replace(Failure.of_check(c), where=None) for c in failed]
        warns = [f"screening: {f}" for f in fails if f] + warns
        fails = [f"{c['id']}: {c['message']}" for c in failed[:3]]
        if len(failed) > 3:
            fails.append(f"and {len(failed) - 3} more failed checks")
    row.per_tendon = json.dumps(tendons)
    row.failures = failures
    row.verdict = "fail" if any(fails) else "pass"
    row.message = "; ".join([f for f in fails if f] + [f"warning: {w}" for w in warns])[:2000]


def _plan_screens(plan: Plan) -> list[Failure]:
    """What the full plan says that the lengths level cannot (``hwgen check`` fails each): the
    checks' own screens (:func:`hwgen.checks.screens.plan_screens`), as a row's failure records."""
    return [Failure(id=s.id, message=s.message, severity=s.severity, measured=s.measured, limit=s.limit,
                    where=s.tendon) for s in plan_screens(plan)]


def robot(plan: Plan) -> mc.Robot:
    """The robot the plan describes, as the taut-path model sees it: one hole per physical hole,
    each tendon from its seat on the base disk to its drum's tangent point (or, without a tensioner
    layout, straight on beyond the tip disk)."""
    names = [p.name for p in plan.paths]
    ND = len(plan.disks)
    chain = np.full((len(names), ND), -1)
    disk, xz, axis, dia = [], [], [], []
    for spec in plan.disks:
        for h in spec.holes:
            for t in h.tendons:
                chain[names.index(t), spec.index] = len(disk)
            disk.append(spec.index)
            xz.append((h.x, h.z))
            axis.append(h.axis)
            dia.append(h.diameter)
    base, tip = plan.disks[0], plan.disks[-1]
    seats = {s.tendon: s for s in base.seats}
    runs = {r.tendon: r for r in plan.tensioner_layout.runs} if plan.tensioner_layout else {}
    anchor, end = [], []
    for k, t in enumerate(names):
        if t in seats:
            anchor.append([seats[t].x, -base.thickness / 2 + base.seat_plate, seats[t].z])
        else:
            x, z = xz[chain[k, 0]]
            anchor.append([x, -base.thickness / 2, z])
        if t in runs:
            x, y, z = runs[t].end
            end.append([x, y - plan.stations[-1], z])
        else:
            x, z = xz[chain[k, -1]]
            end.append([x, tip.thickness / 2 + lengths.END_RUN_MM, z])
    return mc.Robot(stations=np.asarray(plan.stations, float), hole_disk=np.asarray(disk),
                    hole_xz=np.asarray(xz, float), hole_axis=np.asarray(axis, float),
                    hole_diameter=np.asarray(dia, float), chain=chain, anchor=np.asarray(anchor, float),
                    end=np.asarray(end, float), tendon_diameter=plan.tendon_material.diameter,
                    length=plan.backbone.length)


def slot_scatter(plan: Plan, c: float) -> mc.Scatter:
    """The process's stated scatter and the play each disk's slot is designed with: the strip may
    shift ``c`` (disks.slot_clearance) each way in x and z, and tilt by the clearance across the
    length that holds it (pitch and yaw: 2c over the disk and its hub; roll: 2c over the strip's
    width). ``hwgen check`` measures that play in each disk's STL instead."""
    h = plan.backbone.height
    tilt = np.array([[math.degrees(math.atan2(2 * c, s.engagement)), math.degrees(math.atan2(2 * c, h)),
                      math.degrees(math.atan2(2 * c, s.engagement))] for s in plan.disks])
    play = np.full((len(plan.disks), 2), c)
    p = plan.process
    return mc.Scatter(p.position_sigma, p.diameter_sigma, plan.jig.station_tolerance_mm, tilt, play)


def robust(plan: Plan, slot_clearance: float, samples: int) -> list[dict]:
    """Each tendon's taut path (nominal print) and its ``check.robust`` statistic over ``samples``
    as-built samples (seeded with ``check.seed``), over hwgen check's sweep; the disks' play from
    ``slot_clearance`` (:func:`slot_scatter`)."""
    s = plan.check
    ang = lengths.check_angles(s.max_angle_deg, s.step_deg)
    res = mc.run(robot(plan), slot_scatter(plan, slot_clearance), ang, samples, s.seed)
    out = []
    for k, p in enumerate(plan.paths):
        nominal = float(np.abs(res.nominal[k]).max())
        at = mc.percentile(res.worst[:, k], s.robust) if samples else nominal
        out.append({"name": p.name, "budget_mm": p.budget_mm, "taut_built_mm": nominal, "robust_mm": at})
    return out


def coupling(plan: Plan, taut_rows: list[dict], centre: dict[str, float]) -> dict:
    """The tension checks of ``hwgen check`` on the plan: the coupling (the actuating tension's
    rise with the stiffening tendons locked), the least stiffening tension as built, and the
    checks that fail."""
    from ..checks.tension import tension_checks        # numpy and scipy; deferred: only this level needs it
    report, checks = tension_checks(plan, {"tendons": [{"name": t["name"], "robust_mm": t["robust_mm"],
                                                        "taut_max_abs_delta_mm": t["taut_built_mm"]}
                                                       for t in taut_rows]}, centre)
    out: dict = {"failed": [c for c in checks if not c.passed and c.severity in ("error", "warning")]}
    if "skipped" in report:
        out["skipped"] = report["skipped"]
        return out
    rises = [s["rise"] for s in report.get("actuation", [])]
    out["coupling"] = max(rises) if rises else None
    least = [t["least_as_built_n"] for t in report.get("tendons", [])]
    out["least_tension_n"] = min(least) if least else None
    return out


def finite(v):
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else v
