"""Bill of materials: bom.csv and bom.md from the manifest and the checks' report.json.

Printed parts are the manifest's parts, one row per file, grouped by family (the part's
``role``). Purchased parts:

* the backbone strip (any part of a purchased family, or with ``"purchased": true`` in its
  manifest entry): its cut size from the file's bounding box, its holes from the drill template;
* every tendon, cut to its rest length plus the tie-off and spool allowances of ``bom:``;
  the rest length is the one the checks measured from the geometry (their report, handed over
  by the stage before this one); a folder without a report (built without its checks) gets
  eq. (2) at zero curvature on the design report's eyelets, and says so;
* hardware a part lists in its manifest entry as ``"hardware": [{"item", "qty", "size",
  "material", "notes"}]``, summed over parts by item and size. A part that fastens to the tip
  disk lists those screws itself, marked ``"tip_mount": true``; without one, screws and nuts
  for the tip disk's bolt pattern are listed from its clearance holes;
* the crimp sleeves of tendons that end in one (``termination``), one per tendon;
* the adhesive that fixes the disks to the strip, enough to fill each slot's gap over the length
  its hub holds the strip (from the report's as-built fit, else from the design), twice over.
"""
from __future__ import annotations

import csv
import io
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..cad.manifest import Added, Manifest, ManifestPart, sha256
from ..checks.meshes import stl_bounds
from ..checks.report import REPORT
from ..model import hardware
from ..model import kinematics as kin

PURCHASED_ROLES = {"backbone"}     # families that are bought and cut, not printed

# ISO 273 "normal" clearance holes: hole diameter -> metric thread it clears.
ISO273_NORMAL = hardware.clearance_holes()     # ISO 273 normal clearance hole -> thread (data/fasteners.csv)
CLEARANCE_MATCH_MM = 0.35          # a hole within this of a table size takes that thread
TIP_SCREW = "socket head cap screw ISO 4762"   # fastens the tensioner (or a fixture) to the tip disk

FAMILY_LABELS = {"disk": "tendon-support disk", "backbone": "backbone strip",
                 "jig": "assembly jig", "base_frame": "rotating base frame", "base_frame_gear": "base frame worm drive",
                 "rig": "stiffness rig"}   # others: the role, spaced
ADHESIVE_MARGIN = 2.0              # adhesive bought: this many times what fills the slots' gaps


COLUMNS = ["item", "category", "part", "family", "qty", "material", "size", "volume_mm3", "mass_g",
           "rest_length_mm", "allowance_mm", "cut_length_mm", "file", "notes"]


def family_label(role: str) -> str:
    return FAMILY_LABELS.get(role, role.replace("_", " "))


def is_purchased(part: ManifestPart | dict) -> bool:
    """A part bought, not printed (the strip, the steel): its family says so, or its role is one of those."""
    p = ManifestPart.of(part)
    return bool(p.meta.get("purchased")) or p.role in PURCHASED_ROLES


def thread_for_hole(diameter: float) -> str | None:
    best = min(ISO273_NORMAL, key=lambda d: abs(d - diameter))
    return ISO273_NORMAL[best] if abs(best - diameter) <= CLEARANCE_MATCH_MM else None


def rest_lengths(manifest: Manifest, report: dict | None) -> tuple[dict[str, float], str]:
    """Tendon rest lengths (mm) and where they came from: the checks' ``report`` (None: there is none)."""
    if report is not None:
        try:
            lengths = {t["name"]: float(t["rest_length_mm"]) for t in report.get("tendons", [])}
        except (ValueError, KeyError, TypeError, AttributeError):
            lengths = {}
        names = {t["name"] for t in manifest.design_report["tendons"]}
        if lengths and names <= set(lengths):
            return lengths, f"{REPORT}: rest lengths measured from the part files by the validator"
    dr = manifest.design_report
    st = dr["stations_mm"]
    lengths = {t["name"]: float(kin.tendon_lengths(st, np.asarray(t["eyelets_xz_mm"]), 0.0)[0])
               for t in dr["tendons"]}
    return lengths, "eq. (2) at zero curvature on the design report's eyelets (no report.json)"


def _size(folder: Path, part: ManifestPart) -> str:
    """Overall size, largest first, from the STL's vertices (the manifest's CAD box is loose)."""
    try:
        lo, hi = stl_bounds(part.stl_in(folder))
    except (OSError, ValueError, KeyError):
        lo, hi = part.bbox_min, part.bbox_max
    ext = sorted(np.asarray(hi) - np.asarray(lo), reverse=True)
    return " × ".join(f"{v:.4g}" for v in ext) + " mm"


