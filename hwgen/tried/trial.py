"""One design's trials: its file (bases merged) with changes applied by dotted path, validated as
the file would be, planned, and evaluated again by the models the checks ran: the tension sweep
(:func:`hwgen.checks.tension.tension_checks`, on the as-built taut study the build measured) and
the tendon states' statics in the reference orientation (:mod:`hwgen.checks.purpose`). Each plan,
sweep and stiffening is made once per distinct change (and the statics remembered in the active
cache by the robot it describes)."""
from __future__ import annotations

import copy
import hashlib
import json
import math
import pickle
from dataclasses import replace

import numpy as np

from .. import cache, designfile, params
from ..checks import purpose
from ..checks.base import Check
from ..checks.tension import sweeps, tension_checks, working_tensions
from ..designfile import keys_of
from ..errors import DesignError, InputError
from ..model import feasibility
from ..model.document import design_from
from ..model.gravity import Gravity
from ..model import statics as st
from ..model import stiffness as sf
from ..model.plan import make_plan

# one check a design, whichever tendon it names (the worst; the stiffening ones)
WORST_OF = ("actuation.coupling", "actuation.tension", "stiffening.tip", "stiffening.torsion")
MODEL_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)


def _key(changes: dict) -> str:
    return json.dumps(changes, sort_keys=True, default=str)


def put(doc: dict, path: str, value) -> None:
    """``value`` at the dotted ``path`` of ``doc`` (changed in place; mappings on the way made)."""
    keys = keys_of(path)
    node = doc
    for k, nxt in zip(keys, keys[1:]):
        child = node[k] if isinstance(k, int) else node.get(k)
        if not isinstance(child, (dict, list)):
            child = [] if isinstance(nxt, int) else {}
            node[k] = child
        node = child
    node[keys[-1]] = value


def up(x: float, step: float = 0.1) -> float:
    """``x`` rounded up to ``step`` (a value a person writes)."""
    return round(math.ceil(x / step - 1e-9) * step, 6)


def down(x: float, step: float = 0.1) -> float:
    return round(math.floor(x / step + 1e-9) * step, 6)


