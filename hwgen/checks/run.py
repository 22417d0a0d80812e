"""Run every check on a built design folder and gather one report.

``run_checks`` measures the files listed in the manifest (whatever they hold now) and compares
them with the design intent recorded there. Whether the folder must be rebuilt first is the
pipeline's business (:func:`hwgen.pipeline.check`), not this module's.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import __version__
from ..cad.manifest import Manifest, manifest_files, manifest_parts, sha256
from ..model import kinematics as kin
from ..model.routing import table_deviations
from .anchors import seat_checks
from .base import REBUILD, Check, failing
from .clearances import StripBend, backbone_checks, hole_checks, tendon_pair_checks, wall_checks
from .sliding import driven_tendons, sliding_checks
from .eyelets import backbone_section, locate_eyelets, measure_disk
from .bench import bench_checks
from .fixtures import jig_checks, mount_checks
from .gear_mesh import gear_checks, gear_pairs
from .gravity import gravity_checks
from .lengths import length_checks, pair_take_up, sweep_angles, tendon_lengths
from .. import heap
from .meshes import drop_solids, one_load_per_mesh
from .parts import build_volume_checks, interference_checks, load_parts, mass_summary, mesh_checks
from .printing import printing_checks
from .report import Report
from .seating import hub_checks, measure_fit, tilt_checks
from .taut import as_built
from .tendon_runs import tendon_checks
from .tension import tension_checks

TABLE_MATCH_MM = 0.1   # Table II gives one decimal: a table within this of its function samples it


def _plain(v):
    """numpy scalars and arrays to JSON-able Python values, recursively."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        v = float(v)
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def _file_checks(folder: Path, manifest: Manifest) -> list[Check]:
    out = []
    entries = manifest_files(manifest)
    changed, missing = [], []
    for f in entries:
        path = folder / f.path
        if not path.exists():
            missing.append(f.path)
        elif sha256(path) != f.sha256:
            changed.append(f.path)
    if missing:
        out.append(Check("files.present", "error", False, f"missing: {', '.join(missing)}", float(len(missing)),
                         0.0, {"files": missing}, fix="build again (hwgen build) to write them"))
    else:
        out.append(Check("files.present", "error", True, f"all {len(entries)} files of the manifest are present",
                         0.0, 0.0, {}))
    if changed:
        out.append(Check("files.unchanged", "warning", False,
                         f"changed since the build (sha256 differs from the manifest), measured as found: "
                         f"{', '.join(changed)}", float(len(changed)), 0.0, {"files": changed},
                         fix="build again (hwgen build) for the files the design makes, or keep the edits knowingly"))
    else:
        out.append(Check("files.unchanged", "warning", True, "every file is as the build wrote it", 0.0, 0.0, {}))
    return out


def _strip_clamp_checks(manifest: Manifest) -> list[Check]:
    """A warning where the tensioner was laid out without the block that clamps the strip's tip
    (a tendon leaves the tip where it would stand): as its housing's layout record says."""
    return [Check("tensioner.strip_clamp", "warning", False,
                  f"{p.name}: strip clamp {p.meta['layout_search']['strip_clamp']}", None, None, {"part": p.name},
                  fix="route the tendons to leave the tip disk clear of the strip's end (tendons[].routing at the "
                      "tip station), or hold the strip's tip in the housing by other means")
            for p in manifest.parts if "strip_clamp" in p.meta.get("layout_search", {})]


def run_checks(folder: str | Path, manifest: Manifest, plan, measured: Measured | None = None) -> Report:
    """Measure the design in ``folder`` against the intent in its manifest; return the report
    (:class:`hwgen.checks.report.Report`: every key and what it holds): the files' own checks
    (every file of the manifest present and as the build wrote it), then what :func:`measure`
    finds, or ``measured``, what it found on these very files before (a build measures them
    while it writes assembly.step, which no check but the files' own reads)."""
    folder = Path(folder)
    checks = _file_checks(folder, manifest)
    m = measured if measured is not None else measure(folder, manifest, plan)
    report = _report(manifest.name, checks + m.checks, m.angles, plan.check.step_deg, m.tls, m.pair, m.emap,
                     m.taut)
    report.update(m.sections)
    return report


class Measured(NamedTuple):
    """What :func:`measure` found: its checks and what the report gathers from them."""
    checks: list[Check]
    angles: np.ndarray
    tls: list
    pair: dict | None
    emap: object
    taut: dict
    sections: dict          # the report's mass, as_built, seats, gravity and tension


def backbone_template(manifest: Manifest) -> str:
    """The strip's DXF template's path in the folder, as the manifest names it."""
    return manifest.files.get("backbone_template", {}).get("path", "backbone_template.dxf")