def _strip_holes(manifest: Manifest) -> int:
    seen = {(round(h["x_mm"], 6), round(h["y_mm"], 6)) for h in manifest.design_report["backbone_holes"]}
    return len(seen)


def bom_rows(folder: Path, manifest: Manifest, plan, report: dict | None) -> tuple[list[dict], str]:
    """Every row of the bill of materials (dicts keyed by COLUMNS) and the rest-length source; ``report``
    is the checks' (None: there is none, and the lengths and adhesive come from the design report)."""
    rows: list[dict] = []

    def add(**kw):
        row = {c: "" for c in COLUMNS} | kw
        row["item"] = len(rows) + 1
        rows.append(row)

    for e in manifest.parts:
        if is_purchased(e):
            continue
        add(category="printed", part=e.name, family=e.role, qty=1,
            material=plan.process.name, size=_size(folder, e),
            volume_mm3=f"{e.volume_mm3:.1f}", mass_g=f"{e.mass_g:.2f}", file=e.stl, notes=_printed_note(e))

    template = manifest.files.get("backbone_template", {}).get("path", "backbone_template.dxf")
    for e in manifest.parts:
        if not is_purchased(e):
            continue
        notes = e.meta.get("notes", "")
        if e.role == "backbone":
            n = _strip_holes(manifest)
            notes = (f"cut to size; drill {n} hole{'s' if n != 1 else ''} from {template} (1:1 template)"
                     if n else f"cut to size; {template} is the 1:1 template")
            laminate = f"carbon-fibre/epoxy laminate, {plan.backbone.thickness:g} mm"
            material = e.material if e.material is not None else laminate
        else:
            material = e.material if e.material is not None else ""
        add(category="purchased", part=e.name, family=e.role, qty=1, material=material,
            size=_size(folder, e), volume_mm3=f"{e.volume_mm3:.1f}", mass_g=f"{e.mass_g:.2f}",
            file=e.step, notes=notes)

    lengths, source = rest_lengths(manifest, report)
    r = plan.bom
    allowance = r.tie_off_mm + r.spool_mm
    tm = plan.tendon_material
    for t in manifest.design_report["tendons"]:
        rest = lengths[t["name"]]
        add(category="purchased", part=f"tendon {t['name']}", family="tendon", qty=1,
            material=tm.name, size=f"Ø{tm.diameter:g} mm", rest_length_mm=f"{rest:.2f}",
            allowance_mm=f"{allowance:.1f}", cut_length_mm=f"{rest + allowance:.1f}",
            notes=f"channel {t['channel']}; rest {rest:.1f} + tie-off {r.tie_off_mm:g} + spool {r.spool_mm:g} mm")

    crimps: dict[tuple[str, str], list[str]] = {}
    ends = {p.name: p.termination for p in plan.paths}
    for t in manifest.design_report["tendons"]:
        term = ends[t["name"]]
        if term.kind == "crimp":
            key = (f"Ø{term.diameter:g} × {term.length:g} mm", term.name or "copper or aluminium")
            crimps.setdefault(key, []).append(t["name"])
    for (size, material), names in crimps.items():
        add(category="purchased", part="crimp sleeve", family="hardware", qty=len(names), size=size,
            material=material, notes=f"ends tendon{'s' if len(names) > 1 else ''} {', '.join(names)} on "
                                     f"{'their seats' if len(names) > 1 else 'its seat'} in the base disk")
    for item, qty, size, material, notes in _fasteners(manifest):
        add(category="purchased", part=item, family="hardware", qty=qty, size=size, material=material, notes=notes)
    ml, how = _adhesive_ml(manifest, plan.backbone.height, plan.backbone.thickness, report)
    gap = _slot_gap(manifest, plan.backbone.thickness)
    add(category="purchased", part="adhesive", family="consumable", qty=1, material=plan.anchors.adhesive,
        size=f"{ml:.2f} ml", notes=(f"the slot's gap is {gap:.3g} mm a side (disks.slot_clearance); " if gap else "")
        + how)
    return rows, source


def _slot_gap(manifest: Manifest, t: float) -> float | None:
    """The gap a side between the strip (thickness ``t``) and a disk's slot, as the design sizes it
    (written from the value, never from a base's words about another value, issue 43)."""
    disks = manifest.design_report.get("disks") or []
    return (disks[0]["slot_mm"][1] - t) / 2 if disks and "slot_mm" in disks[0] else None


