"""What each level of a sweep computes for a batch of variants, on a worker: one row per variant.

``lengths`` (:mod:`.lengths`): the plan's eyelets, eq. (2) and the nominal taut path, many
variants at once. ``robust``: the full plan (:func:`hwgen.model.plan.make_plan`: its tip disk's
eyelets turned toward the drums and the base disk's seats, which the lengths level cannot see;
:func:`_plan_screens`) and the as-built Monte Carlo of :mod:`hwgen.model.scatter` on the plan's holes, seats and tensioner runs, judged at
``check.robust`` like ``hwgen check``'s ``tendon.robust``. ``coupling``: the tendon statics of
:mod:`hwgen.checks.tension` on that plan (tautness, overload, the actuating tension's rise).
``build``: the whole pipeline (:mod:`.build`), with ``hwgen check``'s report. Each level includes
the ones before it.

A variant that is bad input, or whose plan is refused, is a row with verdict ``bad input`` and
the message ``hwgen build`` would print; one that makes hwgen fail is a row with verdict
``error``; neither stops the batch. Each row's ``failures`` lists what fails (and what only warns)
one record a rule: ``id``, ``severity``, ``message``, ``measured``, ``limit`` (for a tune's
constraints; the sweep's Parquet keeps the message).

``options["screen"]``: a variant that fails at the lengths level (eq. (2), the walls) goes no
further than ``with_plan``'s figures (its row says ``screened``): a tune's trial that cannot be
feasible costs no more than its statics;
``options["stop"]``, called with the row once ``with_plan``'s figures are in, does the same for
a trial those figures rule out (a tune's bound on the statics), and so does a plan that fails its
screens (:func:`_plan_screens`: the Monte Carlo and the tensions' statics are not run for it).
``options["with_plan"]``, when given, is called with each valid variant's plan (made for it at the
lengths level too) and returns more figures for its row: a tune's objectives
(:mod:`hwgen.tune.results`).
"""
from __future__ import annotations

import json
import math
import time
from itertools import combinations

import numpy as np

from ..errors import DesignError, InputError
from ..model import feasibility, scatter as mc
from ..checks.clearances import SAG_MM, segment_distance
from ..checks.lengths import sweep_angles
from ..model import kinematics as kin
from ..model.holes import AXIS_CUT_FRACTION
from ..model.plan import Plan, make_plan
from . import lengths
from .lengths import failure
from .spec import Resolved, Variant, resolve

METRICS = ("centre_mm", "taut_mm", "robust_mm", "clearance_mm", "mass_g", "coupling", "least_tension_n")


def evaluate_batch(batch: list[tuple[int, tuple]], base: dict, names: tuple[str, ...], level: str,
                   done: frozenset | set = frozenset(), options: dict | None = None) -> list[dict]:
    """Rows for the variants of ``batch`` ((index, values) pairs) whose hash is not in ``done``."""
    options = options or {}
    if options.get("numba_threads"):
        # a Dask worker already has a core of its own: the taut kernel's threads would only contend
        import numba
        numba.set_num_threads(options["numba_threads"])
    t0 = time.process_time()
    todo = [r for r in (resolve(base, names, Variant(i, tuple(v))) for i, v in batch) if r.hash not in done]
    rows = {r.index: _row(r, level) for r in todo}
    good = [r for r in todo if r.design is not None]
    figures = _lengths(good)
    for r in good:
        row = rows[r.index]
        fig = figures[r.index]
        if isinstance(fig, str):
            row.update(verdict="error", message=fig, failures=[failure("error", fig)])
            continue
        row["verdict"], row["message"], f = lengths.verdict(fig)
        row.update(f)
        row["failures"] = lengths.failures(fig)
    share = (time.process_time() - t0) / max(len(todo), 1)
    for r in todo:
        rows[r.index]["cpu_s"] = share
    if level != "lengths" or options.get("with_plan"):
        for r in good:
            row = rows[r.index]
            if row["verdict"] == "error":
                continue
            screened = bool(options.get("screen") and any(f["severity"] == "error" for f in row["failures"]))
            if screened and not options.get("with_plan"):
                row["screened"] = True          # a tune's trial that fails already: the levels after it not run
                continue
            t1 = time.process_time()
            try:
                if screened:
                    _figures_only(r, row, options)
                else:
                    _deeper(r, row, level, options)
            except (InputError, DesignError) as e:
                row.update(verdict="bad input", message=f"{e.path or '<document>'}: {e.message}")
                row["failures"] = [failure("input", row["message"])]
            except Exception as e:      # a variant that makes hwgen fail is a row, never the end of the sweep
                row.update(verdict="error", message=f"internal error: {type(e).__name__}: {e}"[:400])
                row["failures"] = [failure("error", row["message"])]
            row["cpu_s"] += time.process_time() - t1
    return [rows[r.index] for r in todo]