def measure(folder: str | Path, manifest: Manifest, plan, gears_made: Callable[[], None] | None = None) -> Measured:
    """Every check but the files' own, measured from the parts' STLs and the strip's DXF template
    (:func:`backbone_template`; the only entry of the manifest's ``files`` read) against the
    manifest's parts and design report. Every STL is read once and handed to every check that
    needs it. ``gears_made``: waits for the gear measurements another process is making (a build's
    work ahead), called before the gear checks, which then read them from the cache."""
    with one_load_per_mesh():
        return _measure(Path(folder), manifest, plan, gears_made)


def _measure(folder: Path, manifest: Manifest, plan, gears_made: Callable[[], None] | None = None) -> Measured:
    s = plan.check
    rep_in = manifest.design_report
    checks: list[Check] = []
    parts, c = load_parts(folder, manifest)
    checks += c
    disks, c = _measure_disks(folder, manifest, {p.name: p.mesh for p in parts}, s.position_tol_mm)
    checks += c
    bb_outline, bb_holes, strip_t, c = _measure_strip(folder, manifest)
    checks += c
    emap, c = locate_eyelets(disks, rep_in, bb_holes, s.position_tol_mm)
    checks += c

    angles = sweep_angles(s.max_angle_deg, s.step_deg)
    L = plan.backbone.length
    tls = tendon_lengths(emap, rep_in, angles, L)
    devs, fdelta, c = _routing_checks(plan, emap.stations_y, angles)
    checks += c
    checks += length_checks(tls, emap, devs, fdelta)
    pair = pair_take_up(tls, plan.tensioner.actuating_channel)
    if pair:
        checks.append(_take_up_check(pair))

    proc, td = plan.process, plan.tendon_material.diameter
    driven = driven_tendons(rep_in, plan.tensioner.actuating_channel)
    checks += wall_checks(emap, rep_in, proc.min_wall, driven)
    checks += sliding_checks(emap, rep_in, plan.tensioner.actuating_channel, proc.min_wall, s.shared_sliding)
    checks += hole_checks(emap, proc.min_hole, td, angles, L, tip_exits(manifest))
    checks += tendon_pair_checks(emap, rep_in, td, angles, L, driven)
    checks += backbone_checks(emap, folder / backbone_template(manifest), bb_outline, bb_holes, td,
                              s.position_tol_mm, rep_in.get("findings", []), StripBend(strip_t, angles, L))
    checks += mesh_checks(parts)
    checks += interference_checks(parts, s.interference_tol_mm3)
    checks += build_volume_checks(parts, proc.build_volume)
    checks += printing_checks(parts, proc.technology)
    checks += mount_checks(parts, disks, plan) + jig_checks(parts, disks, plan)
    # the tendon runs are measured against the placed solids the interference check has just made
    # (their place in the report is further down)
    runs = tendon_checks(folder, manifest, plan) if gear_pairs(manifest.parts) else []   # no tensioner: no runs
    drop_solids()           # the whole parts' solids are done with: the Monte Carlo's memory comes next
    heap.trim()
    mass, c = mass_summary(parts, manifest)
    checks += c
    # the gear checks' place in the report; they are measured last, when a build has had them made
    # meanwhile (in a process of its own, kept in the cache: hwgen.engine.concurrency.Ahead)
    gears_at = len(checks)
    checks += runs
    checks += _strip_clamp_checks(manifest)
    fits, c = _seating(parts, emap, bb_outline, strip_t, plan, angles)
    checks += c
    seats, c = _seats(parts, emap, rep_in, plan)
    checks += c
    taut, c = as_built(emap, rep_in, manifest, plan, fits, angles, devs, {t.name: t.max_abs_delta for t in tls})
    checks += c
    tension, c = tension_checks(plan, taut, {t.name: t.max_abs_delta for t in tls})
    checks += c
    gravity, c = gravity_checks(parts, manifest, plan, fits, None if bb_outline is None else bb_outline.extent[0],
                                strip_t, L)
    checks += c
    bench, c = bench_checks(parts, plan)
    checks += c
    if gears_made is not None:
        gears_made()
    checks[gears_at:gears_at] = gear_checks(folder, manifest.parts, plan)
    sections_bench = {"bench": _plain(bench)} if bench else {}
    return Measured(checks, angles, tls, pair, emap, taut, {
        "mass": _plain(mass),
        "as_built": _plain({
            "about": "what the files let each disk do on the strip (measured from its STL) and how well the jig "
                     "sets its station (design data: jig.station_tolerance_mm), for a study of as-built tendon "
                     "lengths",
            "station_tolerance_mm": plan.jig.station_tolerance_mm,
            "max_tilt_deg": plan.hub.max_tilt_deg,
            "disks": [f.to_json() for f in fits],
            "taut": taut}),
        "seats": _plain(seats),
        "gravity": _plain(gravity),
        "tension": _plain(tension), **sections_bench})


