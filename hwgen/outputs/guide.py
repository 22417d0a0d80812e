"""The assembly guide: assembly.md and assembly.html (one page, its pictures embedded), in
steps from the strip in the jig to the tensioning, each with a picture of the model with that
step's parts highlighted.

Every count, size and length a step gives comes from the bill of materials (``bom.csv``,
written by the stage before): a part or hardware row is cited as ``qty × part, size [BOM #n]``
and a tendon as ``1 × tendon X, cut L mm [BOM #n]``, so a reader can find it in the list and a
test can check each against it. The tensioning step's take-up per worm turn comes from the
geometry in the manifest: one worm turn turns the wheel by (thread starts / teeth) of a turn,
and the drum winds that share of its circumference at the winding radius (drum radius plus
half the line):

    take-up per worm turn = 2π · r_winding · starts / teeth

The pictures (``guide/step_NN.png``) are drawn by the pictures stage's child process
(:func:`picture_jobs` says what each shows); without a renderer the guide is written without
them and says so.
"""
from __future__ import annotations

import base64
import csv
import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..cad.manifest import Added, Manifest, sha256

FOLDER = "guide"
MD, HTML = "assembly.md", "assembly.html"
PICTURE_WIDTH_PX = 1000       # a step's picture: enough to tell the parts apart on a page, small embedded


@dataclass
class Step:
    key: str
    title: str
    lines: list[str]
    shown: list[str]                  # the parts drawn
    highlight: list[str]              # of those, the ones drawn in their colours (the others grey)
    tendons: bool = False             # draw the tendons through their eyelets
    picture: str = ""                 # guide/step_NN.png
    extra: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- the bill of materials