def warm() -> None:
    """Load what every batch needs (the taut kernel compiled on disk, numba's import) in this worker."""
    from ..model import taut_kernels  # noqa: F401


def _row(r: Resolved, level: str) -> dict:
    row = {"variant": r.index, "hash": r.hash, "level": level, "values": r.values,
           "verdict": "bad input" if r.design is None else "pass", "message": r.message, "decoupled": None,
           "checks_failed": None, "per_tendon": None, "kept": None, "cpu_s": 0.0,
           "failures": [failure("input", r.message)] if r.design is None else []}
    row.update({m: None for m in METRICS})
    return row


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

def _figures_only(r: Resolved, row: dict, options: dict) -> None:
    """A screened trial's ``with_plan`` figures (a tune's statics, a fraction of the checks after
    them): every bound of its goal is then measured, so the optimiser learns how far the trial is
    from each, not only that it failed eq. (2) or a wall. A plan that is refused leaves them out."""
    row["screened"] = True
    try:
        plan = make_plan(r.design)
    except (InputError, DesignError):
        return
    row.update(options["with_plan"](plan))


def _deeper(r: Resolved, row: dict, level: str, options: dict) -> None:
    d = r.design
    plan = make_plan(d)
    feasibility.check_plan(plan, d)
    if options.get("with_plan"):
        row.update(options["with_plan"](plan))
    if level == "lengths":
        return
    if options.get("stop") and options["stop"](row):
        row["screened"] = True         # a tune's trial its figures already rule out: the checks after them not run
        return
    centre = {t["name"]: t["centre_mm"] for t in json.loads(row["per_tendon"])}
    fails = [row["message"]] if row["message"] else []
    warns = []
    failures = list(row["failures"])
    for f in _plan_screens(plan, d.process.min_wall):
        if not any(g["id"] == f["id"] for g in failures):
            (fails if f["severity"] == "error" else warns).append(f["message"])
            failures.append(f)
    if options.get("screen") and any(f["severity"] == "error" for f in failures):
        # a tune's trial the plan already fails: the Monte Carlo and the statics of the tensions not run
        row.update(screened=True, failures=failures, verdict="fail",
                   message="; ".join([f for f in fails if f] + [f"warning: {w}" for w in warns])[:2000])
        return
    taut_rows = robust(plan, d.disks.slot_clearance, options.get("robust_samples", 200))
    budgeted = [t for t in taut_rows if t["budget_mm"] is not None]
    for t in budgeted:
        if t["robust_mm"] > t["budget_mm"]:
            text = (f"{t['name']} changes {t['robust_mm']:.3f} mm at {d.check.robust} as built, "
                    f"budget {t['budget_mm']:g} mm")
            (fails if d.check.robust_severity == "error" else warns).append(text)
            failures.append(failure("tendon.robust", text, d.check.robust_severity, t["robust_mm"], t["budget_mm"],
                                     t["name"]))
    tendons = json.loads(row["per_tendon"])
    for t in tendons:
        t.update({k: v for k, v in next(x for x in taut_rows if x["name"] == t["name"]).items()
                  if k in ("robust_mm", "taut_built_mm")})
    row["robust_mm"] = max((t["robust_mm"] for t in budgeted), default=None)
    if level in ("coupling", "build"):
        report = coupling(plan, taut_rows, centre)
        if "skipped" in report:
            warns.append(f"statics skipped: {report['skipped']}")
        for c in report.get("failed", []):
            (fails if c["severity"] == "error" else warns).append(f"{c['id']}: {c['message']}")
            failures.append(failure(c["id"], c["message"], c["severity"], c.get("measured"), c.get("limit"),
                                     (c.get("where") or {}).get("tendon"), c.get("fix") or ""))
        row["coupling"] = report.get("coupling")
        row["least_tension_n"] = report.get("least_tension_n")
    if level == "build":
        from .build import build_and_check       # CadQuery: only a build-level worker imports it, once
        failed, kept = build_and_check(r, options)
        row["checks_failed"] = len(failed)
        row["kept"] = kept
        # the build's verdict is hwgen check's, which runs every rule above on the built files (eq. (2)
        # through the centres only as information): the screening figures stay on record as warnings
        failures = [dict(f, severity="warning") for f in failures]
        failures += [failure(c["id"], c["message"], c["severity"], c.get("measured"), c.get("limit"), None,
                             c.get("fix") or "")
                     for c in failed]
        warns = [f"screening: {f}" for f in fails if f] + warns
        fails = [f"{c['id']}: {c['message']}" for c in failed[:3]]
        if len(failed) > 3:
            fails.append(f"and {len(failed) - 3} more failed checks")
    row["per_tendon"] = json.dumps(tendons)
    row["failures"] = failures
    row["verdict"] = "fail" if any(fails) else "pass"
    row["message"] = "; ".join([f for f in fails if f] + [f"warning: {w}" for w in warns])[:2000]