def _seating(parts, emap, bb_outline, strip_t, plan, angles):
    """Each disk's slot fit (tilt, play, engagement) and its hub against the tendons."""
    by_name = {p.name: p for p in parts}
    h = bb_outline.extent[0] if bb_outline is not None else plan.backbone.height
    t = strip_t if strip_t is not None else plan.backbone.thickness
    fits = [measure_fit(dk, by_name[dk.part].mesh, by_name[dk.part].placement, h, t)
            for dk in emap.disks if dk.part in by_name]
    radius = {e.station: 0.0 for e in emap.eyelets}
    for e in emap.eyelets:
        radius[e.station] = max(radius[e.station], float(np.hypot(*e.design_xz)))
    checks = tilt_checks(fits, plan.hub.max_tilt_deg, radius,
                         (plan.disks[0].slot_height - plan.backbone.thickness) / 2)   # disks.slot_clearance
    checks += hub_checks(emap, fits, {p.name: p.mesh for p in parts}, {p.name: p.placement for p in parts},
                         plan.tendon_material.diameter, angles, plan.backbone.length)
    return fits, checks


def _seats(parts, emap, rep_in, plan):
    """The tendons' seats on the base disk."""
    by_name = {p.name: p for p in parts}
    ends = {p.name: p.termination for p in plan.paths}
    out, rows = [], []
    for dk in emap.disks:
        rd = next((r for r in rep_in["disks"] if r["index"] == dk.station), None)
        if rd is None or not rd.get("seats") or dk.part not in by_name:
            continue
        c, r = seat_checks(dk, by_name[dk.part].mesh, by_name[dk.part].placement, rd, ends, plan.process.min_wall,
                           plan.tendon_material.break_load, plan.tensioner.resin_strength)
        out += c
        rows += r
    return rows, out


def _measure_disks(folder: Path, manifest: Manifest, meshes: dict, tol: float):
    """Every disk's STL sectioned (through its placement), and where its mid-plane lies."""
    ys = manifest.design_report["stations_mm"]
    # how deep the base disk's seat plate and the chambers over it reach from its outer face
    # (design data): the axis cuts stay clear of them
    recess = {d["index"]: (d.get("seat_plate_mm", 0.0) or 0.0)
              + max((c["height_mm"] for c in d.get("seat_chambers", [])), default=0.0)
              for d in manifest.design_report["disks"] if d.get("seats")}
    disks, checks = [], []
    for p in manifest_parts(manifest):
        if p.role != "disk":
            continue
        stl = p.stl_in(folder)
        if not stl.exists():
            continue
        try:
            dk = measure_disk(stl, p.placement, p.name, int(p.station), meshes.get(p.name),
                              recess.get(int(p.station), 0.0))
        except Exception as e:
            checks.append(Check("disk.section", "error", False, f"{p.name}: cannot be measured ({e})",
                                None, None, {"part": p.name}, fix=REBUILD))
            continue
        disks.append(dk)
        dy = abs(dk.y_mid - ys[dk.station])
        checks.append(Check("disk.station", "error", dy <= tol,
                            f"{dk.part}: mid-plane at y={dk.y_mid:.4f} mm, station {dk.station} is at "
                            f"y={ys[dk.station]:g} mm", dy, tol, {"part": dk.part, "station": dk.station},
                            fix="" if dy <= tol else REBUILD))
    return disks, checks


def _measure_strip(folder: Path, manifest: Manifest):
    """The strip's outline, holes and thickness from its STL (None where it cannot be read)."""
    bb = next((p for p in manifest_parts(manifest) if p.role == "backbone"), None)
    if bb is None or not bb.stl_in(folder).exists():
        return None, None, None, []
    try:
        return (*backbone_section(bb.stl_in(folder), bb.placement), [])
    except Exception as e:
        return None, None, None, [Check("backbone.section", "error", False, f"{bb.name}: cannot be measured "
                                        f"({e})", None, None, {"part": bb.name}, fix=REBUILD)]