def read_bom(folder: Path) -> list[dict]:
    with open(Path(folder) / "bom.csv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def cite(row: dict) -> str:
    """A row of the bill of materials as the guide gives it (see the module)."""
    detail = f"cut {row['cut_length_mm']} mm" if row["family"] == "tendon" else row["size"]
    return f"{row['qty']} × {row['part']}, {detail} [BOM #{row['item']}]"


CITATION = re.compile(r"(\d+) × ([^,\[\]]+), ([^\[\]]+?) \[BOM #(\d+)\]")


def _users(row: dict) -> set[str]:
    """The parts a hardware row names as its users (its notes: "for a, b, c and 2 more; ...")."""
    head = row["notes"].split(";")[0].removeprefix("for ")
    return {w.strip() for w in re.split(r",\s*|\s+and\s+", head)}


def _hardware_for(bom: list[dict], names: set[str], only: bool = False) -> list[dict]:
    """The hardware rows for any of these parts (``only``: for none but these, of the parts it names)."""
    known = {r["part"] for r in bom}
    out = []
    for r in bom:
        users = _users(r) & known if r["family"] == "hardware" else set()
        if users & names and (not only or users <= names):
            out.append(r)
    return out


# --------------------------------------------------------------------------- the steps

def take_up(manifest: Manifest) -> dict | None:
    """Tendon wound in per worm turn, per channel, from the worm's starts and teeth and the drum's
    winding radius in the manifest."""
    out = {}
    worms = {p.channel: p for p in manifest.parts if p.role == "tensioner_worm"}
    for wheel in (p for p in manifest.parts if p.role == "tensioner_wheel"):
        worm = worms.get(wheel.channel)
        if worm is None or "winding_radius_mm" not in wheel.meta:
            continue
        r, starts, teeth = wheel.meta["winding_radius_mm"], worm.meta["starts"], worm.meta["teeth"]
        out[wheel.channel] = {"winding_radius_mm": r, "spool_diameter_mm": wheel.meta.get("spool_diameter_mm"),
                              "starts": starts, "teeth": teeth, "tendons": wheel.meta.get("tendons", []),
                              "take_up_mm": 2 * math.pi * r * starts / teeth,
                              "hex_key_mm": worm.meta.get("hex_key_mm"), "worm": worm.name, "wheel": wheel.name}
    return out or None


def _tension_step(manifest: Manifest, plan, tendon_rows: list[dict], shown: list[str], tensioner: list[str],
                  names) -> Step | None:
    """The tensioning step: each channel's take-up per worm turn and the tension it adds (None
    without a tensioner that takes up)."""
    tm = plan.tendon_material
    ups = take_up(manifest)
    if not ups:
        return None
    ea, comp = tm.axial_stiffness_n, tm.tie_off_compliance_mm_per_n
    rest = {r["part"].removeprefix("tendon "): (float(r["rest_length_mm"]), r) for r in tendon_rows}
    lines = [f"Turn each channel's worm with a {next(iter(ups.values()))['hex_key_mm']:g} mm hex key. One worm "
             f"turn turns the wheel by starts/teeth of a turn, and its drum winds that share of its "
             f"circumference: take-up per worm turn = 2π × winding radius × starts / teeth (the winding "
             f"radius is the drum's radius plus half the line)."]
    for ch, u in ups.items():
        per_n = [(t, rest[t][0] / ea + comp) for t in u["tendons"] if t in rest]
        tension = "; ".join(f"{t} about {u['take_up_mm'] / s:.1f} N per turn once taut "
                            f"(rest {rest[t][1]['rest_length_mm']} mm [BOM #{rest[t][1]['item']}] / EA {ea:g} N + "
                            f"{comp:g} mm/N at its ends)" for t, s in per_n)
        lines.append(f"Channel {ch} ({u['worm']}): 2π × {u['winding_radius_mm']:.3f} mm × {u['starts']} / "
                     f"{u['teeth']} = **{u['take_up_mm']:.3f} mm per worm turn**; {tension}.")
    lines.append(f"Take up the slack of every channel, then tension the stiffening channels and the actuating "
                 f"channel ({plan.tensioner.actuating_channel}) last, a quarter turn at a time; the worm "
                 f"self-locks, so the tension stays when the key comes off.")
    inside = [n for n in tensioner if n not in names(lambda p: p.role == "tensioner_housing")]
    return Step("tension", "Tensioning", lines, shown + inside,   # the housing hides the worms
                names(lambda p: p.role in ("tensioner_worm", "tensioner_drive")), tendons=True,
                extra={"take_up": ups})


def _rig_step(rig: list[str], rows: dict, bom: list[dict], shown: list[str]) -> Step:
    """The stiffness rig's step (Sect. III-C's push test)."""
    hw = _hardware_for(bom, set(rig))
    lines = ["For the push test (Sect. III-C): screw the load cell's fixed end under the bracket's arm and the "
             "push block under its free end, bolt the bracket to the arm's flange (its spigot in the flange's "
             "recess, the pin in its hole), and stand the base frame on the support: "
             + "; ".join(cite(rows[n]) for n in rig if n in rows) + "."]
    if hw:
        lines.append("Hardware: " + "; ".join(cite(r) for r in hw) + ".")
    lines.append("Jog the arm until the pad stands just above the first disk's rim, then push down at a constant "
                 "speed; the pad meets the rim above every eyelet, so no tendon is touched.")
    return Step("rig", "The stiffness rig", lines, shown, rig)


def steps(folder: Path, manifest: Manifest, plan, bom: list[dict] | None = None) -> list[Step]:
    """The assembly in order, each step's words (numbers from bom.csv, or the rows in ``bom``, and
    the plan's tendon material and actuating channel) and what its picture shows (from the manifest
    alone)."""
    bom = read_bom(folder) if bom is None else bom
    parts = manifest.parts
    names = lambda pred: [p.name for p in parts if pred(p)]          # noqa: E731
    disks = names(lambda p: p.role == "disk")
    strip = names(lambda p: p.role == "backbone")
    jig = names(lambda p: p.fixture)
    base = names(lambda p: p.role in ("base_mount", "base_clamp"))
    tensioner = names(lambda p: p.role.startswith("tensioner"))
    frame = names(lambda p: p.meta.get("bench") == "base_frame")
    rig = names(lambda p: p.meta.get("bench") == "rig")
    rows = {r["part"]: r for r in bom}
    tendon_rows = [r for r in bom if r["family"] == "tendon"]
    out: list[Step] = []

    strip_row = next((r for r in bom if r["part"] in strip), None)
    lines = []
    if strip_row:
        lines.append(f"Cut the strip: {cite(strip_row)}; {strip_row['notes']}.")
    if jig:
        lines.append("Lay it into the assembly jig: " + "; ".join(cite(rows[n]) for n in jig if n in rows) + ".")
    out.append(Step("strip", "The strip into the jig", lines, strip + jig, strip + jig))

    glue = next((r for r in bom if r["family"] == "consumable"), None)
    lines = [f"Slide the disks onto the strip in order, base to tip ({', '.join(disks)}), each into its "
             f"place in the jig: " + "; ".join(cite(rows[n]) for n in disks if n in rows) + "."]
    if glue:
        lines.append(f"Glue each disk to the strip through its glue port: {cite(glue)} in all ({glue['material']}).")
    out.append(Step("disks", "Disks on and glued", lines, strip + jig + disks, disks))

    lines = ["Thread the tendons in this order, each from the base disk through every disk's eyelet to the tip:"]
    lines += [f"{cite(r)} (channel {r['notes'].split(';')[0].removeprefix('channel ')})" for r in tendon_rows]
    out.append(Step("tendons", "Tendons threaded", lines, strip + disks, [], tendons=True))

    tm = plan.tendon_material
    term = tm.termination
    crimp = [r for r in bom if r["part"] == "crimp sleeve"]
    if term.kind == "knot":
        how = (f"tie a knot about {term.diameter:g} mm across in each tendon's base end and pull it into its "
               f"seat in the base disk")
    else:
        how = "squeeze a crimp sleeve onto each tendon's base end and pull it into its seat in the base disk: " + \
              "; ".join(cite(r) for r in crimp)
    out.append(Step("anchor", "Anchored at the base", [f"At the base disk ({disks[0]}), {how}."],
                    strip + disks, disks[:1], tendons=True))

    if base:
        hw = _hardware_for(bom, set(base))
        lines = ["Take the robot out of the jig and clamp the strip's base between the jaws: "
                 + "; ".join(cite(rows[n]) for n in base if n in rows) + "."]
        if hw:
            lines.append("Hardware: " + "; ".join(cite(r) for r in hw) + ".")
        out.append(Step("base", "The base mount", lines, strip + disks + base, base, tendons=True))
    if frame:
        out.append(_frame_step(frame, base, strip + disks, rows, bom, manifest))

    if tensioner:
        clamps = names(lambda p: p.role == "tensioner_clamp")
        hw = [r for r in _hardware_for(bom, set(tensioner)) if r not in _hardware_for(bom, set(clamps), only=True)]
        lines = ["Press the dowel pins, set the worms and wheels into the housing and fasten it to the tip disk: "
                 + "; ".join(cite(rows[n]) for n in tensioner if n in rows and rows[n]["family"] != "tensioner_clamp")
                 + "."]
        if hw:
            lines.append("Hardware: " + "; ".join(cite(r) for r in hw) + ".")
        shown = strip + disks[-1:] + tensioner
        out.append(Step("tensioner", "The tensioner mounted", lines, shown,
                        [n for n in tensioner if not n.startswith("tensioner_clamp")]))

        hw = _hardware_for(bom, set(clamps), only=True)
        lines = ["Lead each tendon to its channel's drum, wind it on and lock it under its clamp: "
                 + "; ".join(cite(rows[n]) for n in clamps if n in rows) + "."]
        if hw:
            lines.append("Hardware: " + "; ".join(cite(r) for r in hw) + ".")
        out.append(Step("wind", "Lines wound", lines, shown, clamps + names(lambda p: p.role == "tensioner_wheel"),
                        tendons=True))

    tension = _tension_step(manifest, plan, tendon_rows, strip + disks[-1:], tensioner, names)
    if tension is not None:
        out.append(tension)
    if rig:
        out.append(_rig_step(rig, rows, bom, strip + disks + base + frame + rig))
    for i, s in enumerate(out, start=1):
        s.picture = f"{FOLDER}/step_{i:02d}.png"
    return out


def _frame_step(frame: list[str], base: list[str], robot: list[str], rows: dict, bom: list[dict],
                manifest: Manifest) -> Step:
    """The rotating base frame (Fig. 3): built, and the base mount bolted onto its cradle."""
    hw = _hardware_for(bom, set(frame))
    cradle = next((p.meta for p in manifest.parts if p.name == "base_frame_cradle"), {})
    step = cradle.get("mark_step_deg", 15)
    lines = ["Press a bearing into each seat of the two uprights and screw the uprights onto the base plate; push "
             "the supporting shaft (on the robot's axis) and the lower shaft through them with a pulley each and the "
             "belt round both, the wheel on the lower shaft's flat; set the worm on its drive shaft and dowel between "
             "the base plate's posts; press the cradle's hub onto the supporting shaft's flat and bolt the base "
             "mount's foot onto the cradle: " + "; ".join(cite(rows[n]) for n in frame if n in rows) + "."]
    if hw:
        lines.append("Hardware: " + "; ".join(cite(r) for r in hw) + ".")
    lines.append(f"The flange is marked every {step:g}°, longer at 0° and 90°; a Ø4 dowel through the front upright "
                 f"into the flange's index hole holds the robot at 0° or 90°. Turn the worm with the hex key to roll "
                 f"the robot (1:1 belt: one wheel turn, one robot turn); it self-locks at any angle.")
    return Step("frame", "The rotating base frame", lines, robot + base + frame, frame, tendons=True)


def picture_jobs(folder: Path, manifest: Manifest, plan) -> list[dict]:
    """What the pictures stage draws for the guide: per step its file, title, parts shown and highlighted.
    Those come from the manifest alone, not the bill of materials: the pictures stage runs beside
    the checks, before bom.csv is written."""
    return [{"file": s.picture, "title": f"{i}. {s.title}", "shown": s.shown, "highlight": s.highlight,
             "tendons": s.tendons} for i, s in enumerate(steps(folder, manifest, plan, bom=[]), start=1)]


# --------------------------------------------------------------------------- the documents

def _markdown(manifest: Manifest, ss: list[Step], pictures: bool) -> str:
    L = [f"# Assembly guide: {manifest.name}", "",
         f"From `{manifest.params_file}`, hwgen {manifest.hwgen_version}. Counts, sizes and "
         f"lengths are rows of the bill of materials (`bom.md`, `bom.csv`), cited as [BOM #item]; the print plates "
         f"are in `plates/plates.md`.", ""]
    if not pictures:
        L += ["(No pictures: the renderer was not available when this was built; see the build's warning.)", ""]
    for i, s in enumerate(ss, start=1):
        L += [f"## {i}. {s.title}", ""]
        if pictures:
            # assembly.md sits in the guide's folder beside its pictures: linked from there
            L += [f"![{s.title}: {', '.join(s.highlight) or 'the tendons'} highlighted]"
                  f"({Path(s.picture).relative_to(FOLDER).as_posix()})", ""]
        L += [f"- {line}" for line in s.lines] + [""]
    return "\n".join(L)


_BOLD = re.compile(r"\*\*(.+?)\*\*")
_CODE = re.compile(r"`([^`]+)`")


def _inline(text: str) -> str:
    t = html.escape(text, quote=False)
    return _CODE.sub(r"<code>\1</code>", _BOLD.sub(r"<strong>\1</strong>", t))


def _html(folder: Path, manifest: Manifest, ss: list[Step], pictures: bool) -> str:
    title = html.escape(f"Assembly guide: {manifest.name}")
    H = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">', f"<title>{title}</title>",
         "<style>body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.45}"
         "img{max-width:100%;border:1px solid #ccc}li{margin:.3em 0}</style></head><body>", f"<h1>{title}</h1>",
         f"<p>Counts, sizes and lengths are rows of the bill of materials (bom.md, bom.csv), cited as [BOM #item].</p>"]
    for i, s in enumerate(ss, start=1):
        H.append(f'<h2 id="{s.key}">{i}. {html.escape(s.title)}</h2>')
        if pictures:
            data = base64.b64encode((Path(folder) / s.picture).read_bytes()).decode()
            H.append(f'<img alt="{html.escape(s.title)}" src="data:image/png;base64,{data}">')
        H.append("<ul>" + "".join(f"<li>{_inline(line)}</li>" for line in s.lines) + "</ul>")
    H.append("</body></html>")
    return "\n".join(H) + "\n"


