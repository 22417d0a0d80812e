"""The tune file: a base design, the free parameters with their bounds, and the goal (pydantic).

A tune file names a base design (a design YAML, relative to the tune file, as a sweep file does),
optional fixed changes to it (``set``: parameter path → value, applied before tuning and kept in
``best.yaml``), the ``free`` parameters (paths into the design as sweep axes name them, each with
``low``/``high`` (continuous, or whole numbers with ``integer``; ``step``, ``log``) or a list of
``choices``) and the ``goal``:

- ``maximize`` / ``minimize``: one result (or a list) of the statics or the checks
  (:mod:`hwgen.tune.results` names them), subject to every check of ``level`` passing, to
  ``require`` (checks that must pass even where the design makes them warnings) and to
  ``at_least`` / ``at_most`` (a number, or ``base``: the base design's own figure). More than one
  result gives a Pareto front. The statics' results are of ``state`` (default: every tendon
  locked), ``orientation`` (default ``gravity -z``) and ``friction`` (default ``none``), as
  ``hwgen stiffness`` headlines them. ``checks: required`` leaves out every check not under ``require``
  (an unconstrained search: a known answer, or a design to be fixed afterwards).
- ``pass: true``: the design nearest the base (each free parameter's change over its bound's
  range, root mean square) that passes every check.

Bad tune input is an :class:`hwgen.errors.InputError` naming the tune file and the field, as a bad
sweep file is; the paths, resolving a trial over the base and its hash are the sweep's
(:mod:`hwgen.sweep.spec`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, model_validator

from .. import designfile
from ..errors import InputError, echo
from ..sweep import spec as sweep_spec
from ..sweep.records import Failure
from . import results

MAX_BUDGET = 100_000
Scalar = str | int | float | bool | None


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class Free(_Model):
    """One free parameter: a path and its bounds (``low``/``high``) or its ``choices``."""

    path: str = Field(min_length=1, max_length=200, description="parameter path: tendons[1].routing.function.k")
    low: float | None = Field(None, allow_inf_nan=False)
    high: float | None = Field(None, allow_inf_nan=False)
    integer: bool = Field(False, description="whole numbers only (low and high included)")
    step: float | None = Field(None, gt=0, allow_inf_nan=False, description="values on a grid of this step from low")
    log: bool = Field(False, description="sample on a log scale (low > 0)")
    choices: list[Scalar] | None = Field(None, min_length=1, max_length=1000)

    @model_validator(mode="after")
    def _bounds(self):
        if self.choices is not None:
            if self.low is not None or self.high is not None:
                raise ValueError("give 'choices' or 'low' and 'high', not both")
            return self
        if self.low is None or self.high is None:
            raise ValueError("give 'low' and 'high' (or 'choices')")
        if not self.high > self.low:
            raise ValueError(f"high ({self.high:g}) must be above low ({self.low:g})")
        if self.log and self.low <= 0:
            raise ValueError("a log scale needs low > 0")
        if self.log and self.step is not None:
            raise ValueError("give 'step' or 'log', not both")
        if self.integer and (self.low != int(self.low) or self.high != int(self.high)):
            raise ValueError("integer bounds must be whole numbers")
        if self.integer and self.step is not None and self.step != int(self.step):
            raise ValueError("an integer parameter's step must be a whole number")
        return self

    @property
    def range(self) -> float:
        """The span a change is scaled by (choices: 1, a change of choice counts one range)."""
        return 1.0 if self.choices is not None else self.high - self.low


def _bound(v):
    if v == "base" or (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)):
        return v
    raise ValueError(f"a bound is a number or 'base' (the base design's own figure), not {echo(v)}")


Bound = Annotated[Any, BeforeValidator(_bound)]


class Goal(_Model):
    maximize: str | list[str] | None = None
    minimize: str | list[str] | None = None
    pass_: bool = Field(False, alias="pass", description="the passing design nearest the base")
    state: str | None = Field(None, description="the tendon state the statics' results are of (default: "
                                                "every tendon locked)")
    orientation: Literal["gravity -z", "gravity +z", "weightless"] = Field(
        "gravity -z", description="the robot's orientation the statics' results are of (hwgen stiffness's headline: "
                                  "horizontal, gravity toward -z)")
    friction: Literal["none", "stuck"] = Field(
        "none", description="the eyelet friction bound the statics' results are of: none (frictionless, hwgen "
                            "stiffness's headline) or stuck (every segment held at its eyelets)")
    at_least: dict[str, Bound] = Field(default_factory=dict)
    at_most: dict[str, Bound] = Field(default_factory=dict)
    require: list[str] = Field(default_factory=list, description="checks that must pass even where the design "
                                                                 "makes them warnings (tendon.taut, ...)")
    checks: Literal["all", "required"] = Field(
        "all", description="all: every check of the level must pass (and those under require); required: only "
                           "those under require")

    def default_state(self, known: tuple[str, ...]) -> str:
        """The one rule for the state a statics result without "@" is of: the goal's ``state``, else
        every tendon locked (the base's last state, as ``hwgen stiffness`` lists them)."""
        return self.state or (known[-1] if known else "")

    @model_validator(mode="after")
    def _one_kind(self):
        if self.pass_ and (self.maximize or self.minimize):
            raise ValueError("give 'pass' or results to maximize/minimize, not both")
        if not self.pass_ and not (self.maximize or self.minimize):
            raise ValueError("give 'maximize', 'minimize' (a result or a list) or 'pass: true'")
        names = [n for n, _ in self.objectives()]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"{', '.join(twice)}: each result is an objective once (maximized or minimized, "
                             f"not both, not twice)")
        return self

    def binds(self, f: Failure | dict) -> bool:
        """Whether a row's failure record (:class:`hwgen.sweep.records.Failure`, or its JSON) counts
        against this goal: one that fails the design when every check must pass, or a check under
        ``require`` whatever its severity."""
        f = Failure.of(f)
        return (f.fails and self.checks == "all") or f.id in self.require

    def objectives(self) -> list[tuple[str, str]]:
        """(name, "maximize" or "minimize") of each objective, in order; ``pass``: the distance."""
        if self.pass_:
            return [("distance", "minimize")]
        out = []
        for how in ("maximize", "minimize"):
            names = getattr(self, how)
            out += [(n, how) for n in ([names] if isinstance(names, str) else names or [])]
        return out


