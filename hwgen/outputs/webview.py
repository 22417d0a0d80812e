"""view.html: the build in the browser, one page that opens from the file with no network and no
server. Inlined in it: the assembly as binary glTF (trimesh writes it from the parts' STLs: a node
per part, named as in the manifest, in its placement and its manifest colour), what the page shows
of the checks and the statics (JSON), and the viewer that draws it: three.js (npm) with hwgen's own
``webview.js``, bundled once by ``make viewer`` into the environment (:data:`BUNDLE`), never into
the repository.

The poses are the pictures' (:mod:`hwgen.outputs.scene`), worked out here and handed over, never
worked out again in the page:

* assembled: every part where the manifest places it, the tendons through their eyelets;
* exploded, by a slider up to the exploded drawing's offsets (:func:`scene.exploded_placements`
  with ``render.explode_mm`` and the isometric view), the tendons' eyelets riding with their disks;
* bent to plus or minus the checks' sweep angle (eq. (1)): disks and the parts off the backbone
  rigid on their frames, the strip bent point by point, each tendon through its eyelets.

The parts sit in a tree by group (the first word of their family: disks, strip, tensioner, base
mount, jig, and any other family a design has), each with a toggle; the parts and tendons of a
failing check are magenta with the check's id; a click on a part or a tendon lists every check of
report.json that names it; the tendon states' stiffness at the tip is a table (stiffness.json).

What cannot be drawn is said in the page, never a blank page: a part whose STL cannot be read is
drawn as its box, an assembly over :data:`MAX_TRIANGLES` draws its largest meshes as boxes, and
without the viewer (``make viewer`` found no npm) the page lists the parts, the checks and the
stiffness, and says how to get the 3D view.
"""
from __future__ import annotations

import base64
import html
import json
import os
import re
import sys
from pathlib import Path

import numpy as np

from .. import __version__
from ..options import VIEWER_ENV
from ..cad.manifest import Added, Manifest, ManifestPart, manifest_parts, sha256
from ..checks.meshes import part_mesh, sharing_meshes
from ..checks.report import named, place, status
from ..model import kinematics as kin
from .bom import family_label
from .pictures import WARNING_COLOUR, failing_marks
from .scene import (ScenePart, bend_points, bent_placement, exploded_placements, scene_parts, sliced,
                    tendon_colours, tendon_polylines)
from .view import ISOMETRIC, TENDON_TUBE_MM

PAGE = "view.html"
BUNDLE = Path(sys.prefix) / "share" / "hwgen" / "webview.js"     # `make viewer` writes it here
STYLE = Path(__file__).with_name("webview.css")
BANNER = re.compile(r"/\* hwgen viewer: ([^*]*) \*/")            # the bundle's first line: what it holds
# The page's budget of triangles (each distinct mesh once): the prototype has about 234 000 (a 4.2 MB
# GLB); past this the largest meshes are drawn as their boxes, so the page stays one a browser opens
MAX_TRIANGLES = 2_000_000
# The strip is cut across every this many mm to be bent: at the prototype's 90° over 270 mm a 10 mm
# chord lies 0.07 mm off the arc, nothing on a screen (the pictures' 3 mm cuts make four times the
# triangles, for their edge lines: 39 000 on the prototype's strip against 12 800)
BEND_PITCH_MM = 10.0
GROUP_LABELS = {"disk": "disks", "backbone": "strip", "base": "base mount"}     # others: the word itself
NO_VIEWER = ("The 3D view is not in this page: its viewer (three.js, bundled with hwgen's webview.js by "
             "`make viewer`, which needs Node.js and npm) is not installed here{where}. The parts, checks "
             "and stiffness are listed below; run `make viewer`, then `hwgen render`, for the 3D view.")


def viewer_bundle(given: str | None = None) -> Path | None:
    """The viewer's bundle (``given``, the build's option: "" where `make viewer` puts it, another
    file, or "none": as if there were none; None: as ``$HWGEN_VIEWER_JS`` says); None when there is none."""
    given = os.environ.get(VIEWER_ENV, "") if given is None else given
    if given.lower() == "none":
        return None
    path = Path(given) if given else BUNDLE
    return path if path.is_file() else None


