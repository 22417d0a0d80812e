"""Tendon lengths as built: the taut path through the measured holes, under print scatter and
the disks' play on the strip (:mod:`hwgen.model.taut`, :mod:`hwgen.model.scatter`).

Everything comes from the files: each hole's centre, axis and diameter as measured in its disk's
STL (the eyelet map), each disk's tilt and play as measured from its STL (:mod:`.seating`), each
tendon's seat on the base disk and its run to the tensioner's drum from the manifest. What the
files cannot show, the process's scatter and the jig's station tolerance, is design data.

The verdict on a budgeted (stiffening) tendon is its largest |ΔL| over the sweep at the
statistic ``check.robust`` (p95 by default) of ``check.samples`` as-built samples; its severity
is ``check.robust_severity``.
"""
from __future__ import annotations

import contextlib
import hashlib
from collections.abc import Callable

import numpy as np

from ..cad.manifest import Manifest
from .. import cache
from ..model import scatter as mc
from ..model import taut as tp
from .base import REBUILD, Check
from .eyelets import EyeletMap

HIST_BINS = 60        # the report's histogram of each tendon's largest |ΔL| per sample
HIST_SPAN = 1.08      # over 0 .. this × the largest of it, the budget and the centre-line value
END_RUN_MM = 20.0     # without a tensioner run: the tendon leaves the tip straight along the backbone this far


def robot(emap: EyeletMap, rep: dict, manifest: Manifest, tendon_d: float, length: float) -> mc.Robot:
    """The measured robot: one hole per physical hole (a shared hole once), every tendon's chain,
    its anchor at its seat and its end at its drum's tangent point."""
    design_holes = {(rd["index"], tuple(h["tendons"])): h for rd in rep["disks"] for h in rd["holes"]}
    names = [t["name"] for t in rep["tendons"]]
    ND = len(rep["stations_mm"])
    chain = np.full((len(names), ND), -1)
    disk, xz, axis, dia, seen = [], [], [], [], {}
    for e in emap.eyelets:
        key = id(e.hole) if e.hole is not None and e.status == "merged" else id(e)
        if key not in seen:
            h = design_holes[(e.station, e.tendons)]
            seen[key] = len(disk)
            disk.append(e.station)
            xz.append(e.measured_xz if e.measured_xz is not None else e.design_xz)
            found = e.hole is not None and e.hole.axis is not None and e.status in ("ok", "moved")
            axis.append(e.hole.axis if found else np.asarray(h["axis"], float))
            dia.append(e.hole.diameter if found else h["diameter_mm"])
        for t in e.tendons:
            chain[names.index(t), e.station] = seen[key]
    base, tip = rep["disks"][0], rep["disks"][-1]
    seats = {s["tendon"]: s for s in base.get("seats", [])}
    runs = {r["tendon"]: r for p in manifest.parts for r in p.tendon_runs}
    anchor, end = [], []
    for k, t in enumerate(names):
        if t in seats:     # the tendon leaves its seat at the plate's inner face
            anchor.append([seats[t]["x"], -base["thickness_mm"] / 2 + base.get("seat_plate_mm", 0.0), seats[t]["z"]])
        else:
            x, z = xz[chain[k, 0]]
            anchor.append([x, -base["thickness_mm"] / 2, z])
        if t in runs:
            x, y, z = runs[t]["end"]
            end.append([x, y - rep["stations_mm"][-1], z])
        else:
            x, z = xz[chain[k, -1]]
            end.append([x, tip["thickness_mm"] / 2 + END_RUN_MM, z])
    return mc.Robot(stations=np.asarray(emap.stations_y, float), hole_disk=np.asarray(disk),
                    hole_xz=np.asarray(xz, float), hole_axis=np.asarray(axis, float),
                    hole_diameter=np.asarray(dia, float), chain=chain, anchor=np.asarray(anchor, float),
                    end=np.asarray(end, float), tendon_diameter=tendon_d, length=length)


