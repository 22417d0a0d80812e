"""Files: STEP, STL, the assembly STEP and the backbone's DXF template (CadQuery, ezdxf).

Every file is byte for byte the same when the same design is built again, in this process or
another, so CI can diff outputs and a cache can trust their sha256:

* STEP: OCCT stamps FILE_NAME with the time and names a part's product
  "Open CASCADE STEP translator 7.9 <n>", n counting the exports of the process. The header
  is set through ``APIHeaderSection_MakeHeader`` on the writer's model after the transfer
  (time stamp :func:`timestamp`, the part's name), and the product is named after the part.
* assembly STEP: a product shared by several instances gets a blank id and name, so FreeCAD shows each
  instance under its own name (:func:`_blank_shared_products`). Besides the header, the id of each part's occurrence counts on through the
  process (renumbered 1, 2, ... in file order), and OCCT writes the colour styles in the order of a hash
  map keyed by shape addresses, which differ from run to run; :func:`canonical_styles`
  renumbers that trailing block in an order fixed by its content.
* DXF: ezdxf's fixed-metadata mode (creation and update dates, GUIDs, its own marker) and the
  CLASSES section in sorted order (ezdxf adds the classes in use from a set, whose order
  follows Python's per-process string hashing).
* STL: OCCT's binary STL is already deterministic (a fixed header, the mesh as computed).
* STEP, both kinds: a zero is written without its sign (OCCT writes ``-0.`` where a direction
  was computed rather than given; the same solid read back from its BREP, as the part cache
  does, writes ``0.`` there), so a part's STEP has the same bytes from a fresh solid and from
  a cached one (:func:`unsigned_zeros`).
"""
from __future__ import annotations

import hashlib
import os
import re
import time
from contextlib import contextmanager
from pathlib import Path

from ..model.specs import BackboneSpec
from . import Part, location

# STL tessellation: 0.01 mm chordal deviation keeps eyelet sections true to well under the
# 0.02 mm the checks need; 0.2 rad angular keeps a Ø1 mm eyelet at ~32 facets and a disk
# file under 1 MB.
STL_TOLERANCE_MM = 0.01
STL_ANGULAR_RAD = 0.2
STEP_AUTHOR = "hwgen"


def settings() -> dict:
    """Everything besides the solid that decides the bytes of a part's files (the part cache keys
    them with it)."""
    return {"stl_tolerance_mm": STL_TOLERANCE_MM, "stl_angular_rad": STL_ANGULAR_RAD, "step_author": STEP_AUTHOR,
            "step_time": timestamp(), "step_zeros": "unsigned"}


def timestamp() -> str:
    """The time written into STEP headers: ``SOURCE_DATE_EPOCH`` (the reproducible-builds
    convention) when set, else the epoch: a file says nothing about when it was made."""
    try:
        t = int(os.environ.get("SOURCE_DATE_EPOCH", "0"))
    except ValueError:
        t = 0
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(max(t, 0)))


def _set_header(model, name: str) -> None:
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.TCollection import TCollection_HAsciiString
    header = APIHeaderSection_MakeHeader(model)
    header.SetName(TCollection_HAsciiString(name))
    header.SetTimeStamp(TCollection_HAsciiString(timestamp()))
    header.SetAuthorValue(1, TCollection_HAsciiString(STEP_AUTHOR))
    header.SetOrganizationValue(1, TCollection_HAsciiString(STEP_AUTHOR))


def _step_settings() -> None:
    """CadQuery's STEP defaults: pcurves written, default precision, millimetres."""
    from OCP.Interface import Interface_Static
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
    Interface_Static.SetIVal_s("write.precision.mode", 0)
    Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
    Interface_Static.SetCVal_s("write.step.unit", "MM")


def _written(ok: bool, path: Path, what: str) -> None:
    if not ok or not path.exists() or path.stat().st_size == 0:
        raise RuntimeError(f"the {what} writer reported a failure")


def write_step(solid, path: Path, name: str | None = None) -> None:
    """One solid as a STEP file whose product and header are named ``name`` (default: the file's stem)."""
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.StepBasic import StepBasic_Product
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TCollection import TCollection_HAsciiString

    name = name or Path(path).stem
    _step_settings()
    writer = STEPControl_Writer()
    writer.Transfer(solid.wrapped, STEPControl_AsIs)
    model = writer.Model()
    for entity in _entities_of(model, StepBasic_Product):
        entity.SetId(TCollection_HAsciiString(name))
        entity.SetName(TCollection_HAsciiString(name))
    _set_header(model, name)
    path = Path(path)
    _written(writer.Write(str(path)) == IFSelect_ReturnStatus.IFSelect_RetDone, path, "STEP")
    path.write_bytes(unsigned_zeros(path.read_bytes()))


# "-0." between ( or , and , or ): the pattern starts with its literal "-", so the search skips
# ahead to each "-" (twenty times faster on a 15 MB assembly than a pattern opening on the look-behind)
_SIGNED_ZERO = re.compile(rb"-(?<=[(,]-)0\.(?=[,)])")


