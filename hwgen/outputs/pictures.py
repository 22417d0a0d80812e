"""Offscreen pictures of a built design: exploded, assembled and bent (VTK, no display, no GPU).

The pictures are drawn in a child process (``python -m hwgen.outputs.pictures``): an OpenGL
driver that is missing or crashes then costs the pictures, never the build. :func:`draw` asks
the child for the pictures and the SVG drawing; if no backend works it records a message
saying what to install and carries on.

Views (parallel projection, robot coordinates: y along the backbone, bending toward +z):

* exploded: disks spread along y by ``render.explode_mm`` per gap, the strip pulled out
  toward the base, the tensioner lifted clear of the tip disk and its parts moved out of
  the housing along their own offsets (see :func:`hwgen.outputs.scene.exploded_placements`);
* assembled: every part where the manifest places it, tendons drawn through their eyelets;
* bent: the constant-curvature pose of eq. (1) at ``render.bend_deg``: disks moved rigidly
  to their frames T_i, the strip bent point by point, each tendon a tube through its eyelets;
* turned (a design with a base frame): the robot rolled by TURNED_DEG in its frame (issue 46).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import time
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import cache
from ..cad.manifest import Added, Manifest, sha256
from ..checks.base import fails
from ..checks.report import named
from ..model import kinematics as kin
from .bom import family_label
from .drawing import write_exploded_svg
from .scene import (Posed, exploded_placements, family_colours, load_parts, pose_bent, pose_rigid,
                    tendon_colours, tendon_polylines)
from .view import BACKEND_ENV, BENT, ISOMETRIC, TEXT_COLOUR, Look, Renderer, RenderUnavailable, View

CHILD_TIMEOUT_S = 300
INSTALL_HINT = (
    "Offscreen pictures need an OpenGL backend for VTK without a display: Mesa's EGL with the "
    "llvmpipe software rasteriser (Debian/Ubuntu: apt-get install libegl1 libgl1-mesa-dri; "
    "Fedora: dnf install mesa-libEGL mesa-dri-drivers), or VTK's OSMesa build "
    "(pip install --extra-index-url https://wheels.vtk.org vtk-osmesa). "
    "The parts, checks and bill of materials were written without the pictures.")
LABEL_GAP_MM = 6.0          # disk numbers sit this far above the disk's top on screen
OUTPUTS = ("exploded.png", "assembled.png", "turned.png", "bent.png", "jig.png", "exploded.svg")
TURNED_DEG = 90.0          # turned.png: the robot rolled this far in its base frame (the protocol turns it by 90°)
EXIT_NO_BACKEND = 3      # the child's exit code for RenderUnavailable
# Mesa's llvmpipe rasterises in the drawing thread itself (unless the user sets it otherwise): its
# rasteriser threads' scene memory made about a tenth of the renderer's peak, the pictures have the
# same bytes, and the checks drawn beside them keep the other core
RASTER_THREADS_ENV = "LP_NUM_THREADS"
# OpenBLAS likewise: its threads for the small products here (a part's face normals turned to the
# view, (m, 3) @ (3, 3)) cost more than they do, most of it waiting for the other core; one
# thread gives the same bytes
BLAS_THREADS_ENV = "OPENBLAS_NUM_THREADS"


class RenderFailed(RuntimeError):
    """The renderer ran but stopped on an error of its own (a bad file, a bug): not a backend problem."""


@dataclass(frozen=True)
class Settings:
    width_px: int
    explode_mm: float
    bend_deg: float


def _legend(names_colours, title: str):
    """Title, then one coloured swatch and a dark label per entry: (text, rgb, (fx, fy), size, swatch)."""
    texts = [(title, TEXT_COLOUR, (0.015, 0.955), 30, None)]
    for i, (name, rgb) in enumerate(names_colours):
        texts.append((name, TEXT_COLOUR, (0.015, 0.91 - 0.035 * i), 24, rgb))
    return texts


def station_labels(posed: list[Posed], view: View) -> list[tuple[str, np.ndarray]]:
    """Disk numbers (the station index) just above each disk on the screen."""
    right, up, d = view.axes()
    out = []
    for ps in posed:
        if ps.part.station is None:
            continue
        top = ps.vertices[np.argmax(ps.vertices @ up)]
        out.append((str(ps.part.station), top + up * LABEL_GAP_MM))
    return out


WARNING_ROLE, WARNING_COLOUR = "(failing check)", (1.0, 0.0, 0.55)   # a vivid magenta no family or tendon has
MARKED = ("exploded.png", "bent.png")      # the pictures that mark what fails


def failing_marks(checks) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """(part -> check ids, tendon -> check ids) of the checks that fail the design (errors), from
    the part(s) and tendon(s) each names where it looked."""
    parts: dict[str, list[str]] = {}
    tendons: dict[str, list[str]] = {}
    for c in checks or []:
        if not fails(c):
            continue
        for names, into in zip(named(c), (parts, tendons)):
            for one in names:
                ids = into.setdefault(one, [])
                if c["id"] not in ids:
                    ids.append(c["id"])
    return parts, tendons


def _marked(posed: list[Posed], parts: dict[str, list[str]]) -> list[Posed]:
    return [ps.as_role(WARNING_ROLE) if ps.part.name in parts else ps for ps in posed]


def _part_labels(posed: list[Posed], view: View, parts: dict[str, list[str]]) -> list[tuple]:
    """The failing checks' ids beside the marked parts (right of them on the screen; a part along
    the backbone at a third of its length), once for parts that fail the same checks, in the
    warning colour."""
    right, up, _ = view.axes()
    groups: dict[str, list[np.ndarray]] = {}
    for ps in posed:
        if ps.part.name not in parts:
            continue
        v = ps.vertices
        if ps.part.station is None and np.ptp(v[:, 1]) > 0.5 * np.ptp(v, axis=0).max():   # along the backbone
            y = np.percentile(v[:, 1], 33)
            v = v[np.abs(v[:, 1] - y) <= np.ptp(v[:, 1]) * 0.02]
        groups.setdefault(", ".join(parts[ps.part.name]), []).append(v[np.argmax(v @ right)])
    return [(text, max(pts, key=lambda p: p @ right) + right * LABEL_GAP_MM, WARNING_COLOUR)
            for text, pts in groups.items()]


def _tendon_marks(tubes: dict, tendons: dict[str, list[str]], view: View) -> tuple[dict, list[tuple]]:
    """Tubes of tendons with a failing check in the warning colour, and a label beside each (spread
    along the tubes, so that two do not meet)."""
    right, _, _ = view.axes()
    out, labels = {}, []
    marked = [n for n in tubes if n in tendons]
    for name, (pts, rgb) in tubes.items():
        if name in tendons:
            out[name] = (pts, WARNING_COLOUR)
            k = marked.index(name)
            at = pts[min(len(pts) - 1, int(len(pts) * (k + 1) / (len(marked) + 1)))]
            labels.append((f"{name}: {', '.join(tendons[name])}", at + right * LABEL_GAP_MM, WARNING_COLOUR))
        else:
            out[name] = (pts, rgb)
    return out, labels


def _warning_legend(parts: dict, tendons: dict) -> list[tuple[str, tuple]]:
    what = [f"{len(d)} {word}{'s' if len(d) > 1 else ''}" for d, word in ((parts, "part"), (tendons, "tendon")) if d]
    return [(f"failing check: {' and '.join(what)} (summary.md)", WARNING_COLOUR)] if what else []


def _jig(r: Renderer, parts: list, aids: list, placed: dict, manifest: Manifest, path: Path) -> dict:
    """jig.png: the disks and the strip the assembly jig holds, in it; its size."""
    holds = {n for a in aids for n in a.meta.get("holds", [])}
    shown = [p for p in parts if p.name in holds] + aids
    jig_colours = family_colours(manifest, fixtures=True)
    posed = [placed[p.name] for p in shown]
    roles = [role for role in jig_colours if any(p.role == role for p in shown)]
    legend = [(f"{family_label(role)} ({sum(p.role == role for p in shown)})", jig_colours[role]) for role in roles]
    _, W, H = r.draw(posed, jig_colours, ISOMETRIC, path,
                     texts=_legend(legend, f"{manifest.name}: the disks and the strip in the assembly jig"))
    return {"width": W, "height": H}


def render_pictures(folder: Path, manifest: Manifest, settings: Settings, svg_table: list[dict] | None = None,
                    renderer: Renderer | None = None, steps: list[dict] | None = None,
                    only: tuple[str, ...] | None = None) -> dict:
    """exploded.png, assembled.png, bent.png, jig.png when the design has an assembly jig (and
    exploded.svg when a parts table is given; the assembly guide's step pictures when ``steps``
    are given, see :func:`hwgen.outputs.guide.picture_jobs`); ``only``: just these of them.
    When the manifest holds the checks, exploded.png and bent.png draw every part and tendon of
    a failing check in the warning colour, labelled with the check's id."""
    folder = Path(folder)
    timings = {}
    t0 = time.perf_counter()
    r = renderer or Renderer(settings.width_px)
    parts = load_parts(folder, manifest)
    report = manifest.design_report
    st = np.asarray(report["stations_mm"], dtype=float)
    colours = family_colours(manifest)
    tcol = tendon_colours(report)
    aids = load_parts(folder, manifest, fixtures=True)
    timings["load_s"] = time.perf_counter() - t0
    fam_legend = [(f"{family_label(role)} ({sum(p.role == role for p in parts)})", colours[role]) for role in colours]
    images = {}
    marks = failing_marks(manifest.checks)
    warned = colours | {WARNING_ROLE: WARNING_COLOUR}
    wanted = set(only or (*OUTPUTS, "guide"))

    t = time.perf_counter()
    d = np.asarray(ISOMETRIC.toward_camera, float)
    d /= np.linalg.norm(d)
    ex = exploded_placements(parts, st, settings.explode_mm, ISOMETRIC.toward_camera)
    exploded = [pose_rigid(p, ex[p.name], d) for p in parts]     # drawn again as exploded.svg
    if "exploded.png" in wanted:
        labels = station_labels(exploded, ISOMETRIC) + _part_labels(exploded, ISOMETRIC, marks[0])
        _, W, H = r.draw(_marked(exploded, marks[0]), warned, ISOMETRIC, folder / "exploded.png", labels=labels,
                         texts=_legend(fam_legend + _warning_legend(marks[0], {}),
                                       f"{manifest.name}: exploded, {settings.explode_mm:g} mm between disks"))
        images["exploded.png"] = {"width": W, "height": H}
    timings["exploded_s"] = time.perf_counter() - t

    t = time.perf_counter()
    # every part where the manifest places it: drawn again by the jig and the guide's steps
    placed = {p.name: pose_rigid(p, p.placement, d) for p in parts + aids} if wanted - set(MARKED) else {}
    if "assembled.png" in wanted:
        posed = [placed[p.name] for p in parts]
        straight = {n: (pts, tcol[n]) for n, pts in tendon_polylines(report, 0.0).items()}
        _, W, H = r.draw(posed, colours, ISOMETRIC, folder / "assembled.png", tubes=straight,
                         texts=_legend(fam_legend + [(n, tcol[n]) for n in straight], f"{manifest.name}: assembled"))
        images["assembled.png"] = {"width": W, "height": H}
    timings["assembled_s"] = time.perf_counter() - t

    t = time.perf_counter()
    if "turned.png" in wanted and any(p.meta.get("turns") for p in parts):
        images["turned.png"] = _turned(r, parts, colours, report, tcol, d, folder / "turned.png", manifest.name)
    timings["turned_s"] = time.perf_counter() - t

    t = time.perf_counter()
    if "bent.png" in wanted:
        kappa = float(kin.kappas_for_angles([settings.bend_deg], st[-1] - st[0])[0])
        b = np.asarray(BENT.toward_camera, float)
        b /= np.linalg.norm(b)
        posed = [pose_bent(p, st, kappa, b) for p in parts]
        bent, tube_labels = _tendon_marks({n: (pts, tcol[n]) for n, pts in tendon_polylines(report, kappa).items()},
                                          marks[1], BENT)
        texts = _legend([(n, tcol[n]) for n in bent] + _warning_legend(*marks),
                        f"{manifest.name}: bent {settings.bend_deg:g}° (constant curvature, eq. 1)")
        texts.append((reachable_note(manifest), TEXT_COLOUR, (0.015, 0.02), 22, None))
        _, W, H = r.draw(_marked(posed, marks[0]), warned, BENT, folder / "bent.png", tubes=bent,
                         look=Look(aspect_range=(0.6, 1.0)), texts=texts,
                         labels=_part_labels(posed, BENT, marks[0]) + tube_labels)
        images["bent.png"] = {"width": W, "height": H}
    timings["bent_s"] = time.perf_counter() - t

    if aids and "jig.png" in wanted:
        t = time.perf_counter()
        images["jig.png"] = _jig(r, parts, aids, placed, manifest, folder / "jig.png")
        timings["jig_s"] = time.perf_counter() - t

    result = {"backend": r.backend, "images": images, "timings_s": timings, "bent_note": reachable_note(manifest),
              "palette": {k: list(v) for k, v in colours.items()},
              "tendon_colours": {k: list(v) for k, v in tcol.items()},
              "explode_mm": settings.explode_mm, "bend_deg": settings.bend_deg}
    if any(marks):
        result["failing"] = {"parts": marks[0], "tendons": marks[1], "colour": list(WARNING_COLOUR),
                             "pictures": list(MARKED)}
    if steps and "guide" in wanted:
        t = time.perf_counter()
        for job in steps:
            images[job["file"]] = draw_step(r, folder, manifest, job, placed, tcol)
        timings["guide_s"] = time.perf_counter() - t
    if svg_table is not None and "exploded.svg" in wanted:
        t = time.perf_counter()
        result["svg"] = write_exploded_svg(r, exploded, colours, svg_table, folder / "exploded.svg",
                                           title=f"{manifest.name}: exploded assembly")
        timings["svg_s"] = time.perf_counter() - t
    return result


