"""A design file as written: its bytes, the bases it builds on, and which file wrote each value.

A design file may build on another: ``base: prototype.yaml`` (a path relative to the file, or
absolute) takes that design and merges this file over it. Mappings merge key by key, to any
depth; anything else (a number, a name, a list such as ``tendons`` or a routing table) replaces
the base's value whole; ``null`` removes the base's value, so hwgen derives it as if it had never
been given. A base may have a base of its own (a chain, at most :data:`MAX_CHAIN` files); a file
met twice on the way is a cycle, and bad input.

Settings that lower a check's severity (:data:`NOT_INHERITED`) are the judgement of one robot,
stated beside its reason in its own file: a design does not take them from its base. A new
robot's verdict then never hides a failing check behind what was decided for another; the file
that means it writes the setting again.

A sweep file's ``base`` is read the same way (:func:`read_layers`), so a sweep can start from a
design that itself builds on the prototype. Every value of the merged document keeps the file it
came from (:class:`Layers`), so a bad value is reported in the file that wrote it.

Reading a file is bounded (:mod:`hwgen.yamlfile`); keys that moved to another section are moved
(:data:`MOVED_KEYS`), with a warning, before the file is merged.
"""
from __future__ import annotations

import copy
import errno
import hashlib
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from . import yamlfile
from .errors import InputError, clip

BASE_KEY = "base"
MAX_CHAIN = 16                  # files in one chain of bases: far more than a lab keeps
# (section, key): a setting that lowers a failing check's severity, for one robot and its reason
NOT_INHERITED = (("check", "robust_severity"), ("check", "overstress"), ("check", "shared_sliding"))
# Keys that moved: (old section, key) -> (new section, key). Read from the old place for one release.
MOVED_KEYS = {("render", "tie_off_mm"): ("bom", "tie_off_mm"), ("render", "spool_mm"): ("bom", "spool_mm"),
              ("tensioner", "backlash"): ("tensioner", "center_offset")}
PATH_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")


# ---------------------------------------------------------------- field paths

def parse_path(text: str) -> list[str | int]:
    """``tendons[1].routing.k`` -> ['tendons', 1, 'routing', 'k']; ValueError when malformed."""
    from .errors import echo
    out: list[str | int] = []
    for part in text.split("."):
        m = PATH_TOKEN.fullmatch(part)
        if not m:
            raise ValueError(f"{echo(text)} is not a parameter path (names joined by '.', list items as [i])")
        out.append(m.group(1))
        out += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return out


def keys_of(path: str) -> tuple:
    """A dotted field path as a tuple of keys (a path that does not parse: the whole text, one key)."""
    try:
        return tuple(parse_path(path))
    except ValueError:
        return (path,)


def dotted(keys) -> str:
    """('tendons', 2, 'routing') -> ``tendons[2].routing``."""
    out = ""
    for k in keys:
        out = yamlfile.join(out, k)
    return out


def value_at(doc, keys):
    """The value at ``keys`` in a document; KeyError when it is not there."""
    node = doc
    for k in keys:
        if isinstance(k, int) and isinstance(node, list) and 0 <= k < len(node):
            node = node[k]
        elif isinstance(k, str) and isinstance(node, dict) and k in node:
            node = node[k]
        else:
            raise KeyError(k)
    return node


# ---------------------------------------------------------------- one file

def read_bytes(path: Path, kind: str = "design") -> bytes:
    """The file's bytes, at most :data:`hwgen.yamlfile.MAX_BYTES` of them (a device such as
    /dev/zero, or a 50 MB file, is refused after reading that much, not read to the end).
    ``kind``: what the file is, for the message on one too large."""
    try:
        with open(path, "rb") as f:
            raw = f.read(yamlfile.MAX_BYTES + 1)
    except OSError as e:
        raise InputError(path, "", f"cannot read the file ({_os_reason(e)})") from None
    if len(raw) > yamlfile.MAX_BYTES:
        raise InputError(path, "", f"larger than {yamlfile.MAX_BYTES >> 20} MiB; a {kind} file is a few kB")
    return raw