def unsigned_zeros(data: bytes) -> bytes:
    """STEP text with every ``-0.`` written as ``0.`` (see the module)."""
    return _SIGNED_ZERO.sub(b"0.", data)


def write_brep(solid) -> bytes:
    """The solid in OCCT's binary BREP, exact: what the part cache keeps to put an assembly
    together without building the part again."""
    import io

    from OCP.BinTools import BinTools
    buf = io.BytesIO()
    BinTools.Write_s(solid.wrapped, buf)
    return buf.getvalue()


def read_brep(data: bytes):
    """A solid from :func:`write_brep`'s bytes."""
    import io

    import cadquery as cq
    from OCP.BinTools import BinTools
    from OCP.TopoDS import TopoDS_Shape
    shape = TopoDS_Shape()
    BinTools.Read_s(shape, io.BytesIO(data))
    return cq.Solid(shape)


def write_stl(solid, path: Path) -> None:
    ok = solid.exportStl(str(path), tolerance=STL_TOLERANCE_MM, angularTolerance=STL_ANGULAR_RAD, ascii=False,
                         relative=False)
    _written(ok is not False, Path(path), "STL")


def write_assembly(parts: list[Part], name: str, path: Path) -> None:
    """Every part placed, named and coloured, as one STEP assembly (CadQuery's XCAF document)."""
    import cadquery as cq
    from cadquery.occ_impl.assembly import toCAF
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_StepModelType
    from OCP.XSControl import XSControl_WorkSession

    assy = cq.Assembly(name=name)
    for p in parts:
        assy.add(p.solid, name=p.name, loc=location(p.placement), color=cq.Color(*p.color))
    _, doc = toCAF(assy, True)
    _step_settings()
    writer = STEPCAFControl_Writer(XSControl_WorkSession(), False)
    writer.SetColorMode(True)
    writer.SetLayerMode(True)
    writer.SetNameMode(True)
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    model = writer.ChangeWriter().Model()
    occurrences = _occurrences(model)
    _number_occurrences(occurrences)
    _blank_shared_products(occurrences)
    _set_header(model, name)
    path = Path(path)
    _written(writer.Write(str(path)) == IFSelect_ReturnStatus.IFSelect_RetDone, path, "assembly STEP")
    path.write_bytes(canonical_styles(unsigned_zeros(path.read_bytes())))


def _entities_of(model, kind) -> list:
    """The STEP model's entities of an OCCT type (and its subtypes), in file order, picked out by
    OCCT (a pass in Python that wrapped every entity cost several times more)."""
    found = model.Entities()
    found.SelectType(kind.get_type_descriptor_s(), True)
    out = []
    while found.More():
        out.append(found.Value())
        found.Next()
    return out


def _occurrences(model) -> list:
    """Each part's placement in the assembly (NEXT_ASSEMBLY_USAGE_OCCURRENCE), in file order."""
    from OCP.StepRepr import StepRepr_NextAssemblyUsageOccurrence
    return _entities_of(model, StepRepr_NextAssemblyUsageOccurrence)


def _number_occurrences(occurrences: list) -> None:
    """Each part's placement in the assembly gets the id 1, 2, ... in file order; OCCT numbers
    them with a counter that runs on through the process."""
    from OCP.TCollection import TCollection_HAsciiString
    for k, entity in enumerate(occurrences, 1):
        entity.SetId(TCollection_HAsciiString(str(k)))


SHARED_PRODUCT_NAME = " "    # a blank id and name (OCCT replaces an empty one with its translator's banner)


def _blank_shared_products(occurrences: list) -> None:
    """A product that several placements share (identical parts: one definition, several
    instances) gets a blank id and name. FreeCAD names each instance after its product (its
    name, else its id) and falls back to the instance's own name (the part's) only when both are
    blank, so every instance then shows its own name; the geometry stays shared."""
    from OCP.TCollection import TCollection_HAsciiString
    products: list = []      # distinct products, in file order (OCP hands back one wrapper per entity)
    uses: list[int] = []
    for entity in occurrences:
        product = entity.RelatedProductDefinition().Formation().OfProduct()
        k = next((j for j, p in enumerate(products) if p is product), None)
        if k is None:
            products.append(product)
            uses.append(0)
            k = len(products) - 1
        uses[k] += 1
    for product, n in zip(products, uses):
        if n > 1:
            product.SetId(TCollection_HAsciiString(SHARED_PRODUCT_NAME))
            product.SetName(TCollection_HAsciiString(SHARED_PRODUCT_NAME))


# ---------------------------------------------------------------- STEP style block

_ENTITY = re.compile(rb"^#(\d+)\s*=\s*(.*?);[ \t]*\r?$", re.M | re.S)
_REF = re.compile(rb"#(\d+)")
STYLE_ROOT = b"MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION("


def _one_line(body: bytes) -> bytes:
    """An entity's text with OCCT's line breaks (which depend on number widths) taken out;
    names and strings in this block hold no line breaks."""
    return re.sub(rb"\r?\n\s*", b"", body)


