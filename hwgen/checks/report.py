"""The check report for people and for CI: JSON, JUnit XML, a Markdown summary and a rich table.

report.json is written and read here only: :func:`write_report` by the checks stage and
:func:`read_report` by whatever runs without the checks in the same process (``hwgen render``,
the statics study). A build hands the report to the outputs in memory."""
from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, TypedDict

from .. import atomic
from .base import failing, fails, warned

REPORT = "report.json"


# ---------------------------------------------------------------- report.json, typed
# The report stays the JSON object it is on disk (what a build hands its outputs in memory is
# what they read back from the file); these types say which keys it has and what each holds.

class _CheckFields(TypedDict):
    id: str
    severity: str                 # "error", "warning" or "info"
    passed: bool
    message: str
    measured: float | None
    limit: float | None
    where: dict[str, Any]         # part(s), tendon(s), channel, station: what :func:`place` prints
    fix: str                      # when it fails: what to change, which way, how far where computed
    lowered_by: str               # the design setting that states its failure as a warning ("" if none)


class CheckRecord(_CheckFields, total=False):
    """One check (:class:`hwgen.checks.base.Check` as JSON). A failing check whose fixes were tried
    also holds ``fixes`` (the one key a record may leave out): each :class:`hwgen.checks.base.Fix` as
    JSON (set, then, breaks, note, relax), best first; ``fix`` is written from them."""
    fixes: list[dict[str, Any]]


class SweepRecord(TypedDict):
    max_angle_deg: float
    step_deg: float
    angles_deg: list[float]


class TendonRecord(TypedDict):
    """A tendon's length over the sweep: eq. (2) through the measured hole centres, the taut path."""
    name: str
    channel: str
    source: str                   # "geometry": from the files
    rest_length_mm: float
    delta_at_max_mm: float
    delta_at_min_mm: float
    max_abs_delta_mm: float
    budget_mm: float | None
    centreline_passed: bool
    taut_rest_length_mm: float
    taut_max_abs_delta_mm: float
    robust_mm: float | None
    passed: bool
    stations_from_backbone: list[int]
    stations_from_design: list[int]
    delta_mm: list[float]
    taut_delta_mm: list[float]


class EyeletRecord(TypedDict):
    """A designed eyelet and where it was found."""
    station: int
    part: str
    tendons: list[str]
    status: str
    design_xz_mm: list[float]
    measured_xz_mm: list[float] | None
    offset_mm: float | None
    diameter_mm: float | None
    axis: list[float] | None


# the design's name, under the key the manifest also uses (spelled as a string: no stage after the
# model holds a name ``design``, tests/test_layout.py)
_Named = TypedDict("_Named", {"design": str})


class _BenchSection(TypedDict, total=False):
    bench: dict[str, Any]         # checks.bench: the base frame's and the rig's figures (a design with either)


class Report(_Named, _BenchSection):
    """report.json. The sections from ``mass`` on are the studies' own documents, each stating
    its model and assumptions (see the checks that write them); ``bench`` only where the design
    has its base frame or rig."""
    ok: bool                      # no failing error-severity check
    hwgen_version: str
    sweep: SweepRecord
    checks: list[CheckRecord]
    tendons: list[TendonRecord]
    pairs: list[dict[str, Any]]   # the antagonistic pair's take-up
    eyelets: list[EyeletRecord]
    mass: dict[str, Any]          # checks.parts.mass_summary
    as_built: dict[str, Any]      # disks on the strip, the taut paths as built (checks.taut)
    seats: list[dict[str, Any]]   # checks.anchors
    gravity: dict[str, Any]       # checks.gravity
    tension: dict[str, Any]       # checks.tension
    stiffening: dict[str, Any] | None   # the tendon states' statics: hwgen.model.stiffness.stiffening


def write_report(report: Report, folder: Path) -> None:
    """report.json into the folder, whole or not at all."""
    atomic.write_json(Path(folder) / REPORT, report)


def read_report(folder: Path) -> Report | None:
    """The report a build's checks wrote into ``folder``; None when there is none, or it is not
    a JSON object (unreadable, cut short)."""
    try:
        report = json.loads((Path(folder) / REPORT).read_text())
    except (OSError, ValueError):
        return None
    return report if isinstance(report, dict) else None


def place(check: dict) -> str:
    """A short label of where a check looked: part, tendon(s), station."""
    w = check.get("where") or {}
    bits = []
    for key in ("part", "parts", "tendon", "tendons", "channel", "station"):
        if key in w:
            v = w[key]
            v = "+".join(map(str, v)) if isinstance(v, list) else str(v)
            bits.append(v if key != "station" else f"station {v}")
    return " ".join(bits)