def assets(viewer: str | None = None) -> dict[str, str | None]:
    """What the page inlines besides the build's files (the viewer's bundle, as ``viewer`` names it:
    :func:`viewer_bundle`; the style), by their sha256: the view stage is kept in the cache under
    these too (hwgen's .py code is keyed already)."""
    bundle = viewer_bundle(viewer)
    return {"bundle": None if bundle is None else sha256(bundle), "style": sha256(STYLE)}


# --------------------------------------------------------------------------- the parts

def _box(part: ManifestPart):
    import trimesh
    return trimesh.creation.box(bounds=np.array([part.bbox_min, part.bbox_max]))


def read_meshes(folder: Path, manifest: Manifest, budget: int = MAX_TRIANGLES
                ) -> tuple[list[tuple[ManifestPart, object]], list[str], list[str]]:
    """Every part of the manifest with its mesh (file coordinates): its STL's (parts of the same
    file's bytes share one), else its manifest box, said in a message. Over ``budget`` triangles
    (each distinct mesh once), the largest meshes are boxes too. Returns (part, mesh) pairs, the
    messages and the names of the parts drawn as boxes."""
    pairs, notes = [], []
    with sharing_meshes():
        for p in manifest_parts(manifest):
            try:
                mesh = part_mesh(folder, p)
                why = "" if len(mesh.faces) else "it holds no triangles"
            except (OSError, ValueError, IndexError, KeyError) as e:
                why = f"it could not be read ({type(e).__name__}: {e})"
            if why:
                mesh = None
                notes.append(f"{p.name}: its STL ({p.stl}): {why}; drawn as its box")
            pairs.append((p, mesh))
    distinct = {id(m): m for _, m in pairs if m is not None}
    total = left = sum(len(m.faces) for m in distinct.values())
    large = set()
    for m in sorted(distinct.values(), key=lambda m: -len(m.faces)):
        if left <= budget:
            break
        large.add(id(m))
        left -= len(m.faces)
    if large:
        names = [p.name for p, m in pairs if m is not None and id(m) in large]
        notes.append(f"{len(names)} parts drawn as their boxes ({', '.join(names)}): the assembly's meshes hold "
                     f"{total:,} triangles, over this page's {budget:,}")
    boxed = [p.name for p, m in pairs if m is None or id(m) in large]
    return [(p, _box(p) if p.name in boxed else m) for p, m in pairs], notes, boxed


def _linear(rgb) -> list[float]:
    """An sRGB colour (the manifest's, 0..1) as glTF's base colour, which is linear."""
    c = np.clip(np.asarray(rgb, float)[:3], 0.0, 1.0)
    return [*np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).tolist(), 1.0]


def glb(parts: list[ScenePart]) -> bytes:
    """The parts as one binary glTF: a node per part named as in the manifest, its mesh in file
    coordinates under the manifest's placement, a material of its manifest colour; parts whose
    files hold the same bytes share one mesh. No normals: the viewer shades each facet flat."""
    import trimesh
    from trimesh.visual.material import PBRMaterial
    scene = trimesh.Scene()
    geometry: dict[int, str] = {}
    for p in parts:
        key = id(p.drawn)               # one per mesh (scene.scene_parts)
        if key in geometry:
            scene.graph.update(frame_to=p.name, frame_from=scene.graph.base_frame, matrix=p.placement,
                               geometry=geometry[key])
            continue
        geometry[key] = p.name
        mesh = trimesh.Trimesh(p.vertices, p.faces, process=False)
        mesh.visual = trimesh.visual.TextureVisuals(material=PBRMaterial(
            name=p.role, baseColorFactor=_linear(p.meta.get("color") or (0.7, 0.7, 0.7)),
            metallicFactor=0.0, roughnessFactor=0.7))
        scene.add_geometry(mesh, node_name=p.name, geom_name=p.name, transform=p.placement)
    return scene.export(file_type="glb", include_normals=False)