_ENTITY_HEAD = re.compile(rb"#\d+\s*=\s*")


def _entity_opening(data: bytes, head: bytes, start: int, end: int) -> int | None:
    """Where the first line between ``start`` and ``end`` that opens an entity with ``head``
    (``#n = HEAD``) begins: the text is searched for ``head`` itself (fast), and each find's line
    start tried."""
    at = data.find(head, start, end)
    while at >= 0:
        line = data.rfind(b"\n", 0, at) + 1
        if line >= start and _ENTITY_HEAD.fullmatch(data, line, at):
            return line
        at = data.find(head, at + 1, end)
    return None


def canonical_styles(data: bytes) -> bytes:
    """The STEP file with its trailing colour-style block in an order fixed by content.

    The block runs from the first ``MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION``
    to the end of DATA; nothing before it refers into it. Each entity gets a hash of its text
    with references into the block replaced by their hashes; the block's roots are taken in
    hash order, each walked depth first, and the entities renumbered in the order met. The
    file is returned unchanged if it does not have that shape.
    """
    start = data.find(b"\nDATA;")
    end = data.rfind(b"\nENDSEC;")
    cut = _entity_opening(data, STYLE_ROOT, max(start, 0), max(end, 0))
    if start < 0 or end < start or cut is None:
        return data
    entities = [(int(m.group(1)), m.group(2), m.start(), m.end()) for m in _ENTITY.finditer(data, cut, end)]
    block = {num: body for num, body, _, _ in entities}
    if not block:
        return data
    lowest = min(block)
    if max(map(int, _REF.findall(data, start, cut)), default=-1) >= lowest:   # something before refers into it
        return data
    refs = {num: [int(r) for r in _REF.findall(body) if int(r) in block] for num, body in block.items()}
    digest: dict[int, bytes] = {}

    def hash_of(num: int, seen: frozenset = frozenset()) -> bytes:
        if num not in digest:
            if num in seen:
                raise ValueError("cyclic style block")
            text = _REF.sub(lambda m: b"@" + hash_of(int(m.group(1)), seen | {num}) if int(m.group(1)) in block
                            else m.group(0), _one_line(block[num]))
            digest[num] = hashlib.sha256(text).hexdigest().encode()
        return digest[num]

    try:
        for num in block:
            hash_of(num)
    except (ValueError, RecursionError):
        return data
    referenced = {r for rs in refs.values() for r in rs}
    order: list[int] = []
    placed: set[int] = set()
    for root in sorted((n for n in block if n not in referenced), key=lambda n: digest[n]):
        stack = [root]
        while stack:
            n = stack.pop()
            if n in placed:
                continue
            placed.add(n)
            order.append(n)
            stack.extend(reversed(refs[n]))
    order += sorted((n for n in block if n not in placed), key=lambda n: digest[n])
    new = {old: lowest + k for k, old in enumerate(order)}
    lines = [b"#%d = %s;" % (new[old], _REF.sub(lambda m: b"#%d" % new.get(int(m.group(1)), int(m.group(1))),
                                                  _one_line(block[old]))) for old in order]
    return data[:cut] + b"\n".join(lines) + data[entities[-1][3]:]


# ---------------------------------------------------------------- DXF

@contextmanager
def _fixed_dxf_metadata():
    import ezdxf
    before = ezdxf.options.write_fixed_meta_data_for_testing
    ezdxf.options.write_fixed_meta_data_for_testing = True
    try:
        yield
    finally:
        ezdxf.options.write_fixed_meta_data_for_testing = before


def write_backbone_dxf(spec: BackboneSpec, stations, path: Path) -> None:
    """1:1 cut-and-drill template: outline, holes labelled by station and tendon, disk lines."""
    import ezdxf
    from ezdxf.enums import TextEntityAlignment

    with _fixed_dxf_metadata():
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
        for dxftype in sorted(doc.entitydb.dxf_types_in_use()):   # fixed CLASSES order (see the module)
            doc.classes.add_class(dxftype)
        set_extents(doc)
        doc.saveas(path)


EXTENT_TYPES = "LINE LWPOLYLINE CIRCLE"   # the drawing's geometry; text is left out (its width depends on the font)


def set_extents(doc):
    """$EXTMIN/$EXTMAX from the geometry (ezdxf's bounding boxes of the lines, the outline and the
    holes), in the header and in the modelspace (ezdxf copies the modelspace's over the header's on
    saving), so a viewer's zoom-to-extents shows the strip. Labels are left out: their width comes
    from whatever font the machine has, and the file must have the same bytes on every machine."""
    from ezdxf import bbox
    msp = doc.modelspace()
    box = bbox.extents(msp.query(EXTENT_TYPES))
    if box.has_data:
        msp.dxf.extmin, msp.dxf.extmax = box.extmin, box.extmax
        doc.header["$EXTMIN"], doc.header["$EXTMAX"] = box.extmin, box.extmax
    return box
