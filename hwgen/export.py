"""Files: STEP, STL, the assembly STEP, the backbone DXF template and the manifest."""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from .design import BackboneSpec, Plan
from .parts import Part

# STL tessellation: 0.01 mm chordal deviation keeps eyelet sections true to well under the
# 0.02 mm the checks need; 0.2 rad angular keeps a Ø1 mm eyelet at ~32 facets and a disk
# file under 1 MB.
STL_TOLERANCE_MM = 0.01
STL_ANGULAR_RAD = 0.2


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_step(solid, path: Path) -> None:
    import cadquery as cq
    cq.exporters.export(cq.Workplane().add(solid), str(path), exportType="STEP")


def write_stl(solid, path: Path) -> None:
    solid.exportStl(str(path), tolerance=STL_TOLERANCE_MM, angularTolerance=STL_ANGULAR_RAD, ascii=False,
                    relative=False)


def location(matrix: np.ndarray):
    """cq.Location from a 4x4 rigid transform."""
    import cadquery as cq
    from OCP.gp import gp_Trsf
    t = gp_Trsf()
    m = matrix
    t.SetValues(*(float(m[r, c]) for r in range(3) for c in range(4)))
    return cq.Location(t)


def write_assembly(parts: list[Part], name: str, path: Path) -> None:
    import cadquery as cq
    assy = cq.Assembly(name=name)
    for p in parts:
        assy.add(p.solid, name=p.name, loc=location(p.placement), color=cq.Color(*p.color))
    assy.export(str(path), exportType="STEP")


def write_backbone_dxf(spec: BackboneSpec, stations, path: Path) -> None:
    """1:1 cut-and-drill template: outline, holes labelled by station and tendon, disk lines."""
    import ezdxf
    from ezdxf.enums import TextEntityAlignment

    from .parts.backbone import unique_holes

    doc = ezdxf.new("R2010", setup=True)
    doc.units = ezdxf.units.MM
    doc.header["$MEASUREMENT"] = 1
    for layer, color in (("OUTLINE", 7), ("HOLES", 1), ("LABELS", 3), ("DISKS", 8)):
        doc.layers.add(layer, color=color)
    msp = doc.modelspace()
    hx = spec.height / 2
    msp.add_lwpolyline([(-hx, spec.y_start), (hx, spec.y_start), (hx, spec.y_end), (-hx, spec.y_end)],
                       close=True, dxfattribs={"layer": "OUTLINE"})
    for i, y in enumerate(stations):
        msp.add_line((-hx, y), (hx, y), dxfattribs={"layer": "DISKS", "linetype": "DASHED"})
        msp.add_text(f"disk {i}", height=2.0, dxfattribs={"layer": "LABELS"}).set_placement(
            (hx + 2, y), align=TextEntityAlignment.MIDDLE_LEFT)
    by_station = {(round(h.x, 6), round(h.y, 6)): h.station for h in spec.holes}
    for x, y, dia, tendons in unique_holes(spec):
        msp.add_circle((x, y), dia / 2, dxfattribs={"layer": "HOLES"})
        st = by_station[(round(x, 6), round(y, 6))]
        where = f"i={st:g}" if float(st).is_integer() else f"i={st:.2f}"
        msp.add_text(f"{where} {'+'.join(tendons)} Ø{dia:.2f}", height=1.5, dxfattribs={"layer": "LABELS"}
                     ).set_placement((x + dia / 2 + 1, y + 1), align=TextEntityAlignment.BOTTOM_LEFT)
    doc.saveas(path)


def design_report(plan: Plan) -> dict:
    """The design intent the checks compare against, as plain JSON."""
    return {
        "stations_mm": list(plan.stations),
        "tendons": [{"name": p.name, "channel": p.channel, "source": p.source, "budget_mm": p.budget_mm,
                     "eyelets_xz_mm": p.points.tolist()} for p in plan.paths],
        "disks": [{"index": d.index, "y_mm": d.y, "role": d.role, "thickness_mm": d.thickness,
                   "outer_diameter_mm": d.outer_diameter, "slot_mm": [d.slot_width, d.slot_height],
                   "holes": [{"x": h.x, "z": h.z, "axis": list(h.axis), "diameter_mm": h.diameter,
                              "tendons": list(h.tendons), "worst_angle_deg": h.worst_angle_deg,
                              "in_slot": h.in_slot} for h in d.holes],
                   "mount_holes": [list(m) for m in d.mount_holes],
                   "knot_pockets": [list(k) for k in d.knot_pockets]} for d in plan.disks],
        "merges": [{"station": m.station, "tendons": list(m.tendons), "kind": m.kind} for m in plan.merges],
        "backbone_holes": [{"tendon": h.tendon, "station": h.station, "x_mm": h.x, "y_mm": h.y,
                            "diameter_mm": h.diameter} for h in plan.backbone.holes],
        "findings": list(plan.findings),
    }


def part_entry(part: Part, files: dict[str, Path], root: Path) -> dict:
    bb = part.solid.BoundingBox()
    entry = {
        "name": part.name,
        "role": part.role,
        "files": {kind: {"path": str(p.relative_to(root)), "sha256": sha256(p)} for kind, p in files.items()},
        "volume_mm3": part.solid.Volume(),
        "bbox_mm": {"min": [bb.xmin, bb.ymin, bb.zmin], "max": [bb.xmax, bb.ymax, bb.zmax]},
        "placement": part.placement.tolist(),
        "color": list(part.color),
    }
    if part.station is not None:
        entry["station"] = part.station
    entry.update(part.meta)
    return entry


def write_json(obj, path: Path) -> None:
    path.write_text(json.dumps(obj, indent=2) + "\n")
