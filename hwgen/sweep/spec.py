"""The sweep file: a base design, axes over parameter paths, and how to combine them (pydantic).

A sweep file names a base design (a design YAML, relative to the sweep file, read as a design
file's own ``base`` is: :mod:`hwgen.designfile`, so it may build on a base itself) and axes, each over
one parameter path of the design (``tendons[1].routing.function.k``, ``disks.count``,
``backbone.length``) with a list of ``values``, a ``range`` (start, stop included, step) or seeded
``random`` draws. ``mode: grid`` takes every combination of the axes' values; ``mode: samples``
draws ``samples`` variants, each axis independently (a list or range: one of its values; random:
one uniform draw); ``mode: zip`` takes the axes side by side (variant i has the i-th value of
every axis; they must have as many values each), for parameters that change together. Expansion (:func:`variants`) is numpy and the standard library only.

Bad sweep input is an :class:`hwgen.errors.InputError` naming the sweep file, the field path and
what is wrong, like a bad design file; a variant that is bad input is not: it becomes a row of
the results with its message (:func:`resolve`).
"""
from __future__ import annotations

import copy
import functools
import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .. import designfile, params
from ..errors import DesignError, InputError, echo, nearest
from ..model.document import design_from

LEVELS = ("lengths", "robust", "coupling", "build")
MAX_VARIANTS = 5_000_000     # a grid larger than this is a mistake in the sweep file, not a sweep
MAX_AXIS_VALUES = 1_000_000


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(_Model):
    """start, start + step, ... up to and including stop (within a millionth of a step)."""

    start: float = Field(allow_inf_nan=False)
    stop: float = Field(allow_inf_nan=False)
    step: float = Field(gt=0, allow_inf_nan=False)

    @model_validator(mode="after")
    def _ordered(self):
        if self.stop < self.start:
            raise ValueError("stop is below start")
        if (self.stop - self.start) / self.step >= MAX_AXIS_VALUES:
            raise ValueError(f"more than {MAX_AXIS_VALUES:,} values")
        return self

    def values(self) -> list[float]:
        n = int(math.floor((self.stop - self.start) / self.step + 1e-6)) + 1
        return [round(self.start + i * self.step, 12) for i in range(n)]


class Random(_Model):
    """Uniform draws in [low, high], from the sweep's seed; ``integer``: whole numbers (high included)."""

    low: float = Field(allow_inf_nan=False)
    high: float = Field(allow_inf_nan=False)
    count: int | None = Field(None, ge=1, le=MAX_AXIS_VALUES, description="grid mode: how many draws this axis has")
    integer: bool = False
    round: float | None = Field(None, gt=0, allow_inf_nan=False, description="round each draw to a multiple of this")

    @model_validator(mode="after")
    def _ordered(self):
        if self.high < self.low:
            raise ValueError("high is below low")
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list:
        if self.integer:
            return [int(v) for v in rng.integers(math.ceil(self.low), math.floor(self.high) + 1, n)]
        v = rng.uniform(self.low, self.high, n)
        if self.round:
            v = np.round(v / self.round) * self.round
        return [round(float(x), 12) for x in v]


class Axis(_Model):
    path: str = Field(min_length=1, max_length=200, description="parameter path: tendons[1].routing.function.k")
    values: list[Any] | None = Field(None, min_length=1, max_length=MAX_AXIS_VALUES)
    range: Range | None = None
    random: Random | None = None

    @model_validator(mode="after")
    def _one_kind(self):
        given = [k for k in ("values", "range", "random") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give one of 'values', 'range' or 'random'" + (f", not {' and '.join(given)}" if given else ""))
        return self


class Summary(_Model):
    axes: tuple[str, str] | None = Field(None, description="the two axes of the decoupled-region plot "
                                                           "(default: the first two)")
    best: int = Field(10, ge=1, le=1000, description="rows of the best-variants table")


class Sweep(_Model):
    sweep: str = Field(min_length=1, max_length=64, description="name; the results go to OUT/sweeps/<name>/")
    base: str = Field(min_length=1, description="the design file every variant starts from (relative to this file)")
    level: Literal["lengths", "robust", "coupling", "build"] = "lengths"
    mode: Literal["grid", "samples", "zip"] = "grid"
    samples: int | None = Field(None, ge=1, le=MAX_VARIANTS, description="mode samples: how many variants")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="seed of the random axes and of samples mode")
    axes: list[Axis] = Field(min_length=1, max_length=32)
    robust_samples: int = Field(200, ge=0, le=100_000,
                                description="robust level and above: as-built samples per variant (a design's "
                                            "check.samples is for one design; a sweep wants a screening figure)")
    batch: int | None = Field(None, ge=1, le=100_000, description="variants per Dask task (default: by level)")
    keep: list[int] = Field(default_factory=list, description="build level: the variant numbers whose files are kept")
    summary: Summary = Field(default_factory=Summary)

    @model_validator(mode="after")
    def _mode(self):
        if self.mode == "samples" and self.samples is None:
            raise ValueError("mode samples needs 'samples' (how many variants)")
        if self.mode != "samples" and self.samples is not None:
            raise ValueError(f"'samples' is for mode samples; mode {self.mode} takes the axes' values")
        return self