class Tune(_Model):
    tune: str = Field(min_length=1, max_length=64, description="name; the results go to OUT/tunes/<name>/")
    base: str = Field(min_length=1, description="the design file every trial starts from (relative to this file)")
    set: dict[str, Any] = Field(default_factory=dict, description="parameter path -> value: fixed changes to the "
                                                                 "base before tuning (null: the default)")
    level: Literal["lengths", "robust", "coupling", "build"] = "coupling"
    free: list[Free] = Field(min_length=1, max_length=64)
    goal: Goal
    budget: int = Field(100, ge=1, le=MAX_BUDGET, description="trials in all (--budget overrides)")
    batch: int | None = Field(None, ge=1, le=1000, description="tasks in flight at once (default: 2 a worker; inline 1): "
                                                                    "one seed draws the same trials wherever this is the same")
    seed: int = Field(0, ge=0, le=2**32 - 1, description="the sampler's seed")
    sampler: Literal["auto", "tpe", "nsga2", "random"] = Field(
        "auto", description="auto: TPE for one objective, NSGA-II for a front")
    robust_samples: int = Field(200, ge=0, le=100_000, description="robust level and above: as-built samples a "
                                                                  "trial")


@dataclass(frozen=True)
class Loaded:
    spec: Tune
    source: Path
    base_path: Path
    base: dict                     # the base design's document with ``set`` applied
    names: tuple[str, ...]         # the free parameters' paths, in order
    base_values: tuple             # each free parameter's value in the base (defaults filled in)
    objectives: tuple[tuple[str, str], ...]
    states: tuple[str, ...]        # the tendon states the statics is asked for
    state: str                     # the goal's state: a statics result without "@" is of it ("" without statics)
    digest: str                    # what makes trials comparable: base, set, free, goal, level

    @property
    def free(self) -> list[Free]:
        return self.spec.free


def load(path: str | Path) -> Loaded:
    """Read and check a tune file and its base design; raise InputError naming the file and field."""
    path = Path(path)
    spec, base_path, layers = sweep_spec.read_with_base(path, Tune, "tune", Tune)
    return resolve(path, spec, base_path, designfile.document_of(layers))