def _adhesive_ml(manifest: Manifest, h: float, t: float, report: dict | None) -> tuple[float, str]:
    """Adhesive for every disk: the slot's gap around the strip (``h`` × ``t``, mm) over the length
    the disk holds it."""
    try:
        fits = report["as_built"]["disks"]
        gaps = [((h + f["play_x_mm"]) * (t + f["play_z_mm"]) - h * t) * f["engagement_mm"] for f in fits]
        how = "fills each slot's gap over the length its hub holds the strip (report.json: as_built)"
    except (ValueError, KeyError, TypeError):
        gaps = [(d["slot_mm"][0] * d["slot_mm"][1] - h * t) * d.get("engagement_mm", d["thickness_mm"])
                for d in manifest.design_report["disks"]]
        how = "fills each slot's gap over the length its hub holds the strip (design report)"
    need = sum(gaps) / 1000
    return ADHESIVE_MARGIN * need, f"{how}: {need:.2f} ml, × {ADHESIVE_MARGIN:g}; through each disk's glue port"


def _printed_note(p: ManifestPart) -> str:
    bits, m = [], p.meta
    if p.fixture:
        bits.append(f"assembly jig, piece {m.get('piece', 1)} of {m.get('pieces', 1)}: not part of the robot")
    if p.role in ("base_mount", "base_clamp"):
        bits.append("base mount: clamps the strip's base; " + ("bolts to the table" if p.role == "base_mount"
                                                               else "the upper jaw"))
    if m.get("bench") == "base_frame":
        bits.append("base frame (Fig. 3): " + ("turns with the robot" if m.get("turns") and p.role == "base_frame"
                                               else "stands on the table"))
    if m.get("bench") == "rig":
        bits.append("stiffness rig (Sect. IV-C): not part of the robot")
    if p.station is not None:
        bits.append(f"station {p.station}")
    if m.get("disk_role") in ("base", "tip"):
        bits.append(f"{m['disk_role']} disk")
    if "channel" in m:
        bits.append(f"channel {m['channel']}")
    return "; ".join(bits)


def _fasteners(manifest: Manifest) -> list[tuple[str, int, str, str, str]]:
    """The hardware the parts list, summed by (item, size); and, when no part says what takes
    the tip disk's bolt pattern (``"tip_mount": true``), screws and nuts for it."""
    listed: list[tuple[Mapping, str]] = [(h, p.name) for p in manifest.parts for h in p.hardware]
    if not any(h.get("tip_mount") for h, _ in listed):
        listed = _tip_screws(manifest) + listed
    summed: dict[tuple[str, str], list] = {}
    for h, user in listed:
        key = (str(h.get("item", "hardware")), str(h.get("size", "")))
        if key not in summed:
            summed[key] = [0, str(h.get("material", "")), set(), set()]
        summed[key][0] += int(h.get("qty", 1))
        summed[key][2].add(user)
        if h.get("notes"):
            summed[key][3].add(str(h["notes"]))
    return [(item, qty, size, material, "; ".join(["for " + _names(sorted(users)), *sorted(notes)]))
            for (item, size), (qty, material, users, notes) in summed.items()]


def _tip_screws(manifest: Manifest) -> list[tuple[dict, str]]:
    """Screws through the tip disk's bolt pattern and a nut for each, sized from its holes."""
    tip = max(manifest.design_report["disks"], key=lambda d: d["index"], default=None)
    mounts = tip.get("mount_holes", []) if tip else []
    if not mounts:
        return []
    dia = mounts[0][2]
    thread = thread_for_hole(dia) or f"screw for Ø{dia:g} mm holes"
    who = "the tip disk's bolt pattern"
    return [({"item": TIP_SCREW, "size": f"{thread} × ({tip['thickness_mm']:g} mm + nut)", "qty": len(mounts),
              "material": "steel"}, who),
            ({"item": "hex nut ISO 4032 or heat-set insert", "size": thread, "qty": len(mounts),
              "material": "steel / brass"}, who)]


def _names(names: list[str]) -> str:
    return ", ".join(names) if len(names) <= 4 else f"{', '.join(names[:3])} and {len(names) - 3} more"


def family_table(manifest: Manifest, printed_in: str, rows: list[dict] | None = None) -> list[dict]:
    """One entry per part family of the robot (assembly aids such as the jig are not drawn with it),
    numbered in order of first appearance (the drawing's balloons); ``printed_in``: the process's name."""
    out: list[dict] = []
    robot = [p for p in manifest.parts if not p.fixture]
    for e in robot:
        if any(f["role"] == e.role for f in out):
            continue
        members = [p for p in robot if p.role == e.role]
        bought = e.material if e.material is not None else ""
        material = bought if is_purchased(e) else printed_in
        out.append({"item": len(out) + 1, "role": e.role, "label": family_label(e.role),
                    "qty": len(members), "material": material,
                    "kind": "purchased" if is_purchased(e) else "printed",
                    "parts": [p.name for p in members]})
    return out


def _csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def _md_cell(v) -> str:
    return str(v).replace("|", "\\|")