def _os_reason(e: OSError) -> str:
    """Why the system would not open a file, in words (a symbolic link loop said as one)."""
    if e.errno == errno.ELOOP:
        return "a symbolic link that leads back to itself: a loop"
    if e.errno == errno.EISDIR:
        return "a folder, not a file"
    return e.strerror or str(e)


def _not_a_file(p: Path) -> str | None:
    """Why ``p`` is no file a design can be read from (None: it is one)."""
    try:
        mode = p.stat().st_mode
    except ValueError:                          # a NUL, or a lone surrogate, in the name
        return "not a name a file can have"
    except OSError as e:
        if e.errno == errno.ENOENT:
            return "a symbolic link to nothing" if p.is_symlink() else "no such file"
        return _os_reason(e)
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    if not os.access(p, os.R_OK):
        return "cannot be read (no permission)"
    return None


def document(raw: bytes, path: str | Path) -> tuple[dict, list[str]]:
    """A design file's bytes as its mapping of sections (deprecated keys moved to their new place),
    and the warnings about those keys; raise :class:`InputError` when it is no such mapping."""
    path = Path(path)
    try:
        data = yamlfile.load(raw.decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(path, "", "not UTF-8 text") from None
    except yamlfile.YamlFault as e:
        raise InputError(path, e.path, e.message) from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(e, "problem", None) or str(e)
        context = getattr(e, "context", None)
        problem += f" ({context})" if context else ""
        raise InputError(path, "", f"YAML syntax: {where}{clip(problem, 160)}") from None
    except ValueError as e:      # a scalar Python cannot convert (a date such as 2024-02-30)
        raise InputError(path, "", f"a value YAML cannot read: {clip(str(e), 80)}") from None
    if not isinstance(data, dict):
        raise InputError(path, "", "the document must be a mapping of sections (design, backbone, disks, ...)")
    return data, _move_deprecated(data, path)


def _move_deprecated(data: dict, path: Path) -> list[str]:
    """Move keys from their old section to their new one; a warning for each, an error if given twice."""
    warnings = []
    for (old, key), (new, new_key) in MOVED_KEYS.items():
        section = data.get(old)
        if not isinstance(section, dict) or key not in section:
            continue
        target = data.setdefault(new, {})
        if not isinstance(target, dict):
            continue          # the schema reports the malformed section
        if new_key in target:
            raise InputError(path, f"{old}.{key}", f"given here and as {new}.{new_key}; keep only {new}.{new_key}")
        target[new_key] = section.pop(key)
        warnings.append(f"{path}: {old}.{key} is deprecated, write it as {new}.{new_key} "
                        f"(read from {old}.{key}: for this release only)")
    return warnings


def base_file(file: Path, value, key: str = BASE_KEY) -> Path:
    """Where ``base: value`` written in ``file`` points: relative to the file's folder, or absolute;
    raise :class:`InputError` (naming ``file``, ``key``, and the path it was looked for at) when
    it is no readable file."""
    if not isinstance(value, str) or not value.strip():
        raise InputError(file, key, "the path of a design file (relative to this file), e.g. base: prototype.yaml")
    p = Path(value)
    p = p if p.is_absolute() else Path(file).parent / p
    why = _not_a_file(p)
    if why:
        raise InputError(file, key, f"{clip(value, 120)}: {why} (looked for at {clip(os.path.abspath(p), 200)})")
    return p


# ---------------------------------------------------------------- a chain of files

@dataclass
class Layers:
    """A design document merged from a file and its chain of bases, and where each value came from.

    ``files[0]`` is the file itself, ``files[1]`` its base, and so on; ``origins`` maps the keys
    of every value a file wrote (and every key a ``null`` removed) to that file's index."""

    doc: dict
    files: tuple[Path, ...]
    raws: tuple[bytes, ...]
    origins: dict[tuple, int] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def sha256(self) -> str:
        """The file's own sha256 when it has no base; else the sha256 of its files' sha256s in
        chain order (an edit to any file of the chain makes another design)."""
        if len(self.raws) == 1:
            return hashlib.sha256(self.raws[0]).hexdigest()
        return hashlib.sha256(b"".join(hashlib.sha256(r).digest() for r in self.raws)).hexdigest()

    def origin(self, keys) -> int | None:
        """The index in ``files`` of the file that wrote the value at ``keys`` (or a mapping or list
        holding it); None when no file did (a default, or a value hwgen derives)."""
        keys = tuple(keys)
        if keys in self.origins:
            return self.origins[keys]
        try:
            value_at(self.doc, keys)
        except KeyError:
            return None
        for n in range(len(keys), 0, -1):
            if keys[:n] in self.origins:
                return self.origins[keys[:n]]
        return None

    def file_of(self, path: str) -> Path:
        """The file to name for a field: the one that wrote it, else the design's own file."""
        i = self.origin(keys_of(path))
        return self.files[i if i is not None else 0]


class Document(dict):
    """A merged design document in memory (a sweep's variant, a tune's trial, a tried fix) that
    remembers which of its keys its own file did not write: ``inherited``, the keys whose values a
    base wrote. Where hwgen derives a value the file leaves to it (the tensioner's gear,
    :mod:`hwgen.model.document`), a value from a base is left to it as well, as in a build of the file."""

    def __init__(self, doc: dict, inherited=frozenset()):
        super().__init__(doc)
        self.inherited: frozenset[tuple] = frozenset(inherited)

    def written(self, keys) -> "Document":
        """This document's ``inherited`` without ``keys`` and what lies below it: a value set there
        is now the document's own."""
        keys = tuple(keys)
        return Document(self, {k for k in self.inherited if k[:len(keys)] != keys})


def document_of(layers: Layers) -> Document:
    """The merged document of ``layers``, remembering the keys a base wrote (a copy: the layers' own
    document is left as it was)."""
    return Document(copy.deepcopy(layers.doc), {k for k, i in layers.origins.items() if i})


def single(doc: dict, file: str | Path) -> Layers:
    """A document read from one file (or made in memory, as a sweep's variant): every key its own,
    except, for a :class:`Document`, those a base wrote (no file of these layers wrote them)."""
    origins: dict[tuple, int | None] = {}
    _mark(doc, (), 0, origins)
    for keys in getattr(doc, "inherited", ()):
        origins[keys] = None
    return Layers(doc, (Path(file),), (b"",), origins)


def _mark(node, keys: tuple, index: int, origins: dict) -> None:
    if keys:
        origins[keys] = index
    if isinstance(node, dict):
        for k, v in node.items():
            _mark(v, (*keys, k), index, origins)


def merge(base: dict, over: dict, index: int, origins: dict, keys: tuple = ()) -> dict:
    """``over`` merged onto a copy of ``base`` (see the module's docstring); the keys ``over`` writes
    (or removes with ``null``) are marked as file ``index``'s in ``origins``."""
    out = dict(base)
    for k, v in over.items():
        here = (*keys, k)
        if v is None:
            out.pop(k, None)
            _unmark(here, origins)
            origins[here] = index
        elif isinstance(v, dict) and isinstance(out.get(k), dict):
            origins.setdefault(here, index)
            out[k] = merge(out[k], v, index, origins, here)
        else:
            _unmark(here, origins)
            out[k] = copy.deepcopy(v)
            _mark(v, here, index, origins)
    return out


def _unmark(keys: tuple, origins: dict) -> None:
    """Forget where the values at and below ``keys`` came from (they are replaced)."""
    n = len(keys)
    for k in [k for k in origins if k[:n] == keys]:
        del origins[k]


def read_layers(path: str | Path) -> Layers:
    """Read a design file and its chain of bases, merged; raise :class:`InputError` naming the file
    (and ``base`` for a base that is not there, or one that leads back to a file of the chain)."""
    files: list[Path] = []
    raws: list[bytes] = []
    docs: list[dict] = []
    warnings: list[str] = []
    seen: dict[Path, int] = {}
    here, named = Path(path), None
    while True:
        raw = read_bytes(here)
        real = _real(here)
        if real in seen:
            loop = " → ".join(str(f) for f in files[seen[real]:]) + f" → {here}"
            raise InputError(files[-1], BASE_KEY, f"{clip(str(named), 120)} leads back to a file of this chain of "
                                                  f"bases ({clip(loop, 200)}): a cycle")
        if len(files) >= MAX_CHAIN:
            raise InputError(files[0], BASE_KEY, f"more than {MAX_CHAIN} files in this chain of bases")
        seen[real] = len(files)
        doc, moved = document(raw, here)
        files.append(here)
        raws.append(raw)
        warnings += moved
        named = doc.pop(BASE_KEY, None)
        docs.append(doc)
        if named is None:
            break
        here = base_file(here, named)
    origins: dict[tuple, int] = {}
    merged: dict = {}
    for index in range(len(docs) - 1, -1, -1):        # the deepest base first, the file itself last
        merged = merge(merged, docs[index], index, origins)
    layers = Layers(merged, tuple(files), tuple(raws), origins, warnings)
    if len(files) > 1:
        _drop_lowered(layers)
    return layers


def _real(path: Path) -> Path:
    """The file's path with every symbolic link followed: the same file twice in a chain is a cycle."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):            # a link loop on the way (RuntimeError before Python 3.13)
        raise InputError(path, "", "a symbolic link that leads back to itself: a loop") from None


def _drop_lowered(layers: Layers) -> None:
    """Leave out the settings of :data:`NOT_INHERITED` that only a base wrote (saying so)."""
    for keys in NOT_INHERITED:
        i = layers.origin(keys)
        if not i:                                    # written by the file itself, or by none
            continue
        try:
            value = value_at(layers.doc, keys)
        except KeyError:
            continue
        del value_at(layers.doc, keys[:-1])[keys[-1]]
        _unmark(keys, layers.origins)
        layers.warnings.append(
            f"{layers.files[0]}: {dotted(keys)}: {value} is not taken from the base {layers.files[i]}: a setting "
            f"that lowers a failing check's severity holds for the robot whose file states it; write it in this "
            f"file, with its reason, if it holds for this robot too")


# ---------------------------------------------------------------- what a field usually holds

# (low, high): the range a field's value falls in for the robots hwgen is made for (a few cm to
# a metre or two long, printed on a desktop printer). A value outside it that a unit slip explains
# (metres or inches for millimetres, a decimal point off) is reported with the value meant; not an
# error: the design is read as written.
USUAL = {
    "backbone.length": (40.0, 1500.0, "mm"),
    "backbone.height": (4.0, 150.0, "mm"),
    "backbone.thickness": (0.1, 3.0, "mm"),
    "disks.spacing": (3.0, 150.0, "mm"),
    "disks.thickness": (0.8, 15.0, "mm"),
    "disks.end_thickness": (1.0, 30.0, "mm"),
    "disks.outer_diameter": (10.0, 300.0, "mm"),
    "tendon_material.diameter": (0.05, 2.0, "mm"),
    "tendon_material.break_load": (5.0, 3000.0, "N"),
    "process.min_wall": (0.2, 4.0, "mm"),
    "process.min_hole": (0.2, 4.0, "mm"),
}
# (factor the value is multiplied by to land in its range, what the slip would be); the first that fits
SLIPS_LOW = ((1000.0, "in metres"), (10.0, "a decimal point off"))
SLIPS_HIGH = ((0.1, "a decimal point off"), (0.001, "in µm"))
SLIP_MARGIN = 1.5               # the value meant lies this far inside the usual range, not on its edge


def hints(doc: dict) -> dict[str, str]:
    """Field path -> a word on a value far off its usual range (:data:`USUAL`) that a unit slip
    explains: ``0.25 mm is under the usual 40-1500 mm: in metres (250 mm)?``."""
    out = {}
    for path, (lo, hi, unit) in USUAL.items():
        try:
            v = value_at(doc, keys_of(path))
        except KeyError:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v < float("inf") or lo <= v <= hi:
            continue
        for f, what in SLIPS_LOW if v < lo else SLIPS_HIGH:
            if lo * SLIP_MARGIN <= v * f <= hi / SLIP_MARGIN:
                side = "under" if v < lo else "over"
                out[path] = f"{v:g} {unit} is {side} the usual {lo:g}-{hi:g} {unit}: {what} ({v * f:.4g} {unit})?"
                break
    return out


# ---------------------------------------------------------------- a design file with values changed

def rewritten(path: str | Path, values: dict[str, tuple[object, str]], name: str, head: str) -> str:
    """The text of the design file ``path`` with each dotted field of ``values`` set to its value and
    the comment beside it replaced by the one given ({field: (value, comment)}), every other
    comment, order and quoting kept (ruamel.yaml's round trip); its ``design`` renamed ``name``; a
    ``base`` made absolute (the text is written elsewhere); ``head`` put first as comment lines.
    A section the file leaves to its base is written with only the changed keys (it merges)."""
    import io

    from ruamel.yaml import YAML
    from ruamel.yaml.comments import CommentedMap
    y = YAML()
    y.preserve_quotes = True
    # null as the file wrote it (``spacing: null``), not as an empty value
    y.representer.add_representer(type(None), lambda r, _: r.represent_scalar("tag:yaml.org,2002:null", "null"))
    y.width = 4096
    y.indent(mapping=2, sequence=4, offset=2)          # hwgen's files: list items two in, their keys four
    path = Path(path)
    doc = y.load(path.read_text())
    if BASE_KEY in doc:
        doc[BASE_KEY] = str(base_file(path, doc[BASE_KEY]).resolve())
    for dotted_path, (value, comment) in values.items():
        keys = parse_path(dotted_path)
        node = doc
        for k in keys[:-1]:
            if not isinstance(k, int) and node.get(k) is None:
                node[k] = CommentedMap()                # a section the file leaves to its base: its comments too
            node = node[k]                              # a list's item: the file writes the list
        new = isinstance(node, CommentedMap) and keys[-1] not in node
        before = _blank_after(node, list(node)[-1]) if new and len(node) else None
        node[keys[-1]] = value
        if hasattr(node, "yaml_add_eol_comment"):
            blank = ""
            if keys[-1] in node.ca.items:
                blank = _take_blank(node.ca.items[keys[-1]])
                del node.ca.items[keys[-1]]
            elif before is not None:
                blank = _take_blank(before)            # the blank line after the section's last key: after this one
            node.yaml_add_eol_comment(comment, keys[-1])
            if blank and node.ca.items[keys[-1]][2] is not None:
                node.ca.items[keys[-1]][2].value += "\n" + blank     # its line ends here, then the blank
    doc["design"] = name
    buf = io.StringIO()
    y.dump(doc, buf)
    return "".join(f"# {line}\n" for line in head.splitlines()) + buf.getvalue()


def _blank_after(node, key):
    """The comment slot (ruamel.yaml's) that holds the blank lines after ``key``'s entry: its own
    line's, or that of the last key of the mapping it holds (the deepest); None without one."""
    from ruamel.yaml.comments import CommentedMap
    while isinstance(node.get(key), CommentedMap) and len(node[key]):
        node, key = node[key], list(node[key])[-1]
    slot = node.ca.items.get(key)
    return slot if slot and len(slot) > 2 and slot[2] is not None else None


def _take_blank(slot) -> str:
    """The blank lines at the end of a comment slot, taken off it (kept once the entry is rewritten)."""
    tok = slot[2] if slot and len(slot) > 2 else None
    if tok is None or not isinstance(tok.value, str):
        return ""
    text = tok.value.rstrip("\n")
    blank = tok.value[len(text) + 1:]
    if blank:
        tok.value = text + "\n"
    return blank