def _turned(r: Renderer, parts, colours: dict, report: dict, tcol: dict, d: np.ndarray, path: Path,
            name: str) -> dict:
    """The robot rolled by TURNED_DEG about its axis (y) in its base frame: what turns (the robot's
    parts and the frame's cradle, by their manifest entries) turned, the frame where it stands;
    the rig, moved by the arm, left out."""
    a = math.radians(TURNED_DEG)
    roll = np.eye(4)
    roll[:3, :3] = [[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]]
    bench = [p for p in parts if p.meta.get("bench") == "base_frame"]
    turning = [p for p in parts if not p.meta.get("bench") or p.meta.get("turns") and p.role == "base_frame"]
    posed = [pose_rigid(p, roll @ p.placement, d) for p in turning]
    posed += [pose_rigid(p, p.placement, d) for p in bench if p not in turning]
    tubes = {n: (pts @ roll[:3, :3].T, tcol[n]) for n, pts in tendon_polylines(report, 0.0).items()}
    shown = {p.role for p in turning} | {p.role for p in bench}
    legend = [(family_label(role), colours[role]) for role in colours if role in shown]
    _, W, H = r.draw(posed, colours, ISOMETRIC, path, tubes=tubes,
                     texts=_legend(legend, f"{name}: turned {TURNED_DEG:g}° in its base frame"))
    return {"width": W, "height": H}