def process_scatter(n_disks: int, position_sigma: float, diameter_sigma: float, station_tolerance: float,
                    fits) -> mc.Scatter:
    """The stated process and the play measured in each disk's STL (half ranges about the middle)."""
    tilt, play = _play(n_disks, [f.to_json() for f in fits])
    return mc.Scatter(position_sigma, diameter_sigma, station_tolerance, tilt, play)


def _play(n: int, fits: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """Per disk (n, 3) tilt half ranges about x, y, z (deg) and (n, 2) offset half ranges in x, z (mm),
    from the fits measured in the STLs (as in report.json); a disk not measured has none."""
    tilt, play = np.zeros((n, 3)), np.zeros((n, 2))
    for f in fits:
        tilt[f["station"]] = [np.ptp(f["tilt_x_deg"]) / 2, np.ptp(f["tilt_y_deg"]) / 2, np.ptp(f["tilt_z_deg"]) / 2]
        play[f["station"]] = [max(f["play_x_mm"], 0.0) / 2, max(f["play_z_mm"], 0.0) / 2]
    return tilt, play


def as_built(emap: EyeletMap, rep: dict, manifest: Manifest, plan, fits, angles: np.ndarray,
             deviations: dict[str, list], centre: dict[str, float]) -> tuple[dict, list[Check]]:
    """The taut-path report section and its checks: one verdict per budgeted tendon, the pair's take-up.
    ``centre``: each tendon's largest |ΔL| by eq. (2) between the measured hole centres (quoted beside)."""
    s, proc, channel = plan.check, plan.process, plan.tensioner.actuating_channel
    rb = robot(emap, rep, manifest, plan.tendon_material.diameter, plan.backbone.length)
    sc = process_scatter(len(plan.disks), proc.position_sigma, proc.diameter_sigma, plan.jig.station_tolerance_mm, fits)
    names = [t["name"] for t in rep["tendons"]]
    act = [k for k, t in enumerate(rep["tendons"]) if t["channel"] == channel]
    budgets = [t["budget_mm"] for t in rep["tendons"]]
    res = monte_carlo(rb, sc, angles, s.samples, s, tuple(act) if len(act) == 2 else None, budgets)
    checks, rows = [], []
    for k, t in enumerate(rep["tendons"]):
        budget = t["budget_mm"]
        worst = res.worst[:, k]
        row = {"name": t["name"], "channel": t["channel"], "budget_mm": budget,
               "centreline_max_abs_delta_mm": centre[t["name"]],
               "taut_rest_length_mm": float(res.rest[k]),
               "taut_max_abs_delta_mm": float(np.abs(res.nominal[k]).max()),
               "taut_delta_mm": res.nominal[k], **(mc.statistics(worst, budget) if len(worst) else {})}
        if len(worst):
            hi = max(float(worst.max()), budget or 0.0, row["centreline_max_abs_delta_mm"]) * HIST_SPAN
            counts, edges = np.histogram(worst, bins=HIST_BINS, range=(0.0, hi))
            row["histogram"] = {"edges_mm": edges, "counts": counts}
        if budget is not None:
            at = mc.percentile(worst, s.robust) if len(worst) else row["taut_max_abs_delta_mm"]
            row.update(robust_mm=at, passed=at <= budget)
            if len(worst) and s.robust != "max":
                row["robust_interval_mm"] = list(mc.quantile_interval(
                    worst, _quantile(s.robust), _look_confidence(s, len(mc.looks(s.samples)))))
            checks.append(_verdict(row, s, len(worst), deviations.get(t["name"], [])))
        rows.append(row)
    out = {"about": "taut path through each measured hole's free aperture ((D - d)/2 in its own plane), from the "
                    "tendon's seat to its drum's tangent point; as built: print scatter, disk slip within the jig's "
                    "tolerance, tilt and offset within the play measured in each disk's STL",
           "samples": len(res.worst), "seed": s.seed, "tendon_diameter_mm": rb.tendon_diameter,
           "stop": stop_rule(s, s.samples, len(res.worst)),
           "length_mm": rb.length, "robust": s.robust,
           "unconverged_solves": res.unconverged,
           "process": {"position_sigma_mm": sc.sigma_pos, "diameter_sigma_mm": sc.sigma_dia,
                       "station_tolerance_mm": sc.station,
                       "tilt_half_range_deg": sc.tilt.max(axis=0), "play_half_range_mm": sc.play.max(axis=0)},
           "robot": {"stations_mm": rb.stations, "holes": [
               {"disk": int(i), "xz_mm": c, "axis": a, "diameter_mm": float(dd)}
               for i, c, a, dd in zip(rb.hole_disk, rb.hole_xz, rb.hole_axis, rb.hole_diameter)],
               "chains": rb.chain, "anchors_mm": rb.anchor, "ends_mm": rb.end},
           "angles_deg": angles, "percentiles": list(mc.PERCENTILES),
           "tendons": rows, "band_mm": res.band, "envelope_mm": res.envelope}
    if res.unconverged:
        checks.append(Check("tendon.taut_solver", "warning", False,
                            f"{res.unconverged} taut-path solves stopped before converging: their lengths are "
                            f"upper bounds", float(res.unconverged), 0.0, {},
                            fix=f"nothing in the design: a tendon.robust that passes on upper bounds holds; one that "
                                f"fails by little may pass; {REBUILD}"))
    if res.take_up is not None and len(res.take_up):
        i, j = act
        pair = {"channel": channel, "tendons": [names[i], names[j]],
                "centreline_mm": res.pair_nominal[0], "taut_mm": res.pair_nominal[1], **mc.statistics(res.take_up)}
        out["pair"] = pair
        checks.append(Check("tendon.take_up_as_built", "info", True,
                            f"actuating pair {' and '.join(pair['tendons'])}: slack to take up over the sweep "
                            f"{pair['centreline_mm']:.3f} mm through the hole centres, {pair['taut_mm']:.3f} mm taut, "
                            f"as built p50 {pair['p50_mm']:.3f}, p95 {pair['p95_mm']:.3f}, max {pair['max_mm']:.3f} mm",
                            pair["p95_mm"], None, {"channel": pair["channel"], "tendons": pair["tendons"]}))
    return out, checks


def _quantile(robust: str) -> float:
    return float(robust[1:]) / 100


def _look_confidence(s, looks: int) -> float:
    """The confidence of each look's interval that keeps ``check.robust_confidence`` over ``looks`` looks."""
    return 1.0 - (1.0 - s.robust_confidence) / looks


def enough_samples(budgets: list[float | None], s) -> Callable[[np.ndarray, int], bool]:
    """The Monte Carlo's stop rule: at each look, every budgeted tendon's ``check.robust`` statistic
    has an interval from order statistics (:func:`hwgen.model.scatter.quantile_interval`) at
    confidence 1 − (1 − ``check.robust_confidence``) / looks (Bonferroni over the looks the run may
    take, so stopping at any of them keeps the stated confidence); the run stops when every such
    interval lies wholly above or wholly at or below its budget, or is no wider than
    ``check.robust_precision_mm``. "max" has no such interval: that run draws every sample."""
    judged = [(k, b) for k, b in enumerate(budgets) if b is not None]

    def enough(worst: np.ndarray, looks: int) -> bool:
        if s.robust == "max":
            return False
        conf = _look_confidence(s, looks)
        for k, budget in judged:
            lo, hi = mc.quantile_interval(worst[:, k], _quantile(s.robust), conf)
            if not (lo > budget or hi <= budget or hi - lo <= s.robust_precision_mm):
                return False
        return True
    return enough


def stop_rule(s, most: int, drawn: int) -> dict:
    """The report's account of the stop rule and where the run stopped."""
    return {"rule": "stop at a look (samples " + ", ".join(map(str, mc.looks(most))) + ") once every budgeted "
                    f"tendon's {s.robust} interval (order statistics, {s.robust_confidence:g} confidence over all "
                    f"looks) lies clear of its budget or within {s.robust_precision_mm:g} mm" if most else "no samples",
            "most_samples": most, "samples": drawn, "confidence": s.robust_confidence,
            "precision_mm": s.robust_precision_mm}


def monte_carlo(rb: mc.Robot, sc: mc.Scatter, angles: np.ndarray, n: int, s, pair, budgets) -> mc.Result:
    """:func:`hwgen.model.scatter.run` with the stop rule, or what it gave last time for this very
    robot (every measured hole, disk play, anchor and end), scatter, sweep and rule (remembered in
    the active cache; the same result either way)."""
    inputs = (rb, sc, angles, n, s.seed, pair, budgets, s.robust, s.robust_confidence, s.robust_precision_mm)
    doc = cache.remembered("as-built monte carlo", inputs, lambda: mc.to_json(
        mc.run(rb, sc, angles, n, s.seed, pair, enough_samples(budgets, s), kept_sweep)))
    return mc.from_json(doc)


def kept_sweep(ch: tp.Chains, angles_deg, length: float) -> tuple[np.ndarray, np.ndarray, int]:
    """:func:`hwgen.model.taut.sweep`, each tendon's lengths kept in the active cache under exactly
    what its solves read (:func:`hwgen.model.taut.tendons`: the same lengths to the bit): its holes'
    centres, planes and free radii and its anchor and end in every sample, the disks' stations and
    slips, the sweep's angles, the length, the solver's tolerance (and, as every entry, the code). An edit that
    moves one tendon's holes leaves the others' samples as they were (the scatter is drawn per hole
    and per disk), and their solves are not done again; the tendons not kept are swept together."""
    ang = np.asarray(angles_deg, float)
    S, T = ch.C.shape[0], ch.chain.shape[0]
    inputs = [(_digest(ch.C[:, h], ch.E[:, h], ch.r[:, h], ch.hole_disk[h], ch.anchor[:, t], ch.end[:, t],
                       ch.stations, ch.dy, ang), float(length), tp.TOL)
              for t, h in enumerate(ch.chain)]
    got: dict[int, dict] = {}
    for t in range(T):
        with contextlib.suppress(_NotKept):     # not kept: solved below with the others
            got[t] = cache.kept_arrays(TENDON_SWEEP, inputs[t], _not_kept)
    todo = [t for t in range(T) if t not in got]
    if todo:
        L, L0, bad = tp.sweep(tp.tendons(ch, todo), ang, length)
        for i, t in enumerate(todo):
            if bad:     # rare: whose they are, tendon by tendon
                Lt, L0t, b = tp.sweep(tp.tendons(ch, [t]), ang, length)
                one = {"lengths": Lt[:, 0], "straight": L0t[:, 0], "unconverged": np.array([b], np.int64)}
            else:
                one = {"lengths": L[:, i], "straight": L0[:, i], "unconverged": np.zeros(1, np.int64)}
            got[t] = cache.kept_arrays(TENDON_SWEEP, inputs[t], lambda one=one: one)
    lengths, straight = np.empty((S, T, len(ang))), np.empty((S, T))
    for t in range(T):
        lengths[:, t], straight[:, t] = got[t]["lengths"], got[t]["straight"]
    return lengths, straight, sum(int(got[t]["unconverged"][0]) for t in range(T))


TENDON_SWEEP = "taut sweep of a tendon"


class _NotKept(Exception):
    pass


def _not_kept():
    raise _NotKept


def _digest(*arrays: np.ndarray) -> str:
    """sha256 of the arrays' dtypes, shapes and bytes."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def from_report(report: dict) -> tuple[mc.Robot, mc.Scatter]:
    """The measured robot and the stated scatter back from a report.json (for what-ifs and tests)."""
    tb, fits = report["as_built"]["taut"], report["as_built"]["disks"]
    rb, p = tb["robot"], tb["process"]
    h = rb["holes"]
    robot_ = mc.Robot(stations=np.asarray(rb["stations_mm"], float), hole_disk=np.array([x["disk"] for x in h]),
                      hole_xz=np.array([x["xz_mm"] for x in h], float),
                      hole_axis=np.array([x["axis"] for x in h], float),
                      hole_diameter=np.array([x["diameter_mm"] for x in h], float), chain=np.asarray(rb["chains"]),
                      anchor=np.asarray(rb["anchors_mm"], float), end=np.asarray(rb["ends_mm"], float),
                      tendon_diameter=tb["tendon_diameter_mm"], length=tb["length_mm"])
    tilt, play = _play(len(robot_.stations), fits)
    return robot_, mc.Scatter(p["position_sigma_mm"], p["diameter_sigma_mm"], p["station_tolerance_mm"], tilt, play)


def _verdict(row: dict, s, n: int, devs: list) -> Check:
    """"C2: 0.188 mm through the hole centres, 0.493 mm taut, 0.594 mm at p95 — fails"; ``n`` samples."""
    ok = row["passed"]
    msg = (f"{row['name']}: {row['centreline_max_abs_delta_mm']:.3f} mm through the hole centres, "
           f"{row['taut_max_abs_delta_mm']:.3f} mm taut (nominal print)")
    if n:
        iv = row.get("robust_interval_mm")
        iv = f" ({s.robust_confidence:.0%} interval {iv[0]:.3f}-{iv[1]:.3f})" if iv and np.all(np.isfinite(iv)) else ""
        msg += (f", {row['robust_mm']:.3f} mm at {s.robust}{iv} of {n} as-built samples (p50 {row['p50_mm']:.3f}, "
                f"max {row['max_mm']:.3f}; {100 * row['p_within']:.0f} % within)")
    msg += f", budget {row['budget_mm']:g} mm — {'passes' if ok else 'fails'}"
    big = [(j, d) for j, d in devs if d > 1e-3]
    if not ok and big:
        m = max(d for _, d in big)
        msg += (f". Its eyelet table does not sample the eq. (3) function it names: it departs by up to {m:.2f} mm "
                f"at stations {[j for j, d in big if d > 0.5 * m]}")
    return Check("tendon.robust", s.robust_severity, ok, msg, row["robust_mm"], row["budget_mm"],
                 {"tendon": row["name"], "channel": row["channel"], "statistic": s.robust if n else "nominal"},
                 fix="" if ok else _robust_fix(row, s),
                 lowered_by="check.robust_severity" if not ok and s.robust_severity == "warning" else "")


def _robust_fix(row: dict, s) -> str:
    """What to change for a tendon whose length change as built is over its budget, led by the
    largest of its three parts: the routing (through the hole centres), the eyelets' play (the taut
    path cutting corners in them) and the print's scatter."""
    name, budget = row["name"], row["budget_mm"]
    centre, taut = row["centreline_max_abs_delta_mm"], row["taut_max_abs_delta_mm"]
    robust = row["robust_mm"] if row.get("robust_mm") is not None else taut
    parts = [(centre, f"route {name} so its length changes less over the bend (tendons[].routing: eq. (3) with a "
                      f"smaller amplitude or more half waves): through the hole centres it changes {centre:.3f} mm"),
             (taut - centre, f"tighter eyelets (process.hole_clearance; tube eyelets pressed in): the line's play in "
                             f"its eyelets lets the taut path cut {max(taut - centre, 0.0):.3f} mm of corners"),
             (robust - taut, f"a more precise print (process.position_sigma, diameter_sigma; jig.station_tolerance_mm): "
                             f"the scatter adds {max(robust - taut, 0.0):.3f} mm at {s.robust}")]
    parts.sort(key=lambda p: -p[0])
    return ("; or ".join(text for share, text in parts if share > 0.01 * budget)
            + f"; or a larger budget (tendons[].budget_mm, now {budget:g} mm) if the robot bears the coupling"
            + ("" if s.robust_severity == "warning" else
               "; or state it as a warning (check.robust_severity: warning) with its reason in this design's file"))