def _routing_checks(plan, stations_y: np.ndarray, angles: np.ndarray):
    """Where a tendon gives a table and a function: how far they part, and the length change the
    function's own eyelets would have. Returns (deviations, function deltas, checks)."""
    devs: dict[str, list] = {}
    for dv in table_deviations(plan.paths):
        devs.setdefault(dv.tendon, []).append((dv.station, dv.distance))
    fdelta = {}
    kappa = kin.kappas_for_angles(angles, plan.backbone.length)
    for p in plan.paths:
        if p.function_points is not None:
            Lf = kin.tendon_lengths(stations_y, p.function_points, kappa)
            fdelta[p.name] = float(np.abs(Lf - Lf[angles == 0][0]).max())
    checks = []
    for name, dl in devs.items():
        big = max(x for _, x in dl)
        ok = big <= TABLE_MATCH_MM
        at = [j for j, x in dl if x > max(TABLE_MATCH_MM, 0.5 * big)]
        checks.append(Check("routing.table_vs_function", "warning", ok,
                            f"{name}: eyelet table matches its eq. (3) function within {big:.4f} mm" if ok else
                            f"{name}: eyelet table departs from the eq. (3) function it names by up to {big:.2f} mm "
                            f"(stations {at}); the geometry follows the table",
                            big, TABLE_MATCH_MM, {"tendon": name, "stations": at},
                            fix="" if ok else f"make {name}'s routing.table and routing.function agree, or give only "
                                              f"the one you mean (the geometry follows the table)"))
    return devs, fdelta, checks


def _take_up_check(pair: dict) -> Check:
    return Check("tendon.take_up", "info", True,
                 f"antagonistic pair {' and '.join(pair['tendons'])} (channel {pair['channel']}): one pays "
                 f"out less than the other hauls in, {abs(pair['take_up_mm']):.3f} mm of "
                 f"{'slack to take up' if pair['take_up_mm'] >= 0 else 'extra length to supply'} "
                 f"at {pair['at_angle_deg']:+g}°", pair["take_up_mm"], None,
                 {"channel": pair["channel"], "tendons": pair["tendons"]})


def _report(name: str, checks: list[Check], angles, step_deg: float, tls, pair, emap, taut: dict) -> dict:
    """``tendons``: eq. (2) through the measured hole centres beside the taut path (nominal print)
    and the as-built statistic; ``passed`` is the verdict, on the taut path as built."""
    ok = not failing(checks)
    tt = {r["name"]: r for r in taut["tendons"]}
    return _plain({
        "design": name,
        "ok": ok,
        "hwgen_version": __version__,
        "sweep": {"max_angle_deg": float(angles[-1]), "step_deg": step_deg, "angles_deg": angles.tolist()},
        "checks": [c.to_json() for c in checks],
        "tendons": [{
            "name": t.name, "channel": t.channel, "source": "geometry",
            "rest_length_mm": t.rest,
            "delta_at_max_mm": float(t.delta[-1]), "delta_at_min_mm": float(t.delta[0]),
            "max_abs_delta_mm": t.max_abs_delta, "budget_mm": t.budget, "centreline_passed": t.passed,
            "taut_rest_length_mm": tt[t.name]["taut_rest_length_mm"],
            "taut_max_abs_delta_mm": tt[t.name]["taut_max_abs_delta_mm"],
            "robust_mm": tt[t.name].get("robust_mm"), "passed": tt[t.name].get("passed", True),
            "stations_from_backbone": emap.via_backbone.get(t.name, []),
            "stations_from_design": emap.unmeasured.get(t.name, []),
            "delta_mm": [float(v) for v in t.delta],
            "taut_delta_mm": [float(v) for v in tt[t.name]["taut_delta_mm"]],
        } for t in tls],
        "pairs": [pair] if pair else [],
        "eyelets": [{
            "station": e.station, "part": e.part, "tendons": list(e.tendons), "status": e.status,
            "design_xz_mm": e.design_xz.tolist(),
            "measured_xz_mm": None if e.measured_xz is None else [float(v) for v in e.measured_xz],
            "offset_mm": None if not np.isfinite(e.offset) else e.offset,
            "diameter_mm": None if e.hole is None else e.hole.diameter,
            "axis": None if e.hole is None or e.hole.axis is None else e.hole.axis.tolist(),
        } for e in emap.eyelets],
    })


def tip_exits(manifest: Manifest) -> dict[str, np.ndarray]:
    """Each tendon's direction from its tip eyelet toward its spool, from the runs the tensioner
    parts record. The tensioner is fixed to the tip disk, so in the tip frame it never turns."""
    out = {}
    for part in manifest.parts:
        for r in part.tendon_runs:
            v = np.subtract(r["end"], r["start"])
            out[r["tendon"]] = v / np.linalg.norm(v)
    return out