def group_of(role: str) -> str:
    """The tree's group of a family: the first word of its role (tensioner_wheel: tensioner)."""
    return role.split("_")[0]


# --------------------------------------------------------------------------- what the page is told

def _columns(m: np.ndarray) -> list[float]:
    """A 4x4 as three.js reads it (column by column)."""
    return [round(float(v), 6) for v in np.asarray(m, float).T.ravel()]


def _b64(a: np.ndarray, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode()


def _hex(rgb) -> str:
    return "#" + "".join(f"{int(round(255 * float(np.clip(c, 0, 1)))):02x}" for c in list(rgb)[:3])


def check_index(checks: list[dict], manifest: Manifest) -> tuple[dict[str, list[int]], dict[str, list[int]]]:
    """(part -> indices of the checks that name it, tendon -> the same). A check that names only a
    channel (the gear checks) names that channel's parts ("all": every part of a channel)."""
    channel_parts: dict[str, list[str]] = {}
    for e in manifest.parts:
        if e.channel is not None:
            channel_parts.setdefault(e.channel, []).append(e.name)
    parts: dict[str, list[int]] = {}
    tendons: dict[str, list[int]] = {}
    for i, c in enumerate(checks):
        ps, ts = named(c)
        w = c.get("where") or {}
        if not ps and not ts and isinstance(w.get("channel"), str):
            ch = w["channel"]
            ps = [n for k, names in channel_parts.items() if ch in (k, "all") or w.get("measured_on") == k
                  for n in names]
        for names, into in ((ps, parts), (ts, tendons)):
            for n in names:
                into.setdefault(n, []).append(i)
    return parts, tendons


def _bent_poses(parts: list[ScenePart], st: np.ndarray, sweep_deg: float) -> tuple[list[dict], dict]:
    """The bent poses at plus and minus the sweep angle: each rigid part's 4x4 (file -> bent robot),
    and the vertices of each part that bends with the strip (robot coordinates), and those parts'
    triangles (the same in every pose)."""
    rigid = {p.name for p in parts if bent_placement(p, st, 0.0) is not None}
    cut = {p.name: sliced(p, BEND_PITCH_MM) for p in parts if p.name not in rigid}
    out = []
    for sign, key in ((1, "plus"), (-1, "minus")):
        deg = sign * abs(float(sweep_deg))
        kappa = float(kin.kappas_for_angles([deg], st[-1] - st[0])[0])
        out.append({"key": key, "label": f"bent {deg:+g}°", "kappa": kappa,
                    "matrices": {p.name: _columns(bent_placement(p, st, kappa)) for p in parts if p.name in rigid},
                    "vertices": {n: _b64(bend_points(V, st, kappa), "<f4") for n, (V, _) in cut.items()}})
    return out, {n: _b64(F, "<u4") for n, (_, F) in cut.items()}


def stiffness_table(study: dict | None) -> dict:
    """The tendon states' stiffness at the tip in the study's reference orientation: per state,
    frictionless and with every eyelet stuck (N/mm), and the frictionless torsion (N·mm/rad)."""
    from ..model.stiffness import entries_by_state
    if not study:
        return {"skipped": "no stiffness.json in this build"}
    if "skipped" in study:
        return {"skipped": study["skipped"]}
    ref = (study.get("stiffening") or {}).get("reference") or next(
        (e["orientation"] for e in study.get("states", [])), None)
    none, stuck = entries_by_state(study, ref, "none"), entries_by_state(study, ref, "stuck")
    rows = [{"state": s, "none": e.get("tip_stiffness_n_per_mm"),
             "stuck": (stuck.get(s) or {}).get("tip_stiffness_n_per_mm"),
             "torsion": e.get("tip_torsion_nmm_per_rad")} for s, e in none.items()]
    return {"orientation": ref, "rows": rows, "headline": (study.get("stiffening") or {}).get("headline", "")}


def listed(manifest: Manifest, report: dict | None, study: dict | None) -> dict:
    """What the page lists, with or without its 3D view: every part (its group, family, colour, the
    checks that name it and those that fail), every tendon, every check, the stiffness table."""
    checks = (report or {}).get("checks") or manifest.checks or []
    failing_parts, failing_tendons = failing_marks(checks)
    by_part, by_tendon = check_index(checks, manifest)
    colours = tendon_colours(manifest.design_report)
    return {
        "design": manifest.name, "hwgen": __version__,
        "parts": [{"name": p.name, "role": p.role, "family": family_label(p.role), "group": group_of(p.role),
                   "colour": _hex(p.color or (0.7, 0.7, 0.7)), "station": p.station,
                   "fixture": p.fixture, "box": False, "failing": failing_parts.get(p.name, []),
                   "checks": by_part.get(p.name, [])} for p in manifest_parts(manifest)],
        "tendons": [{"name": n, "colour": _hex(rgb), "failing": failing_tendons.get(n, []),
                     "checks": by_tendon.get(n, [])} for n, rgb in colours.items()],
        "checks": [{"id": c["id"], "status": status(c), "where": place(c), "message": c.get("message", ""),
                    "fix": c.get("fix", "") if not c.get("passed", True) else ""} for c in checks],
        "stiffness": stiffness_table(study),
        "messages": [] if checks else ["no checks in this build (report.json is missing): nothing is marked"],
    }


def drawn(folder: Path, manifest: Manifest, data: dict, explode_mm: float, sweep_deg: float) -> bytes:
    """The assembly's GLB, and into ``data`` what the viewer needs to pose it: each part's exploded
    offset, the bent poses, each tendon's eyelet points in every pose, what was drawn as a box."""
    pairs, notes, boxed = read_meshes(folder, manifest, MAX_TRIANGLES)
    parts = scene_parts(pairs)
    planned = manifest.design_report
    st = np.asarray(planned["stations_mm"], dtype=float)
    robot = [p for p in parts if not p.meta.get("fixture")]
    ex = exploded_placements(robot, st, explode_mm, ISOMETRIC.toward_camera)
    shift = {p.name: (ex[p.name][:3, 3] - p.placement[:3, 3]) if p.name in ex else np.zeros(3) for p in parts}
    for entry in data["parts"]:
        entry["shift"] = np.round(shift[entry["name"]], 4).tolist()
        entry["box"] = entry["name"] in boxed
    disk_shift = {p.station: shift[p.name] for p in robot if p.station is not None}
    poses, bending = _bent_poses(robot, st, sweep_deg)
    lines = {"straight": tendon_polylines(planned, 0.0)} | {
        pose["key"]: tendon_polylines(planned, pose["kappa"]) for pose in poses}
    for t in data["tendons"]:
        t.update({k: np.round(v[t["name"]], 4).tolist() for k, v in lines.items()})
        t["shift"] = [np.round(disk_shift.get(i, np.zeros(3)), 4).tolist() for i in range(len(t["straight"]))]
    data.update({"explode_mm": explode_mm, "sweep_deg": sweep_deg, "poses": poses, "bending": bending,
                 "view": {"toward_camera": list(ISOMETRIC.toward_camera), "up": [0.0, 0.0, 1.0]},
                 "warning_colour": _hex(WARNING_COLOUR), "tendon_radius_mm": TENDON_TUBE_MM})
    data["messages"] += notes
    return glb(parts)


# --------------------------------------------------------------------------- the page

def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _script_text(text: str) -> str:
    """Text safe inside a <script> element (no "</script" can end it early)."""
    return text.replace("</", "<\\/")


def _ids(ids: list[str]) -> str:
    return f"<span class=ids>{_e(', '.join(ids))}</span>" if ids else ""


def _tree(data: dict) -> str:
    """The part tree as HTML: a group per family's first word (toggled whole, or part by part),
    the failing parts magenta with their check ids; then the tendons."""
    groups: dict[str, list[dict]] = {}
    for p in data["parts"]:
        groups.setdefault(p["group"], []).append(p)
    out = []
    for g, ps in groups.items():
        on = "" if all(p["fixture"] for p in ps) else " checked"        # an assembly aid starts hidden
        items = "".join(
            f'<li data-part="{_e(p["name"])}"{" class=failing" if p["failing"] else ""}>'
            f'<input type=checkbox data-part="{_e(p["name"])}"{on}><span class=swatch style="background:{p["colour"]}">'
            f'</span><button class=name type=button>{_e(p["name"])}</button> <span class=family>{_e(p["family"])}'
            f'{" (box)" if p["box"] else ""}</span>'
            f'{_ids(p["failing"])}</li>' for p in ps)
        out.append(f'<details open><summary><input type=checkbox data-group="{_e(g)}"{on}> '
                   f'{_e(GROUP_LABELS.get(g, g))} ({len(ps)})</summary><ul>{items}</ul></details>')
    items = "".join(
        f'<li data-tendon="{_e(t["name"])}"{" class=failing" if t["failing"] else ""}>'
        f'<input type=checkbox data-tendon="{_e(t["name"])}" checked><span class=swatch style="background:{t["colour"]}">'
        f'</span><button class=name type=button>{_e(t["name"])}</button> <span class=family>tendon</span>'
        f'{_ids(t["failing"])}</li>' for t in data["tendons"])
    out.append(f'<details open><summary><input type=checkbox data-group="(tendons)" checked> tendons '
               f'({len(data["tendons"])})</summary><ul>{items}</ul></details>')
    return "".join(out)


def _fix(check: dict) -> str:
    return f"<div class=fix>fix: {_e(check['fix'])}</div>" if check["fix"] else ""


def _failing_list(data: dict) -> str:
    """The checks that fail (errors first, then warnings), as the info panel shows before a click."""
    shown = [c for c in data["checks"] if c["status"] == "FAIL"] + [c for c in data["checks"] if c["status"] == "warning"]
    if not shown:
        return "<p>No check fails.</p>" if data["checks"] else ""
    return "".join(f'<div class="check {c["status"]}"><span class=status>{_e(c["status"])}</span><b>{_e(c["id"])}</b> '
                   f'<span class=where>{_e(c["where"])}</span><div>{_e(c["message"])}</div>'
                   f'{_fix(c)}</div>' for c in shown)


def _stiffness_html(table: dict) -> str:
    if "skipped" in table:
        return f'<p class=note>{_e(table["skipped"])}</p>'

    def cell(v, digits):
        return "–" if v is None else f"{v:.{digits}g}"
    rows = "".join(f'<tr><td>{_e(r["state"])}</td><td>{cell(r["none"], 4)}</td><td>{cell(r["stuck"], 4)}</td>'
                   f'<td>{cell(r["torsion"], 4)}</td></tr>' for r in table["rows"])
    return (f'<table id=stiffness><thead><tr><th>state</th><th>frictionless N/mm</th><th>stuck N/mm</th>'
            f'<th>torsion N·mm/rad</th></tr></thead><tbody>{rows}</tbody></table>'
            f'<p class=note>At the tip, {_e(table["orientation"])}; eyelets frictionless or all stuck (stiffness.json). '
            f'{_e(table["headline"])}</p>')


def _verdict(data: dict, ok: bool | None) -> str:
    n = len(data["checks"])
    if not n:
        return '<span class=verdict>not checked</span>'
    fails = sum(c["status"] == "FAIL" for c in data["checks"])
    warns = sum(c["status"] == "warning" for c in data["checks"])
    word = "PASS" if ok else "FAIL"
    return (f'<span class="verdict {word.lower()}">{word}: {n} checks, {fails} failed, {warns} warning(s)</span>')


def render_page(data: dict, ok: bool | None, glb_bytes: bytes | None = None, bundle: Path | None = None) -> str:
    """The page: the static HTML (the tree, the failing checks, the stiffness: all there without the
    viewer), and, given the GLB and the viewer's bundle, the 3D view with both inlined."""
    js, viewer = "", ""
    if bundle is not None and glb_bytes is not None:
        js = bundle.read_text(encoding="utf-8")
        m = BANNER.search(js[:300])
        viewer = m.group(1) if m else "unknown version"
    messages = "".join(f"<li>{_e(m)}</li>" for m in data["messages"])
    head = (f'<header><h1>{_e(data["design"])}</h1>{_verdict(data, ok)}'
            f'<span class=files><a href="summary.md">summary.md</a><a href="report.json">report.json</a>'
            f'<a href="stiffness.json">stiffness.json</a><a href="exploded.png">exploded.png</a></span>'
            f'<ul id=messages>{messages}</ul></header>')
    poses = "".join(f'<option value="{p["key"]}">{_e(p["label"])}</option>' for p in data.get("poses", []))
    view = "<section id=view></section>" if not js else (f'<section id=view><div id=controls><label>exploded <input id=explode type=range min=0 max=1 step=0.01 '
            f'value=0> <output id=explode-mm>0 mm</output></label><label>pose <select id=pose><option value=straight>'
            f'straight</option>{poses}</select></label><label><input id=marks type=checkbox checked> failing checks in '
            f'magenta</label><button id=fit type=button>fit view</button></div><div id=canvas></div>'
            f'<div id=legend>drag: turn · right-drag: move · wheel: zoom · click a part: its checks</div></section>')
    info = (f'<aside id=info><h2 id=info-title>Checks that fail or warn</h2><div id=info-body>{_failing_list(data)}</div>'
            f'<h2>Stiffness of the tendon states</h2>{_stiffness_html(data["stiffness"])}'
            f'<footer>hwgen {_e(data["hwgen"])}{"; viewer: " + _e(viewer) if viewer else ""}; '
            f'units mm</footer></aside>')
    scripts = ""
    if js:
        scripts = (f'<script type="application/json" id="hwgen-data">{_script_text(json.dumps(data))}</script>'
                   f'<script type="application/octet-stream" id="hwgen-glb">{base64.b64encode(glb_bytes).decode()}'
                   f'</script><script>{_script_text(js)}</script>')
    return (f'<!DOCTYPE html><html lang=en><head><meta charset=utf-8><title>{_e(data["design"])}: hwgen view</title>'
            f'<meta name=viewport content="width=device-width, initial-scale=1"><style>{STYLE.read_text()}</style>'
            f'</head><body data-state="{"loading" if js else "static"}">{head}<nav id=tree>{_tree(data)}</nav>{view}'
            f'{info}{scripts}</body></html>\n')


def write_view(folder: Path, manifest: Manifest, report: dict | None, study: dict | None, explode_mm: float,
               sweep_deg: float, viewer: str | None = None) -> Added:
    """view.html into the folder; the manifest's ``view`` section (what the page holds, what it
    could not draw) and the file's entry. Without the viewer (``viewer``: :func:`viewer_bundle`),
    no mesh is read: the page lists."""
    folder = Path(folder)
    data = listed(manifest, report, study)
    given = os.environ.get(VIEWER_ENV, "") if viewer is None else viewer
    bundle, glb_bytes = viewer_bundle(given), None
    if bundle is None:
        where = "" if given.lower() == "none" else f" ({BUNDLE} is missing)"
        data["messages"].insert(0, NO_VIEWER.format(where=where))
    elif not manifest.parts:
        data["messages"].insert(0, "The 3D view is empty: the manifest lists no part.")
    else:
        glb_bytes = drawn(folder, manifest, data, explode_mm, sweep_deg)
    text = render_page(data, (report or {}).get("ok", manifest.checks_ok), glb_bytes, bundle)
    (folder / PAGE).write_text(text, encoding="utf-8")
    entry = {"status": "ok" if glb_bytes is not None else "no viewer", "parts": len(data["parts"]),
             "glb_bytes": len(glb_bytes or b""), "boxes": [p["name"] for p in data["parts"] if p["box"]],
             "messages": data["messages"]}
    return Added({"view": entry}, {PAGE: {"path": PAGE, "sha256": sha256(folder / PAGE)}})
