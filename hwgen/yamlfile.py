"""Reading a YAML file with limits: a design file is small, shallow and plain.

PyYAML's safe loader builds Python objects only of the plain YAML types, but it has no limit
on how deep the document nests (its composer recurses until Python's stack runs out), on how
far aliases expand (nine aliases of nine aliases of ... make a billion values out of a few
hundred bytes, and every later stage that walks them hangs), or on how long a scalar is (a
5 001-digit integer stops Python's int()). :func:`load` composes the document under a depth
limit, then walks its node graph once, with each aliased node counted as often as it is used,
before any value is built; every fault comes back as a :class:`YamlFault` with the field path
where it was found.

The text is scanned and parsed by libyaml where PyYAML has it (PyYAML's own scanner, in Python, was
most of the time a design took to read, which the CAD-free tests do hundreds of times); the composer
over its events is PyYAML's, with the depth limit. A document libyaml refuses is read again by
PyYAML's own parser: the error the user is shown is always PyYAML's (its wording, the line quoted),
whichever parser ran. tests/test_fuzz.py holds the two parsers to the same values and errors.
"""
from __future__ import annotations

from dataclasses import dataclass

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.resolver import Resolver

try:
    from yaml._yaml import CParser
except ImportError:                  # PyYAML built without libyaml: its own parser reads every file
    CParser = None

MAX_BYTES = 1 << 20          # 1 MiB; the prototype is 8 kB, 200 stations of 60 tabled tendons about 500 kB
MAX_DEPTH = 32               # nesting levels; the deepest a design needs is 6 (tendons[i].routing.table[j][k])
MAX_VALUES = 200_000         # scalars, lists and mappings after aliases are expanded
MAX_SCALAR_CHARS = 1_000     # the longest single value (a name, a number)
MERGE_TAG = "tag:yaml.org,2002:merge"


@dataclass
class YamlFault(Exception):
    """What is wrong (``message``) and where: the field path, and the line when known."""

    path: str
    message: str

    def __str__(self) -> str:
        return f"{self.path or '<document>'}: {self.message}"


def join(path: str, key) -> str:
    """``tendons`` + 2 -> ``tendons[2]``; ``tendons[2]`` + ``routing`` -> ``tendons[2].routing``."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


class _Depth:
    """The composer's depth limit: documents nested deeper than :data:`MAX_DEPTH` are refused.

    PyYAML passes ``compose_node`` the key node of a mapping value or the index of a sequence
    item; a stack of them is the field path of the node being composed.
    """

    _where: list[str]

    def compose_node(self, parent, index):
        if len(self._where) >= MAX_DEPTH:
            mark = self.peek_event().start_mark
            path = ""
            for key in self._where[1:]:
                path = join(path, key)
            raise YamlFault(path, f"line {mark.line + 1}: nested deeper than {MAX_DEPTH} levels")
        if isinstance(index, ScalarNode):
            key = _short(index.value)
        elif isinstance(index, int):
            key = index
        else:
            key = "<key>"
        self._where.append(key)
        try:
            return super().compose_node(parent, index)
        finally:
            self._where.pop()


class _Loader(_Depth, yaml.SafeLoader):
    """PyYAML's safe loader, all in Python, with the depth limit."""

    def __init__(self, stream):
        super().__init__(stream)
        self._where = []


if CParser is not None:
    class _FastLoader(_Depth, Composer, CParser, SafeConstructor, Resolver):
        """libyaml's scanner and parser under PyYAML's composer (the Python one, with the depth
        limit, not libyaml's own), constructor and resolver: the nodes and values of the safe loader."""

        def __init__(self, stream):
            CParser.__init__(self, stream)
            Composer.__init__(self)
            SafeConstructor.__init__(self)
            Resolver.__init__(self)
            self._where = []


def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[:limit] + "…"


def _children(node: Node, path: str):
    """(child node, its path) of a list or mapping node; a mapping's keys come with ``<key>`` paths."""
    if isinstance(node, SequenceNode):
        for i, child in enumerate(node.value):
            yield child, join(path, i)
    elif isinstance(node, MappingNode):
        for key, value in node.value:
            name = _short(key.value) if isinstance(key, ScalarNode) else "<key>"
            yield key, join(path, name) if isinstance(key, ScalarNode) else path
            yield value, join(path, name)


def _kind(node: Node) -> str:
    return "list" if isinstance(node, SequenceNode) else "mapping"


def check_nodes(root: Node) -> None:
    """Walk the composed document once: expanded size, alias cycles, long scalars, keys.

    Aliased nodes are the same Python object wherever they are used; their expanded size is
    counted once per use (memoised by identity), so the walk itself stays as small as the file.
    """
    size: dict[int, int] = {}
    state: dict[int, str] = {}          # "open" while its children are walked, "done" after
    stack = [(root, "", False)]
    while stack:
        node, path, leaving = stack.pop()
        key = id(node)
        if leaving:
            total = 1 + sum(size[id(c)] for c, _ in _children(node, path))
            if total > MAX_VALUES:
                raise YamlFault(path, f"expands to more than {MAX_VALUES:,} values (aliases used many "
                                      f"times over?); a design needs a few thousand")
            size[key], state[key] = total, "done"
            continue
        if state.get(key) == "done":
            continue
        if state.get(key) == "open":
            raise YamlFault(path, "an alias refers to the list or mapping it is part of")
        if isinstance(node, ScalarNode):
            if len(node.value) > MAX_SCALAR_CHARS:
                raise YamlFault(path, f"a value of {len(node.value):,} characters; at most {MAX_SCALAR_CHARS:,}")
            size[key], state[key] = 1, "done"
            continue
        if isinstance(node, MappingNode):
            seen: dict[str, int] = {}
            for k, _ in node.value:
                if k.tag == MERGE_TAG:
                    continue
                if not isinstance(k, ScalarNode):
                    raise YamlFault(path, f"a {_kind(k)} used as a key (line {k.start_mark.line + 1}); "
                                          f"keys are plain names")
                if k.value in seen:
                    raise YamlFault(join(path, _short(k.value)),
                                    f"duplicate key (lines {seen[k.value]} and {k.start_mark.line + 1})")
                seen[k.value] = k.start_mark.line + 1
        state[key] = "open"
        stack.append((node, path, True))
        stack.extend((c, p, False) for c, p in reversed(list(_children(node, path))))


def load(text: str, *, libyaml: bool = True):
    """The one document in ``text`` as plain Python values (dict, list, str, int, float, bool,
    None, dates). Raises :class:`YamlFault` past a limit and ``yaml.YAMLError`` on bad syntax
    (PyYAML's own, also where libyaml read the file first). ``libyaml=False`` reads with PyYAML's
    parser alone, as an install without libyaml does."""
    fast = libyaml and CParser is not None
    try:
        return _read(_FastLoader(text) if fast else _Loader(text))
    except yaml.YAMLError:
        if not fast:
            raise
        return _read(_Loader(text))          # PyYAML's parser says what is wrong, in its own words


def _read(loader):
    """The document ``loader`` composes, within the limits, as Python values."""
    try:
        root = loader.get_single_node()
        if root is None:
            return None
        check_nodes(root)
        return loader.construct_document(root)
    finally:
        loader.dispose()
