"""The parameter reference, written from the schema each time the site is built (a MkDocs hook).

Every field of ``hwgen schema`` gets a row: its path in the YAML, type, unit, default, bounds and
description. The unit is the one the field's description ends with (", mm", ", N", ", deg"), as the
schema writes it; a field without one is a count, a word or a ratio. Nothing here is typed by
hand, so the page cannot drift from the code: `tests/test_docs.py` checks that it names every
field the schema has.
"""
from __future__ import annotations

import json
import re

PAGE = "reference/parameters.md"
UNITS = {"mm": "mm", "deg": "°", "n": "N", "g/cm³": "g/cm³", "gpa": "GPa", "mpa": "MPa", "mm/n": "mm/N",
         "n/mm": "N/mm", "px": "px", "g": "g", "%": "%", "n·mm": "N·mm", "s": "s", "mm³": "mm³"}
# a field's name that ends in its unit (``spool_mm``, ``pretension_n``) says it when its description does not
NAME_UNITS = {"_mm": "mm", "_deg": "°", "_n": "N", "_px": "px", "_mm3": "mm³", "_gpa": "GPa", "_mpa": "MPa",
              "_g_cm3": "g/cm³", "_mm_per_n": "mm/N", "_n_per_mm": "N/mm"}
# ", mm" at the end of a description, or before its closing note in brackets
_UNIT = re.compile(r",\s*(mm/N|N/mm|N·mm|mm³|mm|deg|N|g/cm³|GPa|MPa|px|g|s|%)(?=\s*(\(|$|,|;))", re.IGNORECASE)


def _resolve(schema: dict, node: dict) -> dict:
    while "$ref" in node:
        extra = {k: v for k, v in node.items() if k != "$ref"}
        node = {**schema["$defs"][node["$ref"].rsplit("/", 1)[1]], **extra}
    return node


def _options(node: dict) -> list[dict]:
    """The alternatives of an ``anyOf`` without the ``null`` one (a value hwgen derives when left out)."""
    return [o for o in node.get("anyOf", [node]) if o.get("type") != "null"]


def _nullable(node: dict) -> bool:
    return any(o.get("type") == "null" for o in node.get("anyOf", []))


def _type(schema: dict, node: dict) -> str:
    words = []
    for o in _options(node):
        o = _resolve(schema, o)
        if "enum" in o:
            words.append(" or ".join(f"`{v}`" for v in o["enum"]))
        elif "const" in o:
            words.append(f"`{o['const']}`")
        elif o.get("type") == "array":
            if "prefixItems" in o:
                words.append(f"list of {len(o['prefixItems'])} numbers")
            else:
                items = _resolve(schema, o.get("items", {}))
                inner = ("section" if items.get("type") == "object" or "properties" in items
                         else _type(schema, items))
                words.append(f"list of {inner}")
        elif isinstance(o.get("additionalProperties"), dict):
            words.append(f"mapping of name to {_type(schema, o['additionalProperties'])}")
        elif o.get("type") == "object" or "properties" in o:
            words.append("section")
        else:
            words.append({"number": "number", "integer": "integer", "string": "text",
                          "boolean": "true/false"}.get(o.get("type", ""), o.get("type", "any")))
    return " or ".join(dict.fromkeys(words)) or "any"


def _bounds(schema: dict, node: dict) -> str:
    parts = []
    for o in _options(node):
        o = _resolve(schema, o)
        if o.get("type") == "array" and "prefixItems" in o:
            o = o["prefixItems"][0]
        if o.get("type") == "array":
            if "minItems" in o or "maxItems" in o:
                parts.append(f"{o.get('minItems', 0)}–{o.get('maxItems', '∞')} items")
            continue
        lo = ("> " + _num(o["exclusiveMinimum"])) if "exclusiveMinimum" in o else (
            "≥ " + _num(o["minimum"]) if "minimum" in o else "")
        hi = ("< " + _num(o["exclusiveMaximum"])) if "exclusiveMaximum" in o else (
            "≤ " + _num(o["maximum"]) if "maximum" in o else "")
        if "minLength" in o or "maxLength" in o:
            parts.append(f"{o.get('minLength', 0)}–{o.get('maxLength', '∞')} characters")
        elif lo or hi:
            parts.append(", ".join(p for p in (lo, hi) if p))
    return "; ".join(dict.fromkeys(parts))


def _num(v) -> str:
    return f"{v:g}" if isinstance(v, float) else str(v)


def _default(node: dict, required: bool) -> str:
    if required:
        return "required"
    if "default" not in node:
        return "—"
    v = node["default"]
    if v is None:
        return "derived" if _nullable(node) else "—"
    return f"`{json.dumps(v, ensure_ascii=False)}`"