CONTEXT_ROLE, CONTEXT_GREY = "(context)", (0.86, 0.86, 0.86)   # a guide picture's parts not of its step


def draw_step(r: Renderer, folder: Path, manifest: Manifest, job: dict, placed: dict[str, Posed], tcol: dict) -> dict:
    """One step of the assembly guide: the parts it shows, assembled (``placed``: every part posed
    where the manifest places it, seen along the isometric view), those of the step in their
    family's colour and the others light grey, the tendons when it says so."""
    colours = family_colours(manifest, fixtures=True) | {CONTEXT_ROLE: CONTEXT_GREY}
    posed = []
    for name in job["shown"]:
        ps = placed.get(name)
        if ps is not None:
            posed.append(ps if name in job["highlight"] else ps.as_role(CONTEXT_ROLE))
    tubes = {n: (pts, tcol[n]) for n, pts in tendon_polylines(manifest.design_report, 0.0).items()} \
        if job["tendons"] else None
    (Path(folder) / job["file"]).parent.mkdir(parents=True, exist_ok=True)
    _, W, H = r.draw(posed, colours, ISOMETRIC, Path(folder) / job["file"], tubes=tubes,
                     texts=[(job["title"], TEXT_COLOUR, (0.015, 0.95), 40, None)], look=Look(width=GUIDE_WIDTH_PX))
    return {"width": W, "height": H}