def _rubbing(plan: Plan) -> dict | None:
    """``tendon.clearance`` as ``hwgen check`` judges it, from the plan's eyelet positions: the closest
    two tendons come between two disks over the check's sweep, bay by bay, leaving out the bays that
    end in an eyelet they share by design; a failure record when it is under the tendon's diameter."""
    ang = sweep_angles(plan.check.max_angle_deg, plan.check.step_deg)
    kappa = kin.kappas_for_angles(ang, plan.backbone.length)
    st = np.asarray(plan.stations, float)
    pts = {p.name: kin.points_in_space(st, p.points, kappa) for p in plan.paths}
    shared: dict[tuple[str, str], set[int]] = {}
    for m in plan.merges:
        if m.kind == "shared":
            for a, b in combinations(m.tendons, 2):
                shared.setdefault(tuple(sorted((a, b))), set()).add(m.station)
    d = plan.tendon_material.diameter
    worst = None
    for a, b in combinations(pts, 2):
        sh = shared.get(tuple(sorted((a, b))), set())
        keep = np.array([j for j in range(len(st) - 1) if j not in sh and j + 1 not in sh], int)
        if keep.size == 0:
            continue
        P, Q = pts[a], pts[b]
        gap = float(segment_distance(P[:, keep], P[:, keep + 1], Q[:, keep], Q[:, keep + 1]).min())
        if worst is None or gap < worst[0]:
            worst = (gap, a, b)
    if worst is None or worst[0] >= d:
        return None
    gap, a, b = worst
    return failure("tendon.clearance", f"{a} and {b} rub between two disks: {gap:.3f} mm apart over the sweep, "
                                       f"less than the tendon diameter {d:g} mm", "error", gap, d)


def _plan_screens(plan: Plan, min_wall: float) -> list[dict]:
    """What the full plan says that the lengths level cannot (``hwgen check`` fails each): on the tip
    disk, its eyelets turned toward the drums (sized there without the turn), tendons whose holes run
    into one opening (the plan's "overlap" merges: ``eyelet.overlap``; one with a driven tendon:
    ``eyelet.shared_sliding``) or a wall between two holes
    under ``process.min_wall`` (their circles on the mid-plane: ``eyelet.wall``); on the base disk, a
    seat as wide as its knot or crimp (a steep tendon's slanted seat: ``tendon.seat``); between the
    disks, two tendons closer than a line's diameter over the sweep (``tendon.clearance``); in the strip,
    a hole for a crossing that breaks through its edge or end (``backbone.crossing``: the helix of 30
    mm at 5 half turns lies on the 60 mm strip's edge at the middle disk)."""
    out = []
    tip = plan.disks[-1]
    hit = [m for m in plan.merges if m.kind == "overlap" and m.station == tip.index]
    if hit:
        out.append(failure("eyelet.overlap", "tendons routed into each other share one opening on the tip disk "
                                              "(its eyelets turned toward the drums): "
                            + "; ".join(" and ".join(m.tendons) for m in hit)))
    thin = _thinnest_wall(plan, min_wall)
    if thin is not None:
        w, a, b, disk = thin
        out.append(failure("eyelet.wall", f"wall {w:.2f} mm between disk {disk.index}'s eyelets for "
                                           f"{'+'.join(a.tendons)} and {'+'.join(b.tendons)} (on its axis cuts, "
                                           f"where a slanted bore drifts), under process.min_wall {min_wall:g} mm",
                           "error", w, min_wall))
    bb = plan.backbone
    for h in bb.holes:
        r = h.diameter / 2
        over = max(abs(h.x) + r - bb.height / 2, bb.y_start - (h.y - r), h.y + r - bb.y_end)   # mm past the outline
        if over >= 0:
            out.append(failure("backbone.crossing", f"{h.tendon} crosses the strip at x = {h.x:.2f}, y = {h.y:.2f} mm, "
                                                     f"where its Ø{h.diameter:.2f} hole breaks through the strip's "
                                                     f"outline (a notch, not a hole)", "error",
                                bb.height / 2 + over, bb.height / 2, h.tendon))
            break
    driven = {p.name for p in plan.paths if p.channel == plan.tensioner.actuating_channel}
    slide = [m for m in plan.merges if m.station == tip.index and driven & set(m.tendons) and len(m.tendons) > 1]
    if slide:
        out.append(failure("eyelet.shared_sliding", "a driven tendon slides through one opening with another on the "
                                                     "tip disk (its eyelets turned toward the drums): "
                            + "; ".join("+".join(m.tendons) for m in slide), plan.check.shared_sliding, 2, 1))
    rub = _rubbing(plan)
    if rub is not None:
        out.append(rub)
    for seat in plan.disks[0].seats:
        if seat.termination and seat.diameter >= seat.termination:
            out.append(failure("tendon.seat", f"{seat.tendon}'s seat on the base disk opens to Ø{seat.diameter:.2f} "
                                               f"mm: its Ø{seat.termination:g} mm termination pulls through", "error",
                                seat.diameter, seat.termination, seat.tendon))
    return out