def _markdown(manifest: Manifest, plan, rows: list[dict], source: str) -> str:
    printed = [r for r in rows if r["category"] == "printed"]
    fam: dict[str, list[dict]] = {}
    for r in printed:
        fam.setdefault(r["family"], []).append(r)
    total = sum(float(r["volume_mm3"]) for r in printed)
    mass = sum(float(r["mass_g"]) for r in printed)
    L = [f"# Bill of materials: {manifest.name}", "",
         f"From `{manifest.params_file}` (sha256 {manifest.params_sha256[:12]}), "
         f"hwgen {manifest.hwgen_version}.", "",
         "## Printed parts", "",
         f"Material: {plan.process.name}. Total part volume {total / 1000:.1f} cm³ "
         f"(≈ {total / 1000:.0f} ml of material before supports and waste), {mass:.1f} g.", "",
         "| family | qty | volume, cm³ | mass, g |", "|---|---:|---:|---:|"]
    for role, rs in fam.items():
        L.append(f"| {family_label(role)} | {len(rs)} | {sum(float(r['volume_mm3']) for r in rs) / 1000:.2f} | "
                 f"{sum(float(r['mass_g']) for r in rs):.1f} |")
    L += ["", "| # | part | family | qty | size | volume, mm³ | mass, g | file | notes |",
          "|---:|---|---|---:|---|---:|---:|---|---|"]
    for r in printed:
        L.append(f"| {r['item']} | {r['part']} | {r['family']} | {r['qty']} | {r['size']} | {r['volume_mm3']} | "
                 f"{r['mass_g']} | `{r['file']}` | {_md_cell(r['notes'])} |")
    bought = [r for r in rows if r["category"] == "purchased" and r["family"] not in ("tendon", "hardware")]
    tendons = [r for r in rows if r["family"] == "tendon"]
    hardware = [r for r in rows if r["family"] in ("hardware", "consumable")]
    L += ["", "## Purchased parts", "", "| # | part | qty | material | cut size | notes |", "|---:|---|---:|---|---|---|"]
    for r in bought:
        L.append(f"| {r['item']} | {r['part']} | {r['qty']} | {_md_cell(r['material'])} | {r['size']} | "
                 f"{_md_cell(r['notes'])} |")
    r_, tm = plan.bom, plan.tendon_material
    term = tm.termination
    ends = "knot on its seat in the base disk" if term.kind == "knot" else "crimp sleeve on its seat in the base disk"
    L += ["", f"### Tendons: {tm.name}, Ø{tm.diameter:g} mm", "",
          f"Cut length = rest length + {r_.tie_off_mm:g} mm tie-off ({ends}) + "
          f"{r_.spool_mm:g} mm spool (to reach and wrap the tensioner). Rest lengths: {source}.", "",
          "| # | tendon | channel | rest, mm | cut, mm |", "|---:|---|---|---:|---:|"]
    for r in tendons:
        ch = r["notes"].split(";")[0].removeprefix("channel ")
        L.append(f"| {r['item']} | {r['part'].removeprefix('tendon ')} | {ch} | {r['rest_length_mm']} | "
                 f"{r['cut_length_mm']} |")
    total_cut = sum(float(r["cut_length_mm"]) for r in tendons)
    L.append(f"| | total | | | {total_cut:.0f} |")
    if hardware:
        L += ["", "### Fasteners and hardware", "", "| # | item | qty | size | material | notes |",
              "|---:|---|---:|---|---|---|"]
        for r in hardware:
            L.append(f"| {r['item']} | {r['part']} | {r['qty']} | {r['size']} | {_md_cell(r['material'])} | "
                     f"{_md_cell(r['notes'])} |")
    L += [""]
    return "\n".join(L)


def write_bom(folder: Path, manifest: Manifest, plan, report: dict | None) -> Added:
    """bom.csv and bom.md into the folder; what the manifest lists of them (the files, the
    rest-length source, the counts)."""
    folder = Path(folder)
    rows, source = bom_rows(folder, manifest, plan, report)
    (folder / "bom.csv").write_text(_csv(rows), encoding="utf-8")
    (folder / "bom.md").write_text(_markdown(manifest, plan, rows, source), encoding="utf-8")
    files = {key: {"path": name, "sha256": sha256(folder / name)}
             for key, name in (("bom_csv", "bom.csv"), ("bom_md", "bom.md"))}
    return Added({"bom": {"tendon_rest_length_source": source,
                          "printed_parts": sum(r["qty"] for r in rows if r["category"] == "printed"),
                          "tendon_cut_total_mm": round(sum(float(r["cut_length_mm"]) for r in rows
                                                           if r["family"] == "tendon"), 1)}}, files)