def write_guide(folder: Path, manifest: Manifest, plan) -> Added:
    """guide/assembly.md and guide/assembly.html (pictures embedded) into the folder, from
    bom.csv, the manifest and the step pictures the pictures stage drew; what the manifest lists
    of them (the files, the steps)."""
    folder = Path(folder)
    ss = steps(folder, manifest, plan)
    pictures = all((folder / s.picture).is_file() for s in ss)
    (folder / FOLDER).mkdir(exist_ok=True)
    (folder / FOLDER / MD).write_text(_markdown(manifest, ss, pictures), encoding="utf-8")
    (folder / FOLDER / HTML).write_text(_html(folder, manifest, ss, pictures), encoding="utf-8")
    files = {key: {"path": f"{FOLDER}/{name}", "sha256": sha256(folder / FOLDER / name)}
             for key, name in (("guide_md", MD), ("guide_html", HTML))}
    entry = {"steps": [{"title": s.title, "picture": s.picture if pictures else None, "highlight": s.highlight}
                       for s in ss], "pictures": pictures}
    tension = next((s for s in ss if s.key == "tension"), None)
    if tension:
        entry["take_up_per_worm_turn"] = {ch: {k: v for k, v in u.items() if k != "tendons"}
                                          for ch, u in tension.extra["take_up"].items()}
    return Added({"guide": entry}, files)