def resolve(path: Path, spec: Tune, base_path: Path, base: dict) -> Loaded:
    """A tune (read from ``path``, or derived from a design there: :mod:`hwgen.tune.derive`) over
    the base design's document ``base``, checked as a tune file is."""
    for key, value in spec.set.items():
        keys = _keys(path, f"set.{key}", key, base)
        if value is None and isinstance(keys[-1], int):
            raise InputError(path, f"set.{key}", "null gives a field its default, and a list's item has none: set "
                                                 "the list whole, without the item")
        base = sweep_spec.set_path(base, keys, value) if value is not None else _drop(base, keys)
    fixed = sweep_spec.resolve_doc(base, -1, (), f"{path}: the base with 'set'")
    if fixed.design is None:
        raise InputError(path, "set", f"the base with these changes is not a design: {fixed.message}")
    names = []
    for i, fr in enumerate(spec.free):
        _keys(path, f"free[{i}].path", fr.path, base)
        if fr.path in names:
            raise InputError(path, f"free[{i}].path", f"{echo(fr.path)} is already free")
        names.append(fr.path)
    dump = fixed.design.model_dump(mode="json")
    values = tuple(_base_value(dump, n) for n in names)
    for i, (fr, v) in enumerate(zip(spec.free, values)):
        if fr.choices is None and v is not None and (not isinstance(v, (int, float)) or isinstance(v, bool)):
            raise InputError(path, f"free[{i}].path", f"the base's value there is {echo(v)}, not a number: give "
                                                      f"'choices'")
    from ..model.plan import make_plan        # the base's tendon states: the statics' results name one
    from ..model.stiffness import states as plan_states
    known = tuple(s.name for s in plan_states(make_plan(fixed.design)))
    objectives = tuple(spec.goal.objectives())
    states, state = _check_goal(path, spec, known)
    digest = sweep_spec.digest({"base": base, "free": [f.model_dump() for f in spec.free],
                                "goal": spec.goal.model_dump(by_alias=True), "level": spec.level,
                                "robust_samples": spec.robust_samples})
    return Loaded(spec=spec, source=path, base_path=base_path, base=base, names=tuple(names), base_values=values,
                  objectives=objectives, states=states, state=state, digest=digest)


def _base_value(dump: dict, name: str):
    """The base's value at a free parameter's path; None where the base writes none (a channel's
    winding, a key of a mapping of names: its default applies)."""
    try:
        return designfile.value_at(dump, sweep_spec.parse_path(name))
    except KeyError:
        return None


def _keys(path: Path, field: str, text: str, base: dict) -> list:
    try:
        keys = sweep_spec.parse_path(text)
    except ValueError as e:
        raise InputError(path, field, str(e)) from None
    why = sweep_spec.check_path(keys, base)
    if why:
        raise InputError(path, field, why)
    return keys


def _drop(doc: dict, keys: list) -> dict:
    """A document without the key at ``keys`` (its default then applies); ``doc`` is left as it was."""
    if len(keys) == 1:
        return {k: v for k, v in doc.items() if k != keys[0]}
    parent = keys[:-1]
    node = doc
    for k in parent:
        node = node[k] if isinstance(k, int) else node.get(k, {})
    return sweep_spec.set_path(doc, parent, {k: v for k, v in node.items() if k != keys[-1]})


def _check_goal(path: Path, spec: Tune, known: tuple[str, ...]) -> tuple[tuple[str, ...], str]:
    """(the tendon states the goal's results need, the goal's state); InputError naming the goal's
    field that is wrong."""
    g = spec.goal
    if g.state is not None and g.state not in known:
        raise InputError(path, "goal.state", f"{echo(g.state)} is not a tendon state of the base: "
                                             f"{', '.join(known)}")
    default = g.default_state(known)
    wanted = []

    def name(field: str, text: str) -> None:
        why, state = results.check_name(text, spec.level, known)
        if why:
            raise InputError(path, field, why)
        if state is not None or results.is_statics(text):
            wanted.append(state or default)

    for how in ("maximize", "minimize"):
        v = getattr(g, how)
        for i, n in enumerate([v] if isinstance(v, str) else v or []):
            name(f"goal.{how}" + ("" if isinstance(v, str) else f"[{i}]"), n)
    for how in ("at_least", "at_most"):
        for n in getattr(g, how):
            name(f"goal.{how}.{n}", n)
    for i, cid in enumerate(g.require):
        if not results.CHECK_ID.fullmatch(cid):
            raise InputError(path, f"goal.require[{i}]", f"{echo(cid)} is not a check id (tendon.taut, ...)")
    states = tuple(dict.fromkeys(wanted))
    return states, (default if states else "")


def distance(loaded: Loaded, values: tuple) -> float:
    """How far a trial is from the base: each free parameter's change over its bound's range (a
    change of choice, or a value where the base has none, counts one), root mean square."""
    total = 0.0
    for fr, v, b in zip(loaded.free, values, loaded.base_values):
        if fr.choices is not None or v is None or b is None:       # a value given where the base leaves it unset
            d = 0.0 if v == b else 1.0                              # (pretension_n: the protocol's) counts one range
        else:
            d = (float(v) - float(b)) / fr.range
        total += d * d
    return math.sqrt(total / len(values))