@dataclass(frozen=True)
class Loaded:
    spec: Sweep
    source: Path
    base_path: Path
    base: dict                     # the base design's document, deprecated keys moved
    names: tuple[str, ...]         # the axes' paths, in order: the parameter columns
    columns: dict[str, str]        # path -> "float", "int" or "json": how its column is stored


@dataclass(frozen=True)
class Variant:
    index: int                     # its number in the sweep (grid order, or draw order)
    values: tuple                  # one value per axis


# ---------------------------------------------------------------- paths

parse_path = designfile.parse_path       # one rule for a field path, written once


def check_path(keys: list[str | int], base: dict) -> str | None:
    """Why the path names no parameter of a design (None: it does). Each key must be a field of the
    schema; each list index must exist in the base design."""
    kind, cur = "model", params.Design
    node: Any = base
    for n, key in enumerate(keys):
        where = "".join(f"[{k}]" if isinstance(k, int) else ("." if n else "") + k for n, k in enumerate(keys[:n + 1]))
        if kind == "model":
            if not isinstance(key, str) or key not in cur.model_fields:
                close = nearest(key, cur.model_fields)
                meant = f"; did you mean {designfile.dotted([*keys[:n], close])}?" if close else ""
                return f"{where}: not a field of the design{meant} (see `hwgen schema`)"
            kind, cur = params.unwrap(cur.model_fields[key].annotation)
            node = node.get(key) if isinstance(node, dict) else None
        elif kind == "seq":
            if not isinstance(key, int):
                return f"{where}: a list, so an item [i] comes next"
            if not isinstance(node, list) or key >= len(node):
                have = len(node) if isinstance(node, list) else 0
                return f"{where}: the base design has {have} item(s) there"
            kind, cur = params.unwrap(cur)
            node = node[key]
        else:                         # a dict of names, or a leaf holding a list (a table row): not checked deeper
            return None
    return None


def set_path(doc: dict, keys, value) -> dict:
    """A document with ``value`` at ``keys``: the mappings and lists on the way there are copies
    (missing mappings made), everything else is shared with ``doc``, which is left as it was; a
    :class:`hwgen.designfile.Document` stays one, the value at ``keys`` now its own."""
    root = doc.written(keys) if isinstance(doc, designfile.Document) else dict(doc)
    node = root
    for k, nxt in zip(keys, keys[1:]):
        child = node[k] if isinstance(k, int) else node.get(k)
        if isinstance(child, dict):
            child = dict(child)
        elif isinstance(child, list):
            child = list(child)
        else:
            child = [] if isinstance(nxt, int) else {}
        node[k] = child
        node = child
    node[keys[-1]] = copy.deepcopy(value)
    return root


# ---------------------------------------------------------------- loading

def read_with_base(path: Path, model: type[BaseModel], kind: str, schema: type[BaseModel] | None = None):
    """A sweep or tune file (``kind``: the field naming it) read with the limits of a design file,
    checked against ``model``, and the base design it names read and validated (a bad base is bad
    input, named in its own file): (spec, the base's path, its layers). ``schema``: the model
    whose keys an unknown key is matched against (None: no suggestion)."""
    raw = designfile.read_bytes(path, kind)
    data, _ = params.document(raw, path) if raw.strip() else ({}, [])
    try:
        spec = model.model_validate(data)
    except ValidationError as e:
        raise params.validation_error(e, path, schema) from None
    name = getattr(spec, kind)
    if not params.SAFE_NAME.match(name):
        raise InputError(path, kind, f"{echo(name)} is not a safe file name (letters, digits, _ and -)")
    base_path = designfile.base_file(path, spec.base)          # as a design file's base: one rule
    layers = designfile.read_layers(base_path)                 # which may build on a base of its own
    params.validate(copy.deepcopy(layers.doc), base_path, layers)
    return spec, base_path, layers