GUIDE_WIDTH_PX = 1000        # a guide step's picture: the parts tell apart on a page, the HTML stays small


def reachable_note(manifest: Manifest) -> str:
    """Whether the hardware can hold the bent pose: only if some drum winds a pair of tendons in
    opposite senses, so that turning its worm hauls one in as it pays the other out."""
    drums = [p for p in manifest.parts if p.role == "tensioner_wheel" and len(p.tendons) > 1]
    bending = [p for p in drums if p.meta.get("winding") == "opposite"]
    if bending:
        return (f"the worm of channel {bending[0].meta['channel']} bends the robot: its drum winds "
                f"{' and '.join(bending[0].tendons)} in opposite senses")
    if drums:
        return (f"model only: the tensioner pre-tensions {' and '.join(drums[0].tendons)} together "
                f"(tensioner.winding: same); it cannot bend the robot")
    return "model only: no drum of this tensioner winds a pair of tendons, so nothing bends the robot"


# --------------------------------------------------------------------------- in a child process

def run_child(folder: Path, manifest: Manifest, settings: Settings, svg_table: list[dict] | None,
              steps: list[dict] | None = None, only: tuple[str, ...] | None = None, enabled: bool = True) -> dict:
    """Draw the pictures (``only``: just these) in a fresh Python process; raise RenderUnavailable
    if it cannot, or when the build's options switch the pictures off (``enabled``)."""
    if not enabled:
        raise RenderUnavailable(f"{BACKEND_ENV}=none: offscreen rendering switched off")
    store = cache.active()
    job = json.dumps({"folder": str(folder), "manifest": manifest.to_json(), "settings": settings.__dict__,
                      "svg_table": svg_table, "steps": steps, "only": list(only) if only else None,
                      # where the child finds the meshes read before (checks.meshes: by their bytes)
                      "store": str(store.folder) if store is not None and store.enabled else None})
    attempts = [dict(os.environ)]
    attempts[0].pop("DISPLAY", None)            # offscreen: EGL first, never a stale X display
    attempts[0].setdefault(RASTER_THREADS_ENV, "0")
    if os.environ.get("DISPLAY"):
        attempts.append(dict(os.environ))       # then the display's own OpenGL, if there is one
    for env in attempts:
        env.setdefault(BLAS_THREADS_ENV, "1")
    errors, backend = [], True
    for env in attempts:
        try:
            proc = subprocess.run([sys.executable, "-m", "hwgen.outputs.pictures"], input=job, capture_output=True,
                                  text=True, env=env, timeout=CHILD_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            errors.append(f"the renderer did not finish in {CHILD_TIMEOUT_S} s")
            continue
        lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
        if proc.returncode == 0 and lines:
            return json.loads(lines[-1])
        tail = (proc.stderr.strip().splitlines() or [""])[-1][:300]
        if proc.returncode < 0:          # killed by a signal: the OpenGL driver crashed
            errors.append(f"the renderer crashed (signal {-proc.returncode}) {tail}".strip())
        else:
            errors.append(tail or f"the renderer stopped with exit code {proc.returncode}")
            backend = proc.returncode == EXIT_NO_BACKEND
    raise (RenderUnavailable if backend else RenderFailed)("; ".join(errors))


def _child_main() -> int:
    job = json.loads(sys.stdin.read())
    store = cache.Store(Path(job["store"])) if job.get("store") else None
    try:
        with cache.using(store) if store is not None else nullcontext():
            result = render_pictures(Path(job["folder"]), Manifest.of(job["manifest"]), Settings(**job["settings"]),
                                     job.get("svg_table"), steps=job.get("steps"),
                                     only=tuple(job["only"]) if job.get("only") else None)
    except RenderUnavailable as e:
        print(f"RenderUnavailable: {e}", file=sys.stderr)
        return EXIT_NO_BACKEND
    print(json.dumps(result))
    return 0


def draw(folder: Path, manifest: Manifest, render, svg_table: list[dict], steps: list[dict] | None = None,
         enabled: bool = True) -> Added:
    """The pictures and the drawing as the plan's ``render`` settings say (width, explode, bend;
    ``svg_table``: the parts table of the bill of materials),
    and the assembly guide's step pictures (``steps``); the manifest's ``render`` section, which
    records a missing or crashing backend, or pictures the build's options switched off
    (``enabled``), never raised."""
    folder = Path(folder)
    settings = Settings(render.width_px, render.explode_mm, render.bend_deg)
    entry: dict = {"settings": settings.__dict__}
    for name in OUTPUTS:                 # never leave pictures of an earlier design beside this one
        (folder / name).unlink(missing_ok=True)
    for job in steps or []:
        (folder / job["file"]).unlink(missing_ok=True)
    try:
        result = run_child(folder, manifest, settings, svg_table, steps, enabled=enabled)
    except RenderUnavailable as e:
        entry |= {"status": "unavailable", "message": f"pictures not drawn: {e}. {INSTALL_HINT}"}
    except RenderFailed as e:
        entry |= {"status": "failed", "message": f"pictures not drawn, the renderer stopped: {e}"}
    else:
        files = {}
        for name, size in result.pop("images").items():
            files[name] = {"path": name, "sha256": sha256(folder / name)} | size
        if (folder / "exploded.svg").exists():
            files["exploded.svg"] = {"path": "exploded.svg", "sha256": sha256(folder / "exploded.svg")}
        result.pop("timings_s", None)       # the manifest holds no times: rebuilds are byte-identical
        entry |= {"status": "ok", "files": files} | result
    return Added({"render": entry})


def mark_failures(folder: Path, manifest: Manifest, render, enabled: bool = True) -> Added:
    """exploded.png and bent.png drawn again with every part and tendon of a failing check in the
    warning colour, once the checks are in the manifest (a build draws its pictures beside the
    checks, before their verdict); the manifest's ``render`` section as it then stands. Nothing is
    drawn (and nothing added) when no check fails, when they were drawn with these marks already,
    or when the pictures could not be drawn (or were switched off: ``enabled``); a renderer that fails now leaves the unmarked
    pictures and says so in the section's ``failing``."""
    entry = json.loads(json.dumps(manifest.render or {}))
    parts, tendons = failing_marks(manifest.checks)
    if entry.get("status") != "ok" or not (parts or tendons):
        return Added()
    if (entry.get("failing") or {}).get("parts") == parts and entry["failing"].get("tendons") == tendons:
        return Added()
    folder = Path(folder)
    settings = Settings(render.width_px, render.explode_mm, render.bend_deg)
    try:
        result = run_child(folder, manifest, settings, None, only=MARKED, enabled=enabled)
    except (RenderUnavailable, RenderFailed) as e:
        entry["failing"] = {"parts": parts, "tendons": tendons, "message": f"not marked in the pictures: {e}"}
        return Added({"render": entry})
    for name, size in result["images"].items():
        entry["files"][name] = {"path": name, "sha256": sha256(folder / name)} | size
    entry["failing"] = result["failing"]
    return Added({"render": entry})


if __name__ == "__main__":
    sys.exit(_child_main())