ELLIPSE_POINTS = 90         # points on each hole's section for the wall between two: 2° apart, within 0.02 mm on
                            # a Ø3 mm hole's polygon of the files (the checks' chordal tolerance is taken off as they do)


def _section(h, y: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bore of a plan hole on the plane ``y`` mm off the disk's mid-plane: its centre drifted along
    the slanted axis, an ellipse 1/cos θ longer along the slant; (outline (ELLIPSE_POINTS, 2), centre,
    the map taking a point's offset from the centre to the unit circle)."""
    ax = np.asarray(h.axis, float)
    ay = max(abs(ax[1]), 1e-6)
    c = np.array([h.x, h.z]) + y * ax[[0, 2]] / ay
    r = h.diameter / 2
    lean = ax[[0, 2]]
    n = np.linalg.norm(lean)
    u = lean / n if n > 1e-12 else np.array([1.0, 0.0])
    v = np.array([-u[1], u[0]])
    t = np.linspace(0, 2 * np.pi, ELLIPSE_POINTS, endpoint=False)
    outline = c + np.outer(np.cos(t) * r / ay, u) + np.outer(np.sin(t) * r, v)
    return outline, c, np.stack([u * ay / r, v / r])


def _gap(a: tuple, b: tuple) -> float:
    """The least distance between two sections' outlines (0 where they overlap)."""
    (p, cp, mp), (q, cq, mq) = a, b
    inside = (np.linalg.norm((p - cq) @ mq.T, axis=1) <= 1).any() or (np.linalg.norm((q - cp) @ mp.T, axis=1) <= 1).any()
    if inside:
        return 0.0
    return float(np.sqrt(((p[:, None] - q[None]) ** 2).sum(-1)).min())


def _thinnest_wall(plan: Plan, min_wall: float):
    """(wall, hole, hole, disk) of the thinnest wall under ``min_wall`` between two eyelet holes of
    any disk, as ``eyelet.wall.eyelet`` measures it from the files: on the mid-plane and on the two
    cuts :data:`hwgen.model.holes.AXIS_CUT_FRACTION` of the thickness either side, where a slanted
    bore's section has drifted along its axis and is an ellipse (the holes' circles on the mid-plane
    alone missed walls of 0.45 mm the build then failed), less the files' chordal tolerance; None
    when every wall is thick enough."""
    worst = None
    for disk in plan.disks:
        holes = disk.holes
        h = disk.thickness * AXIS_CUT_FRACTION
        for i, a in enumerate(holes):
            for b in holes[i + 1:]:
                ra = a.diameter / 2 / max(abs(a.axis[1]), 1e-6)
                rb = b.diameter / 2 / max(abs(b.axis[1]), 1e-6)
                drift = h * (math.hypot(a.axis[0], a.axis[2]) / max(abs(a.axis[1]), 1e-6)
                             + math.hypot(b.axis[0], b.axis[2]) / max(abs(b.axis[1]), 1e-6))
                if math.hypot(a.x - b.x, a.z - b.z) - ra - rb - drift >= min_wall + 2 * SAG_MM:
                    continue            # thick enough wherever the cuts fall
                w = min(_gap(_section(a, y), _section(b, y)) for y in (0.0, -h, h)) - 2 * SAG_MM
                if w < min_wall and (worst is None or w < worst[0]):
                    worst = (max(w, 0.0), a, b, disk)
    return worst


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
    return mc.Robot(np.asarray(plan.stations, float), np.asarray(disk), np.asarray(xz, float),
                    np.asarray(axis, float), np.asarray(dia, float), chain, np.asarray(anchor, float),
                    np.asarray(end, float), plan.tendon_material.diameter, plan.backbone.length)


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
    out: dict = {"failed": [c.to_json() if hasattr(c, "to_json") else _check(c) for c in checks if not c.passed
                            and c.severity in ("error", "warning")]}
    if "skipped" in report:
        out["skipped"] = report["skipped"]
        return out
    rises = [s["rise"] for s in report.get("actuation", [])]
    out["coupling"] = max(rises) if rises else None
    least = [t["least_as_built_n"] for t in report.get("tendons", [])]
    out["least_tension_n"] = min(least) if least else None
    return out


def _check(c) -> dict:
    return {"id": c.id, "severity": c.severity, "message": c.message}


def finite(v):
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else v