def load(path: str | Path) -> Loaded:
    """Read and check a sweep file and its base design; raise InputError naming the file and field."""
    path = Path(path)
    spec, base_path, layers = read_with_base(path, Sweep, "sweep", Sweep)
    base = designfile.document_of(layers)          # which keys a base wrote: a variant's gear follows its process
    names, columns = [], {}
    for i, ax in enumerate(spec.axes):
        try:
            keys = parse_path(ax.path)
        except ValueError as e:
            raise InputError(path, f"axes[{i}].path", str(e)) from None
        why = check_path(keys, base)
        if why:
            raise InputError(path, f"axes[{i}].path", why)
        if ax.path in names:
            raise InputError(path, f"axes[{i}].path", f"{echo(ax.path)} is already an axis")
        names.append(ax.path)
        columns[ax.path] = _column_kind(ax)
    if spec.summary.axes is not None:
        for j, a in enumerate(spec.summary.axes):
            if a not in names:
                raise InputError(path, f"summary.axes[{j}]", f"{echo(a)} is not one of the axes")
    if spec.mode == "zip":
        sizes = [len(v) for v in _axis_values(spec)]
        for i, k in enumerate(sizes):
            if k != sizes[0]:
                raise InputError(path, f"axes[{i}]", f"{k} values; mode zip needs as many as axes[0] has ({sizes[0]})")
    n = count(spec)
    if n > MAX_VARIANTS:
        raise InputError(path, "axes", f"{n:,} variants; at most {MAX_VARIANTS:,} in one sweep")
    for j, k in enumerate(spec.keep):
        if not 0 <= k < n:
            raise InputError(path, f"keep[{j}]", f"variant {k} does not exist (there are {n}, numbered from 0)")
    return Loaded(spec, path, base_path, base, tuple(names), columns)


def _column_kind(ax: Axis) -> str:
    if ax.range is not None:
        return "float"
    if ax.random is not None:
        return "int" if ax.random.integer else "float"
    vals = ax.values
    if all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
        return "int"
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        return "float"
    return "json"


def _axis_values(spec: Sweep) -> list[list]:
    """Each axis's values for a grid (random axes drawn from the sweep's seed, one stream per axis)."""
    out = []
    for i, ax in enumerate(spec.axes):
        if ax.values is not None:
            out.append(list(ax.values))
        elif ax.range is not None:
            out.append(ax.range.values())
        else:
            rng = np.random.default_rng([spec.seed, i])
            out.append(ax.random.draw(rng, ax.random.count or 1))
    return out


def count(spec: Sweep) -> int:
    if spec.mode == "samples":
        return spec.samples
    if spec.mode == "zip":
        return len(_axis_values(spec)[0])
    n = 1
    for ax in spec.axes:
        if ax.values is not None:
            n *= len(ax.values)
        elif ax.range is not None:
            n *= int(math.floor((ax.range.stop - ax.range.start) / ax.range.step + 1e-6)) + 1
        else:
            n *= ax.random.count or 1
    return n


def variants(spec: Sweep) -> list[Variant]:
    """Every variant of the sweep, numbered: the grid in row-major order (the last axis fastest), or
    ``samples`` draws (one seeded stream per axis, so adding an axis leaves the others' draws)."""
    if spec.mode == "grid":
        return [Variant(i, tuple(v)) for i, v in enumerate(itertools.product(*_axis_values(spec)))]
    if spec.mode == "zip":
        return [Variant(i, tuple(v)) for i, v in enumerate(zip(*_axis_values(spec)))]
    cols = []
    for i, ax in enumerate(spec.axes):
        rng = np.random.default_rng([spec.seed, i])
        if ax.random is not None:
            cols.append(ax.random.draw(rng, spec.samples))
        else:
            vals = ax.values if ax.values is not None else ax.range.values()
            cols.append([vals[j] for j in rng.integers(0, len(vals), spec.samples)])
    return [Variant(i, tuple(c[i] for c in cols)) for i in range(spec.samples)]


# ---------------------------------------------------------------- one variant

@dataclass
class Resolved:
    """A variant applied to the base: its document, its hash and, when it is valid, its design."""

    index: int
    values: tuple
    doc: dict | None
    hash: str
    design: params.Design | None
    message: str                   # why it is bad input ("" when valid)


def digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str).encode()).hexdigest()


def resolve(base: dict, names: tuple[str, ...], v: Variant, label: str = "variant") -> Resolved:
    """Apply the variant's values to a copy of the base and validate it like a design file (schema,
    the checks across fields, feasibility). The hash is of the resolved design (every default filled
    in), so two spellings of one design share it; of the document when it is bad input."""
    doc = base
    for name, value in zip(names, v.values):
        try:
            doc = set_path(doc, _parsed(name), value)
        except (IndexError, KeyError, TypeError) as e:
            return Resolved(v.index, v.values, None, digest({"bad": [base, names, list(v.values)]}), None,
                            f"{name}: cannot be set in this variant ({type(e).__name__})")
    return resolve_doc(doc, v.index, v.values, f"{label} {v.index}")


@functools.lru_cache(maxsize=1024)
def _parsed(path: str) -> tuple[str | int, ...]:
    return tuple(parse_path(path))


def resolve_doc(doc: dict, index: int, values: tuple, where: str) -> Resolved:
    try:
        design, _ = design_from(doc, where)            # as a build of this document makes it
    except (InputError, DesignError) as e:
        found = e.problems if isinstance(e, InputError) else [e]
        return Resolved(index, values, doc, digest({"bad": doc}), None,
                        "; ".join(f"{p.path or '<document>'}: {p.message}" for p in found))
    return Resolved(index, values, doc, digest(design.model_dump(mode="json")), design, "")