class Trial:
    """A loaded design, its plan and what its build measured, ready to be changed and evaluated."""

    def __init__(self, loaded: params.LoadedDesign, plan, report: dict, study: dict):
        self.loaded, self.plan, self.report = loaded, plan, report
        self.doc = designfile.document_of(loaded.layers)      # which keys a base wrote, for the gear
        self.gravity = Gravity.of(report.get("gravity"))
        self.taut = (report.get("as_built") or {}).get("taut") or {}
        self.centre = {t["name"]: t["max_abs_delta_mm"] for t in report.get("tendons", [])}
        self.base = purpose.figures(study)
        self.base_checks = {ident(c): c for c in report.get("checks", [])}
        lay = plan.tensioner_layout
        self.record = lay.search if lay is not None and lay.search else None
        self._plans: dict[str, object] = {}
        self._swept: dict[bytes, tuple] = {}
        self._tension: dict[str, list[Check] | None] = {}
        self._stiff: dict[str, dict | None] = {}
        self._robots: dict[bytes, dict] = {}      # the stiffening per robot, whatever its protocol's ceiling

    # ------------------------------------------------------------ where a value is
    def index(self, tendon: str) -> int | None:
        """The index in ``tendons`` of the design's tendon named ``tendon`` (or its mirror)."""
        for i, t in enumerate(self.loaded.design.tendons):
            if tendon in t.names:
                return i
        return None

    def current(self, path: str):
        """The design's value at ``path`` as validated (defaults and derived nulls included)."""
        node = self.loaded.design
        for k in keys_of(path):
            node = node[k] if isinstance(k, int) else getattr(node, k, None)
            if node is None:
                return None
        return node

    # ------------------------------------------------------------ the design changed
    def plan_with(self, changes: dict):
        """The plan of the design with ``changes`` ({dotted path: value}); None when the changed
        design is refused (the schema's bounds, a rule, a plan that cannot be made)."""
        key = _key(changes)
        if key not in self._plans:
            self._plans[key] = self._plan(changes)
        return self._plans[key]

    def _plan(self, changes: dict):
        if not changes:
            return self.plan
        doc = copy.deepcopy(self.doc)
        for path, value in changes.items():
            put(doc, path, value)
            doc = doc.written(keys_of(path))
        try:
            d, _ = design_from(doc, self.loaded.source)       # as a build of the changed file makes it
            plan = make_plan(d, self.record)       # the build's tensioner arrangement, laid out again
            feasibility.check_plan(plan, d)
        except (InputError, DesignError, *MODEL_ERRORS):
            return None
        return plan

    def tension(self, changes: dict) -> list[Check] | None:
        """The tension checks (tendon.taut, tendon.overload, actuation.*) of the changed design,
        on the as-built taut study this build measured (a change to the holes is not in it)."""
        key = _key(changes)
        if key not in self._tension:
            plan = self.plan_with(changes)
            got = None
            if plan is not None:
                try:
                    got = tension_checks(plan, self.taut, self.centre, self._sweeps(plan))[1]
                except MODEL_ERRORS:
                    got = None
            self._tension[key] = got
        return self._tension[key]

    def _sweeps(self, plan) -> tuple:
        """:func:`hwgen.checks.tension.sweeps` of ``plan``, once per robot: a change to the line's
        strength or the checks' limits moves none of the sweep's tensions (only the rules the
        statics does not read in it), so it sweeps once for them all."""
        desc = sf.describe(plan)
        key = hashlib.sha256(pickle.dumps((replace(desc, rules=None), working_tensions(desc, plan),
                                           plan.check.max_angle_deg))).digest()
        if key not in self._swept:
            self._swept[key] = sweeps(plan)
        return self._swept[key]

    def stiffening(self, changes: dict) -> dict | None:
        """{"tip", "torsion"} ratios (all tendons over the pair, reference orientation,
        frictionless) of the changed design, and its floors; None when it has no pair."""
        key = _key(changes)
        if key not in self._stiff:
            plan = self.plan_with(changes)
            self._stiff[key] = None if plan is None else self._stiffening(plan)
        return self._stiff[key]

    def _stiffening(self, plan) -> dict | None:
        todo = sf.states(plan)
        act = plan.tensioner.actuating_channel
        by = {s.name: s for s in todo}
        full = max(todo, key=lambda s: len(s.channels)) if todo else None
        if full is None or act not in by or full.name == act:
            return None
        try:
            desc = replace(sf.describe(plan, self.gravity), eyelet_friction=None)   # frictionless: no capstan
            robot = hashlib.sha256(pickle.dumps((replace(desc, rules=replace(desc.rules, allowable_n=0.0)),
                                                 full, by[act]))).digest()
            kept = self._robots.get(robot)
            if kept is not None and kept["max_set_n"] < 0.99 * min(kept["allowable_n"], desc.rules.allowable_n):
                got = kept      # only the protocol's ceiling moved, and it pulled nowhere near either
            else:
                inputs = (desc, full, by[act], sf.REFERENCE, sf.STUDY_H_MAX)
                got = cache.remembered("tried stiffening", inputs, lambda: _two_states(desc, full, by[act]))
                if got is not None:
                    got = {**got, "allowable_n": desc.rules.allowable_n}
                    self._robots.setdefault(robot, got)
        except MODEL_ERRORS:
            return None
        if got is None:
            return None
        return {**got, "min_tip": plan.check.min_stiffening, "min_torsion": plan.check.min_torsion_stiffening}


def _two_states(desc: sf.Described, full: sf.State, act: sf.State) -> dict | None:
    """The ratios of :func:`hwgen.checks.purpose.ratios` from the two states alone."""
    model = st.Model(desc.robot, sf.STUDY_H_MAX)
    if model.n_dof > sf.STUDY_MAX_DOF:
        return None
    memo: dict = {}
    got = {}
    for s in (act, full):
        got[s.name] = next(e for e in sf.evaluate(desc, model, s, sf.REFERENCE, memo)
                           if e["friction"] == purpose.FRICTION)
    pulled = [v for e in got.values() for v in e["set_n"].values() if v is not None]
    return {**purpose.ratios(got[full.name], got[act.name], (full.name, act.name)),
            "max_set_n": max(pulled, default=0.0)}


def ident(check) -> tuple:
    """A check's identity across two evaluations: its id and where it looked (part, tendon, ...)."""
    c = check if isinstance(check, dict) else check.to_json()
    if c["id"] in WORST_OF:
        return (c["id"],)
    w = c.get("where") or {}
    return (c["id"],) + tuple((k, json.dumps(w[k], sort_keys=True, default=str))
                              for k in ("part", "parts", "tendon", "tendons", "channel", "station") if k in w)