def _unit(name: str, description: str) -> tuple[str, str]:
    """(unit, description without it) from a description that says ', mm' at its end or before a note
    (', mm (note)', ', mm, increasing'), else from the field's name (``tie_off_mm``)."""
    m = _UNIT.search(description)
    if m is None:
        ends = [u for suffix, u in NAME_UNITS.items() if name.endswith(suffix)]
        return (max(ends, key=len) if ends else ""), description
    return UNITS[m.group(1).lower()], (description[:m.start()] + description[m.end():]).strip()


def _cell(text: str, prose: bool = False) -> str:
    """One table cell: on one line, its bars escaped; in prose (a description, not a code span)
    ``<name>`` is shown as written, not read as HTML."""
    if prose:
        text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    return " ".join(text.replace("|", "\\|").split())


def fields(schema: dict) -> list[dict]:
    """Every field of the schema, depth first in the schema's order: path, type, unit, default, bounds,
    description. A list of sections (``tendons``) gives its items' fields under ``tendons[]``."""
    rows: list[dict] = []

    def walk(node: dict, prefix: str) -> None:
        node = _resolve(schema, node)
        required = set(node.get("required", []))
        for name, sub in node.get("properties", {}).items():
            path = f"{prefix}{name}"
            unit, description = _unit(name, sub.get("description") or _resolve(schema, sub).get("description", ""))
            rows.append({"path": path, "type": _type(schema, sub), "unit": unit,
                         "default": _default(sub, name in required), "bounds": _bounds(schema, sub),
                         "description": description.split("\n\n")[0]})
            for o in _options(sub):
                o = _resolve(schema, o)
                if "properties" in o:
                    walk(o, path + ".")
                elif o.get("type") == "array" and "properties" in _resolve(schema, o.get("items", {})):
                    walk(o["items"], path + "[].")

    walk(schema, "")
    return rows


def anchor(path: str) -> str:
    """The id of a field's row on the page: its path without the list brackets
    (``tendons[].routing.function.k`` → ``tendons.routing.function.k``)."""
    return path.replace("[]", "")


def _row(r: dict, with_id: bool = True) -> str:
    mark = f'<span id="{anchor(r["path"])}"></span>' if with_id else ""
    return (f"| {mark}`{r['path']}` | {_cell(r['type'])} | {r['unit']} | {_cell(r['default'])} | {_cell(r['bounds'])} "
            f"| {_cell(r['description'], prose=True)} |")


HEAD = ["| field | type | unit | default | bounds | what it is |", "|---|---|---|---|---|---|"]


def page(schema: dict) -> str:
    """The reference page: the fields at the top of the file (``design``, ``base``) in one table, then
    a heading and a table per section, in the schema's order. Every row carries its field's path as
    an anchor (:func:`anchor`), so other pages link straight to it."""
    rows = fields(schema)
    out = ["# The parameter file, field by field", "",
           "Generated from `hwgen schema` each time this site is built: every field of a design YAML, "
           "with its type, unit, default and bounds. A default of *derived* means hwgen works the value "
           "out from the robot at hand when the field is left out (or set to `null` over a base design); "
           "*required* means a design must give it, itself or through its `base:`. What each section is "
           "for is on [the parameter file](../parameters.md); how to write your own robot on "
           "[your own robot](../your-robot.md). From the command line, `hwgen schema` prints the same as "
           "JSON Schema, for an editor's completion and validation.", ""]
    top = [r for r in rows if "." not in r["path"] and "[" not in r["path"]]
    scalars = [r for r in top if r["type"] != "section" and not r["type"].startswith("list of section")]
    out += ["## The file itself", "", "The fields at the top of a design file, beside its sections.", "", *HEAD]
    out += [_row(r) for r in scalars]
    out.append("")
    for section in (r for r in top if r not in scalars):
        out += [f"## `{section['path']}`", ""]
        if section["description"]:
            out += [_cell(section["description"], prose=True), ""]
        mine = [r for r in rows if r["path"].startswith(section["path"] + ".")
                or r["path"].startswith(section["path"] + "[]")]
        if section["type"] != "section":          # a list of sections: its own row (its bounds), no anchor
            mine.insert(0, section)               # beside the heading's
        out += HEAD + [_row(r, with_id=r is not section) for r in mine] + [""]
    return "\n".join(out)


def paths(schema: dict) -> set[str]:
    """Every field's path, as the pages write it (``tendons[].pretension_n``)."""
    return {r["path"] for r in fields(schema)}


def on_files(files, config):
    """MkDocs hook: add the generated page to the site's files."""
    from mkdocs.structure.files import File

    from hwgen.params import json_schema
    files.append(File.generated(config, PAGE, content=page(json_schema())))
    return files