def named(check: dict) -> tuple[list[str], list[str]]:
    """The parts and the tendons a check names where it looked, each once ("A1+A2", the tendons of
    one eyelet, names both)."""
    w = check.get("where") or {}
    parts: list[str] = []
    tendons: list[str] = []
    for key, into in (("part", parts), ("parts", parts), ("tendon", tendons), ("tendons", tendons)):
        v = w.get(key)
        for name in ([v] if isinstance(v, str) else v if isinstance(v, list) else []):
            into.extend(one for one in str(name).split("+") if one not in into)
    return parts, tendons


def status(check: dict) -> str:
    if check["passed"]:
        return "pass"
    return "FAIL" if check["severity"] == "error" else check["severity"]


def write_junit(report: dict, path: Path) -> None:
    """One test case per check; failing errors are failures, failing warnings print a warning."""
    checks = report["checks"]
    failures = len(failing(checks))
    suites = ET.Element("testsuites", name="hwgen check", tests=str(len(checks)), failures=str(failures))
    suite = ET.SubElement(suites, "testsuite", name=f"hwgen check {report['design']}", tests=str(len(checks)),
                          failures=str(failures), errors="0", skipped="0")
    seen: dict[str, int] = {}
    for c in checks:
        name = c["id"] + (f" [{place(c)}]" if place(c) else "")
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            name += f" #{seen[name]}"
        case = ET.SubElement(suite, "testcase", classname=f"hwgen.{report['design']}.{c['id']}", name=name)
        detail = f"measured={c['measured']} limit={c['limit']} where={json.dumps(c['where'])}"
        fix = c.get("fix") or ""
        if fails(c):
            fail = ET.SubElement(case, "failure", message=c["message"], type=c["id"])
            fail.text = detail + (f"\nfix: {fix}" if fix else "")
        else:
            out = ET.SubElement(case, "system-out")
            out.text = ("" if c["passed"] else f"{c['severity'].upper()}: ") + c["message"] + (
                f"\nfix: {fix}" if fix and not c["passed"] else "")
    ET.indent(suites)
    atomic.write_text(path, '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(suites, encoding="unicode") + "\n")


def _fmt(v) -> str:
    if v is None:
        return "–"
    return f"{v:.4g}" if isinstance(v, float) else str(v)


def as_built_lines(report: dict) -> list[str]:
    """The verdict on the budgeted tendons in words, one line each ("C2: … — fails")."""
    tb = (report.get("as_built") or {}).get("taut")
    if not tb:
        return []
    p = tb["process"]
    out = ["", f"As built: the taut path through the measured holes, {tb['samples']} samples (seed {tb['seed']}; "
               f"σ {p['position_sigma_mm']:g} mm on hole position, {p['diameter_sigma_mm']:g} mm on diameter, disks "
               f"±{p['station_tolerance_mm']:g} mm along the strip, tilt and play as measured). Plot: `tolerance.png`.",
           ""]
    for c in report["checks"]:
        if c["id"] == "tendon.robust":
            word = "" if c["passed"] or c["severity"] == "error" else " (stated as a warning: check.robust_severity)"
            out.append(f"- {c['message'].replace(' — fails', ' — **FAILS**')}{word}")
    pair = tb.get("pair")
    if pair:
        out.append(f"- actuating pair {' and '.join(pair['tendons'])}: {pair['taut_mm']:.3f} mm of slack to take up "
                   f"(taut, nominal), {pair['p95_mm']:.3f} mm at p95")
    return out


def _finding(c: dict) -> str:
    """A failing check in summary.md: its id, what was found and, on a line of its own, the fix."""
    text = f"- `{c['id']}` {c['message']}"
    if c.get("lowered_by"):
        text += f" (an error stated as a warning: {c['lowered_by']})"
    return text + (f"  \n  **Fix:** {c['fix']}" if c.get("fix") else "")


# the unit a check's measured value and limit are in ("%": a share, printed as a percentage)
UNITS = {"disk.tilt": "°", "disk.station": " mm", "gravity.strip_stress": " MPa", "backbone.bend_stress": " MPa",
         "tendon.clearance": " mm", "tendon.robust": " mm", "tendon.length": " mm", "tendon.taut": " N",
         "tendon.overload": " N", "actuation.tension": " N", "actuation.coupling": "%", "mount.stiffness": "%",
         "eyelet.wall.edge": " mm", "eyelet.wall.eyelet": " mm", "eyelet.wall.slot": " mm", "eyelet.min_hole": " mm",
         "eyelet.tendon_angle": " mm", "eyelet.position": " mm", "hub.tendon_clearance": " mm",
         "tensioner.tendon_clearance": " mm", "part.interference": " mm³", "part.build_volume": " mm",
         "part.volume": "%", "backbone.hole_angle": " mm", "backbone.crossing": " mm", "gear.center_distance": " mm",
         "gear.gap": " mm", "gear.interference": " mm³", "gear.shaft_angle": "°", "gear.lewis": "×", "gear.hertz": "×",
         "print.cup": " mm²", "tendon.seat": " mm", "routing.table_vs_function": " mm",
         "mount.clamp": " mm", "mount.foot": " mm", "jig.hold": " mm²", "stiffening.tip": "×",
         "stiffening.torsion": "×"}


def _value(v, unit: str) -> str:
    if unit == "%":
        return f"{v * 100:.3g} %"
    if isinstance(v, float):
        return f"{0.0 if abs(v) < 5e-5 else v:.4g}{unit}"
    return f"{v}{unit}"


def finding_line(c: dict) -> str:
    """One failing check on a line: its id, what it looked at, the value measured against its limit,
    and the change that fixes it (else what it found)."""
    unit = UNITS.get(c["id"], "")
    head = " ".join(dict.fromkeys(bit for bit in (c["id"], *place(c).split(" ")) if bit))   # "C1 C1": tendon, channel
    if c.get("measured") is not None and c.get("limit") is not None:
        head += f": {_value(c['measured'], unit)} against {_value(c['limit'], unit)}"
    if c.get("lowered_by"):
        head += f" (stated as a warning: {c['lowered_by']})"
    return f"{head}; fix: {c['fix']}" if c.get("fix") else f"{head}: {c['message']}"


def lowered_settings(report: dict, files: dict[str, str] | None = None) -> str:
    """The design's settings that state failing checks as warnings, and how many each lowers
    ("check.robust_severity: warning (in params/prototype.yaml) states failing checks as warnings
    (2 tendon.robust)"); "" when none does. ``files``: setting -> the file that wrote it."""
    by: dict[str, list[str]] = {}
    for c in report["checks"]:
        if not c["passed"] and c.get("lowered_by"):
            by.setdefault(c["lowered_by"], []).append(c["id"])
    out = []
    for setting, ids in by.items():
        counts = ", ".join(f"{ids.count(i)} {i}" for i in dict.fromkeys(ids))
        where = f" (in {files[setting]})" if files and setting in files else ""
        out.append(f"{setting}: warning{where} states failing checks as warnings ({counts})")
    return "; ".join(out)


def verdict_lines(report: dict, summary: Path | str, files: dict[str, str] | None = None) -> list[tuple[str, str]]:
    """What `hwgen build` and `hwgen check` end with, as (label, text): one line per failed check
    (:func:`finding_line`), then the warnings, then the verdict naming ``summary`` and the settings
    that lowered a failing check's severity."""
    checks = report["checks"]
    errs, warns = failing(checks), warned(checks)
    out = [("failed:", finding_line(c)) for c in errs] + [("warning:", finding_line(c)) for c in warns]
    lowered = lowered_settings(report, files)
    text = (f"{'PASS' if report['ok'] else 'FAIL'}: {len(checks)} checks, {len(errs)} failed, {len(warns)} warning(s)"
            + (f"; severity lowered by the design: {lowered}" if lowered else "") + f"; see {summary}")
    return out + [("verdict", text)]


def stiffening_lines(report: dict) -> list[str]:
    """What locking the stiffening tendons adds, in words (the statics' ``stiffening``), after a blank line."""
    st = report.get("stiffening") or {}
    return ["", *st["lines"]] if st.get("lines") else ["", st["skipped"] + "."] if st.get("skipped") else []


def write_summary(report: dict, path: Path) -> None:
    """A short Markdown summary: verdict, tendon lengths, failing and warning findings."""
    checks = report["checks"]
    errs, warns = failing(checks), warned(checks)
    sw = report["sweep"]
    soft = [c["where"]["tendon"] for c in warns if c["id"] == "tendon.robust"]
    head = f"# {report['design']}: {'PASS' if report['ok'] else 'FAIL'}"
    if soft:
        head += f"; as built, {' and '.join(soft)} FAIL{'S' if len(soft) == 1 else ''} (stated as warnings)"
    lines = [head, "",
             f"{len(checks)} checks: {len(errs)} failed, {len(warns)} warning(s). "
             f"Tendon lengths by eq. (1)-(2) from the eyelets measured in the exported disks, "
             f"bending -{sw['max_angle_deg']:g}° to +{sw['max_angle_deg']:g}° in {sw['step_deg']:g}° steps.", "",
             "| tendon | channel | rest length mm | Δ at +max mm | Δ at −max mm | max abs Δ mm | taut max abs Δ mm | "
             "as built mm | budget mm | |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for t in report["tendons"]:
        lines.append(f"| {t['name']} | {t['channel']} | {t['rest_length_mm']:.3f} | {t['delta_at_max_mm']:+.4f} | "
                     f"{t['delta_at_min_mm']:+.4f} | {t['max_abs_delta_mm']:.4f} | {t['taut_max_abs_delta_mm']:.4f} | "
                     f"{_fmt(t.get('robust_mm'))} | {'–' if t['budget_mm'] is None else format(t['budget_mm'], 'g')} | "
                     f"{'pass' if t['passed'] else '**FAIL**'} |")
    lines += as_built_lines(report)
    for p in report.get("pairs", []):
        lines += ["", f"Antagonistic pair {' and '.join(p['tendons'])} (channel {p['channel']}): "
                      f"{p['take_up_mm']:+.3f} mm to take up at {p['at_angle_deg']:+g}°."]
    fits = (report.get("as_built") or {}).get("disks", [])
    if fits:
        pitch = max(max(abs(v) for v in f["tilt_x_deg"]) for f in fits)
        yaw = max(max(abs(v) for v in f["tilt_z_deg"]) for f in fits)
        lines += ["", f"Disks on the strip (measured from their STLs): pitch at most ±{pitch:.3f}° "
                      f"(limit {report['as_built']['max_tilt_deg']:g}°), yaw ±{yaw:.3f}°, held over "
                      f"{min(f['engagement_mm'] for f in fits):.2f} mm or more."]
    g = report.get("gravity") or {}
    if g.get("cases"):
        case = g["cases"][g["gravity"]]
        lines += ["", f"Own weight, no tendon tensioned (state N): tip sag {case['tip_sag_mm']:.1f} mm, strip stress "
                      f"{case['max_stress_mpa']:.0f} MPa (allowable {g['allowable_stress_mpa']:g} MPa). Plot: `sag.png`."]
    lines += stiffening_lines(report)
    if errs:
        lines += ["", "## Failed", ""] + [_finding(c) for c in errs]
    if warns:
        lines += ["", "## Warnings", ""] + [_finding(c) for c in warns]
    lowered = lowered_settings(report)
    if lowered:
        lines += ["", f"Severity lowered by the design: {lowered}."]
    lines += ["", "Plots: `lengths.png`, `tolerance.png`. Every check: `report.json`.", ""]
    atomic.write_text(path, "\n".join(lines))


def print_report(report: dict, console, verbose: bool = False) -> None:
    """Rich tables: tendons, then the findings (failures and warnings; every check if verbose);
    the verdict follows (:func:`verdict_lines`).

    Styles are given as Text spans, never as markup, so nothing in a message is read as markup."""
    from rich.table import Table
    from rich.text import Text

    t = Table(title=f"{report['design']}: tendon lengths from the geometry (±{report['sweep']['max_angle_deg']:g}°)")
    robust = ((report.get("as_built") or {}).get("taut") or {}).get("robust", "p95")
    for col in ("tendon", "channel", "rest mm", "Δ+max mm", "Δ−max mm", "max |Δ| mm", "taut mm", f"{robust} mm",
                "budget mm", ""):
        t.add_column(col, justify="left" if col in ("tendon", "channel", "") else "right")
    for r in report["tendons"]:
        t.add_row(r["name"], r["channel"], f"{r['rest_length_mm']:.3f}", f"{r['delta_at_max_mm']:+.4f}",
                  f"{r['delta_at_min_mm']:+.4f}", f"{r['max_abs_delta_mm']:.4f}", f"{r['taut_max_abs_delta_mm']:.4f}",
                  _fmt(r.get("robust_mm")),
                  "–" if r["budget_mm"] is None else f"{r['budget_mm']:g}",
                  Text("pass", style="green") if r["passed"] else Text("FAIL", style="bold red"))
    console.print(t)
    shown = [c for c in report["checks"] if verbose or not c["passed"]
             or c["id"] in ("tendon.take_up", "tendon.robust", "tendon.take_up_as_built")]
    ft = Table(title="findings" if not verbose else "checks")
    for col in ("", "check", "where", "measured", "limit", "message"):
        ft.add_column(col, overflow="fold")
    style = {"pass": "green", "FAIL": "bold red", "warning": "yellow", "info": "cyan"}
    for c in shown:
        s = status(c) if not (c["passed"] and c["severity"] == "info") else "info"
        ft.add_row(Text(s, style=style.get(s, "")), c["id"], Text(place(c)), _fmt(c["measured"]), _fmt(c["limit"]),
                   Text(c["message"]))
    console.print(ft)
    if (report.get("stiffening") or {}).get("headline"):
        console.print(Text(report["stiffening"]["headline"] + " (summary.md, stiffness.json)"))
