"""Files: STEP, STL, the assembly STEP and the backbone's DXF template (CadQuery, ezdxf)."""
from __future__ import annotations

from pathlib import Path

from ..model.specs import BackboneSpec
from . import Part, location

# STL tessellation: 0.01 mm chordal deviation keeps eyelet sections true to well under the
# 0.02 mm the checks need; 0.2 rad angular keeps a Ø1 mm eyelet at ~32 facets and a disk
# file under 1 MB.
STL_TOLERANCE_MM = 0.01
STL_ANGULAR_RAD = 0.2


def write_step(solid, path: Path) -> None:
    import cadquery as cq
    cq.exporters.export(cq.Workplane().add(solid), str(path), exportType="STEP")


def write_stl(solid, path: Path) -> None:
    solid.exportStl(str(path), tolerance=STL_TOLERANCE_MM, angularTolerance=STL_ANGULAR_RAD, ascii=False,
                    relative=False)


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
    for x, y, dia, tendons in spec.merged_holes():
        msp.add_circle((x, y), dia / 2, dxfattribs={"layer": "HOLES"})
        st = by_station[(round(x, 6), round(y, 6))]
        where = f"i={st:g}" if float(st).is_integer() else f"i={st:.2f}"
        msp.add_text(f"{where} {'+'.join(tendons)} Ø{dia:.2f}", height=1.5, dxfattribs={"layer": "LABELS"}
                     ).set_placement((x + dia / 2 + 1, y + 1), align=TextEntityAlignment.BOTTOM_LEFT)
    doc.saveas(path)
