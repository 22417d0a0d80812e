"""Running a tune: Optuna asks for trials, the sweep's workers evaluate them, Optuna is told.

The optimiser is Optuna's (:mod:`optuna`): TPE (``TPESampler``, each parameter modelled on its
own (:func:`sampler` says why), constant liar for the trials in flight) for one objective, NSGA-II
(``NSGAIISampler``) for a Pareto front, both reading each trial's constraints
(``Trial.set_constraint``, Optuna 5's successor of ``constraints_func``: a trial is feasible
when every constraint value is ≤ 0; an infeasible one ranks by the sum of its violations);
``random`` for a baseline. The constraints (:func:`score`):
``checks``, the checks of the level that fail (and those under ``goal.require`` even where the
design makes them warnings; each counts how far past its limit it is, relative to the limit:
:func:`_violation`), and each ``at_least`` / ``at_most`` bound's relative shortfall, named after
the bound. Both in the same relative measure, so an infeasible trial ranks by how far it is from
feasible whichever rule it breaks (a check failed by a whole count each drew the search to the
edge of the bounds, where it stayed).

Trials run on the sweep's pool (:func:`hwgen.sweep.run.pool`: a local Dask cluster, a running
one, or inline), as batches of :func:`hwgen.sweep.levels.evaluate_batch` with the statics as its
``with_plan`` hook (:func:`hwgen.tune.results.statics`); a new trial is asked whenever one
finishes, so the workers stay busy. Each trial's row is kept in the trial itself (its user
attributes) in the study's journal (``JournalStorage(JournalFileBackend)``,
``OUT/tunes/<name>/journal.log``), so an interrupted tune resumes from its trials: those told are
never evaluated again, those in flight when it stopped are asked again first. A trial whose
design (by the sweep's hash of the resolved design) was already evaluated is told that result
without evaluating it again. A trial that cannot be feasible stops early on its worker (its row
says ``screened``): one that fails at the lengths level (eq. (2), the walls), and one whose
statics already miss a bound of the goal (:func:`short_of_bounds`); it is told what was found.
"""
from __future__ import annotations

import json
import math
import shutil
import time
import uuid
from collections import deque
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from ..designfile import parse_path
from ..errors import InputError
from ..sweep import levels
from ..sweep.run import pool
from ..sweep.records import EvalOptions, Failure, Row
from ..sweep.spec import Variant, resolve
from . import local, results
from .spec import Loaded, distance

TRIALS_PER_TASK = {"lengths": 8, "robust": 1, "coupling": 1, "build": 1}
BAD = 100.0                 # the constraint value of a trial that is bad input or an error: worse than any check
EXCESS_CAP = 10.0
MIN_EXCESS = 1e-3
# TPE ranks the trials it counts infeasible by their violation alone, and so closes on a binding
# bound from the side it cannot pass (tune-stiffness: hundreds of trials 0.01-0.1 % short of the
# prototype's torsion, none beyond it). It is told each bound of the goal this much further
# (relative), so that where it closes on a bound it does so on the goal's side of it; feasibility
# and the best are judged by the goal's own bounds. (Not measured apart from the changes beside it.)
SEARCH_MARGIN = 0.01
UNMEASURED = 1.0
# the moves are the feasible-first phase: while this share of the trials told passes, TPE's model of the
# good trials is informed and it draws every trial (on the known answer, where every trial passes, moves
# from the start left the best farther from the answer than random search's, TPE's model then fitted
# to the base's neighbourhood)
FEASIBLE_ENOUGH = 0.25
LOCAL_SHARE = 0.8           # of the trials, moves from the incumbent (:class:`_Moves`); measured in docs/sweeps.md
# a climb from the one best trial stalls on its ridge (the prototype: 1.12x and 1.26x flat for the last
# 250 of 600 trials): this share of the moves starts from another of the few best passing trials
TOP_K = 5
RESTART_SHARE = 0.2
# the base sits on its own torsion bound, and most stiffer moves from it pass every check and miss that
# bound by a little (a drawn tension moves the torsion across it): this share of the moves starts from
# the stiffest such near miss (checks passing, bounds missed by at most NEAR_MISS in all, relative),
# stiffer than the incumbent, and moves one of its pre-tensions: a tension moves the statics (the
# bounds) and leaves the geometry the checks passed (eq. (2), walls, overlaps) as it is. (A near miss of
# any constraints summing to 5 %, any one value moved: the prototype's seeds 0 and 1 at 1.00x after 100
# trials, against 1.12x and 1.06x this way.)
REPAIR_SHARE = 0.25
NEAR_MISS = 0.05
JOURNAL = "journal.log"


@dataclass
class Outcome:
    folder: Path
    budget: int
    done_before: int            # trials told before this run
    evaluated: int              # trials this run evaluated
    repeated: int               # trials this run told from an evaluated design of the same hash
    seconds: float
    workers: int
    start_seconds: float
    cpu_s: float
    first_best_s: float | None = None     # wall time from the start to the best trial's result (this run)
    whole: int = 0              # trials this run evaluated through every level (not screened out early)
    whole_cpu_s: float = 0.0    # their CPU
    verdicts: dict = field(default_factory=dict)


def folder_of(loaded: Loaded, out_root: Path) -> Path:
    return Path(out_root) / "tunes" / loaded.spec.tune


def _optuna():
    import optuna
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def grid_low(fr, base) -> float:
    """Where a free parameter's step grid starts: at ``low``, or, where the base's value lies within the
    bounds but off that grid (7.6 on a 0.5 grid from 4), at the first point at or above ``low`` of the
    grid through the base's value, so that the base is a trial like any other."""
    if fr.step is None or fr.choices is not None or not isinstance(base, (int, float)) or isinstance(base, bool):
        return fr.low
    if not fr.low <= base <= fr.high:
        return fr.low
    n = (base - fr.low) / fr.step
    if abs(n - round(n)) < 1e-9:
        return fr.low
    return base - math.floor(n) * fr.step


def distributions(loaded: Loaded) -> dict:
    optuna = _optuna()
    out = {}
    for fr, b in zip(loaded.free, loaded.base_values):
        if fr.choices is not None:
            out[fr.path] = optuna.distributions.CategoricalDistribution(fr.choices)
            continue
        low = grid_low(fr, b)
        high = fr.high if fr.step is None else round(low + math.floor((fr.high - low) / fr.step + 1e-9) * fr.step, 9)
        if fr.integer:
            out[fr.path] = optuna.distributions.IntDistribution(int(low), int(round(high)), log=fr.log,
                                                                step=int(fr.step or 1))
        else:
            out[fr.path] = optuna.distributions.FloatDistribution(low, high, log=fr.log, step=fr.step)
    return out


def sampler(loaded: Loaded, told: int):
    """The sampler for this tune (see the module's docstring); seeded with the tune's seed and the
    number of trials already told, so a resumed tune does not draw its first trials again."""
    optuna = _optuna()
    kind = loaded.spec.sampler
    seed = loaded.spec.seed + told
    multi = len(loaded.objectives) > 1
    if kind == "auto":
        kind = "nsga2" if multi else "tpe"
    budget = loaded.spec.budget
    if kind == "random":
        return optuna.samplers.RandomSampler(seed=seed)
    if kind == "nsga2":
        return optuna.samplers.NSGAIISampler(population_size=max(8, min(50, budget // 6)), seed=seed)
    # a tenth of the budget drawn at random first (at least 4): the first basins found are TPE's to
    # refine, and with a dozen free parameters ten random trials leave most of them unseen (tune-stiffness:
    # where 40 drew no design of its one feasible island, TPE spent the rest short of it). Each parameter
    # modelled on its own (TPE's independent mode): modelled jointly, TPE settled within a hundred
    # trials on one set of whole numbers and choices (a helix's half turns, phases) and spent the
    # rest there, feasible or not (six runs of tune-stiffness.yaml: 85-95 % of the trials in one
    # such set); on its own, each parameter keeps the values that worked anywhere, and the trials
    # recombine them (tune-stiffness: 128 feasible trials in 600 against none)
    return optuna.samplers.TPESampler(n_startup_trials=max(4, budget // 10), multivariate=False,
                                      constant_liar=True, seed=seed)


def open_study(loaded: Loaded, folder: Path):
    """The tune's study from its journal (made when there is none). Trials left running by an
    interrupted run are marked failed and asked again (queued with their parameters)."""
    optuna = _optuna()
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend
    from optuna.trial import TrialState

    storage = JournalStorage(JournalFileBackend(str(folder / JOURNAL)))
    name = loaded.spec.tune
    directions = [how for _, how in loaded.objectives]
    known = {s.study_name for s in storage.get_all_studies()}
    if name in known:
        study = optuna.load_study(study_name=name, storage=storage)
        if study.user_attrs.get("digest") != loaded.digest:
            raise InputError(loaded.source, "", f"{folder} holds the trials of another tune (its base, set, free, "
                                                f"goal, level or robust_samples differ): move that folder away or "
                                                f"give this tune another name")
    else:
        study = optuna.create_study(study_name=name, storage=storage, directions=directions)
        study.set_user_attr("digest", loaded.digest)
    told = len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)))
    study.sampler = sampler(loaded, told)
    for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        study.tell(t.number, state=TrialState.FAIL)
        study.enqueue_trial(t.params, skip_if_exists=False)
    return study


def enqueue_base(loaded: Loaded, study, base: dict) -> None:
    """The base as the first trial of a new study: the search starts from what works. A pre-tension
    the base leaves to the protocol takes the tension the protocol sets it to in the goal's state
    (the base row's ``set_n``), the next up on its grid; any other value the base leaves unset or
    has outside the bounds is drawn."""
    if study.get_trials(deepcopy=False):
        return
    dists = distributions(loaded)
    set_n = (base.get("set_n") or {}).get(loaded.state) or {}
    start = {}
    for n, v in zip(loaded.names, loaded.base_values):
        if v is None and n.endswith(".pretension_n"):
            i = parse_path(n)[1]
            v = _on_grid(dists[n], set_n.get(loaded.base["tendons"][i].get("name")))
        if _within(dists[n], v):
            start[n] = v
    if start:
        study.enqueue_trial(start)


def _on_grid(dist, v):
    """The least value of a number distribution at or above ``v`` (None for None): a tension no
    lower than the protocol's (the prototype's base sits on its own torsion bound, and 12.5 N for
    the protocol's 12.63 N left trial 0 0.4 % short of it)."""
    if v is None or getattr(dist, "choices", None) is not None:
        return None
    v = min(max(float(v), dist.low), dist.high)
    step = getattr(dist, "step", None)
    return v if step is None else round(min(dist.low + math.ceil((v - dist.low) / step - 1e-9) * step, dist.high), 9)


def constraint_names(loaded: Loaded) -> list[str]:
    g = loaded.spec.goal
    return ["checks", *(f"{n} >= {b}" for n, b in g.at_least.items()), *(f"{n} <= {b}" for n, b in g.at_most.items())]


def _within(dist, v) -> bool:
    """Whether a value is one the sampler may draw from a free parameter's distribution (within its
    bounds, on its grid, a choice among the choices)."""
    if v is None:
        return False
    try:
        return bool(dist._contains(dist.to_internal_repr(v)))
    except (ValueError, TypeError):
        return False


def score(loaded: Loaded, row: dict, base_row: dict | None,
          margin: float = 0.0) -> tuple[list[float], list[float], bool]:
    """(objective values, constraint values, feasible) of an evaluated row (see the module's
    docstring); an objective the row lacks takes the base's value (told as infeasible anyway).
    ``margin``: each bound of the goal taken that much further (relative), as the sampler is told
    them (:data:`SEARCH_MARGIN`); feasible is then by the bounds so moved."""
    g = loaded.spec.goal
    state = loaded.state
    if row["verdict"] in ("bad input", "error"):
        checks = BAD
    else:
        checks = 0.0
        for f in map(Failure.of, row.get("failures") or []):
            if g.binds(f):
                checks += _violation(f)
    bounds = []
    for how, sign in (("at_least", 1.0), ("at_most", -1.0)):
        for name, bound in getattr(g, how).items():
            if bound == "base":
                bound = results.value(name, base_row or {}, state)
            v = results.value(name, row, state)
            if bound is None or v is None:
                bounds.append(BAD)          # a bound not measured is not met (run() refuses a base without it)
                continue
            short = sign * (bound - v) / max(abs(bound), 1e-12) + margin
            bounds.append(max(0.0, short))
    values = []
    for name, _ in loaded.objectives:
        v = results.value(name, row, state)
        if v is None or not math.isfinite(v):
            v = results.value(name, base_row or {}, state)
        values.append(float(v) if v is not None and math.isfinite(v) else 0.0)
    cons = [checks, *bounds]
    return values, cons, all(c <= 0 for c in cons)


def bound_limits(loaded: Loaded, base_row: dict) -> list[tuple[str, float, float]]:
    """(result, +1 for at least / -1 for at most, the bound's value) of each statics bound of the goal
    (``base``: the base's own figure), for :func:`short_of_bounds` on a worker."""
    g = loaded.spec.goal
    state = loaded.state
    out = []
    for how, sign in (("at_least", 1.0), ("at_most", -1.0)):
        for name, bound in getattr(g, how).items():
            if not results.is_statics(name):
                continue
            if bound == "base":
                bound = results.value(name, base_row, state)
            if bound is not None:
                key = name if "@" in name else f"{name}@{state}"
                out.append((key, sign, float(bound)))
    return out


def short_of_bounds(limits: list[tuple[str, float, float]], row: Row) -> bool:
    """Whether a row's statics already miss a bound of the goal (the worker's ``stop``: such a trial
    is infeasible whatever its checks say, so the checks after the statics are not run)."""
    got = row.figures.get("statics") or {}
    return any(key in got and sign * (bound - got[key]) > 0 for key, sign, bound in limits)


def _violation(f: Failure | dict) -> float:
    """How far past its limit a failed check is, relative to the limit (at most EXCESS_CAP; at least
    MIN_EXCESS, so that a check failed at its limit still counts); one that measures nothing (two
    eyelets that merge) counts UNMEASURED, as far past as a value twice its limit."""
    f = Failure.of(f)
    m, lim = f.measured, f.limit
    if not isinstance(m, (int, float)) or not isinstance(lim, (int, float)) or not math.isfinite(m):
        return UNMEASURED
    return min(max(abs(m - lim) / max(abs(lim), 1e-9), MIN_EXCESS), EXCESS_CAP)


def _plain(v):
    if isinstance(v, Failure):
        return v.to_json()
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, (tuple, set)):
        return list(v)
    return str(v)


def _options(loaded: Loaded, folder: Path, cache, p) -> EvalOptions:
    g = loaded.spec.goal
    return EvalOptions(
        robust_samples=loaded.spec.robust_samples, out=str(folder), cache=cache,
        # a trial that fails its level's screening stops there; not at the build level, whose verdict is
        # hwgen check's (eq. (2) through the hole centres is information there, not a failure)
        screen=g.checks == "all" and loaded.spec.level in ("robust", "coupling"),
        with_plan=partial(results.statics, states=loaded.states, orientation=g.orientation, friction=g.friction,
                          judge=judges_stiffening(g)) if loaded.states else None,
        numba_threads=1 if p.client is not None else None)      # a worker has a core of its own


def judges_stiffening(goal) -> bool:
    """Whether a goal's trials must pass what the stiffening tendons are for (``stiffening.tip``,
    ``.torsion``: errors ``hwgen check`` fails a build by), screened with the statics: every check
    passing, or either under ``require``."""
    return goal.checks == "all" or any(c.startswith("stiffening.") for c in goal.require)


def _finish(loaded: Loaded, row: Row, values: tuple) -> dict:
    """A worker's row made plain (JSON: :meth:`~hwgen.sweep.records.Row.to_json`), with the trial's
    distance from the base."""
    row = json.loads(json.dumps(row.to_json(), default=_plain))
    row["distance"] = distance(loaded, values)
    row["values"] = list(values)
    return row


def _base_figures(loaded: Loaded, base: dict, made: Path | None) -> None:
    """InputError naming the goal's field when a bound of ``base`` has no base figure to bound by
    (the base is bad input, or its evaluation failed): such a bound cannot be met or judged. A
    folder this run made is removed first: bad input writes nothing."""
    g = loaded.spec.goal
    for how in ("at_least", "at_most"):
        for name, bound in getattr(g, how).items():
            if bound == "base" and results.value(name, base, loaded.state) is None:
                if made is not None:
                    shutil.rmtree(made, ignore_errors=True)
                raise InputError(loaded.source, f"goal.{how}.{name}",
                                 f"the base design gives no {name} to bound by (its evaluation: {base['verdict']}"
                                 f"{': ' + base['message'] if base.get('message') else ''}): give a number, or "
                                 f"a base that evaluates")


def base_row(loaded: Loaded, study, p, options: EvalOptions) -> dict:
    """The base design evaluated like a trial (kept in the study: a resumed tune reads it back)."""
    if "base_row" in study.user_attrs:
        return study.user_attrs["base_row"]
    fut = p.submit(levels.evaluate_batch, [(-1, loaded.base_values)], loaded.base, loaded.names, loaded.spec.level,
                   frozenset(), options, key=f"tune-{loaded.spec.tune}-base-{uuid.uuid4().hex[:6]}")
    row = _finish(loaded, fut.result()[0], loaded.base_values)
    row["trial"] = -1
    study.set_user_attr("base_row", row)
    return row


def _folder(loaded: Loaded, out_root: Path) -> tuple[Path, Path | None]:
    """The tune's folder, made here, and the outermost folder this made (None: it was there)."""
    folder = folder_of(loaded, out_root)
    made = None if folder.exists() else folder
    while made is not None and not made.parent.exists():
        made = made.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(out_root, "--out", f"cannot write the results here ({e.strerror or e})") from None
    return folder, made


class _Search:
    """One run's ask-evaluate-tell loop. Trials are asked ahead of the last told by a fixed lag (the
    pool's tasks in flight times the trials a task) and told in the order they were asked, whatever
    order the workers finish them in: the trial asked n-th is asked right after the (n - lag)-th is
    told, so the sampler sees the same trials at every ask and a seed draws the same trials however
    the workers' timing falls (with two workers and constant liar, telling in completion order made
    two runs of one seed part at trial 21). A design already evaluated (by hash) takes that result,
    and one asked while its twin is in flight waits for it. A share of the trials (:data:`LOCAL_SHARE`)
    is a move from the incumbent (:mod:`hwgen.tune.local`) instead of the sampler's draw."""

    def __init__(self, loaded: Loaded, study, p, options: EvalOptions, base: dict, out: Outcome, by_hash: dict,
                 on_trial=None):
        self.loaded, self.study, self.p, self.options, self.base, self.out = loaded, study, p, options, base, out
        self.by_hash, self.on_trial = by_hash, on_trial
        self.dists = distributions(loaded)
        self.told = out.done_before
        self.doc = p.scatter(loaded.base)
        self.per_task = TRIALS_PER_TASK[loaded.spec.level]
        self.cap = loaded.spec.batch or (2 * p.workers if p.client is not None else 1)   # inline: one at a time
        self.lag = self.cap * self.per_task
        self.ac = p.completed()
        self.asked: deque = deque()                  # trials asked and not yet told, in the order asked
        self.ready: dict[int, tuple] = {}            # trial number -> (row, same as) to tell in its turn
        self.unsent: list = []                       # [(trial, values, hash)] asked, not yet on a worker
        self.flying: dict[str, list] = {}            # task key -> [(trial, values, hash)]
        self.waiting: dict[str, list] = {}           # hash in flight -> trials of the same design asked meanwhile
        self.best = None
        self.moves = _Moves(loaded, study, self.dists, base)
        self.t0 = time.perf_counter()

    def tell(self, trial, row: dict, same_as: int | None = None) -> None:
        loaded, out = self.loaded, self.out
        values, cons, ok = score(loaded, row, self.base)
        trial.set_user_attr("row", row)
        trial.set_user_attr("constraints", cons)
        for label, c in zip(constraint_names(loaded), score(loaded, row, self.base, SEARCH_MARGIN)[1]):
            trial.set_constraint(label, c)           # the sampler's: each bound a margin further
        trial.set_user_attr("feasible", ok)
        if same_as is not None:
            trial.set_user_attr("same_as", same_as)
        self.study.tell(trial, values)
        self.told += 1
        self.moves.saw(trial.params, values, cons, ok)
        out.verdicts[row["verdict"]] = out.verdicts.get(row["verdict"], 0) + 1
        if ok and len(values) == 1:
            sign = 1 if loaded.objectives[0][1] == "maximize" else -1
            if self.best is None or sign * values[0] > sign * self.best:
                self.best = values[0]
                out.first_best_s = time.perf_counter() - self.t0
        if self.on_trial:
            self.on_trial(self.told, out.budget)

    def ask(self) -> None:
        """Ask one trial: told at once where its design is known, queued behind its twin in flight, or
        kept to be sent."""
        loaded = self.loaded
        trial = self.moves.ask()
        values = tuple(trial.params[n] for n in loaded.names)
        h = resolve(loaded.base, loaded.names, Variant(trial.number, values)).hash
        self.asked.append(trial)
        if h in self.by_hash:
            self.out.repeated += 1
            known = self.by_hash[h]
            self.ready[trial.number] = (dict(known, values=list(values), distance=distance(loaded, values)),
                                        known.get("trial"))
        elif h in self.waiting:
            self.waiting[h].append((trial, values))
        else:
            self.waiting[h] = []
            self.unsent.append((trial, values, h))

    def advance(self) -> None:
        """Ask up to the lag ahead, and tell the oldest trial whenever its result is in; an ask first,
        so that each ask follows the same tells whatever the timing."""
        while True:
            if len(self.asked) < self.lag and self.told + len(self.asked) < self.out.budget:
                self.ask()
            elif self.asked and self.asked[0].number in self.ready:
                trial = self.asked.popleft()
                self.tell(trial, *self.ready.pop(trial.number))
            else:
                return

    def send(self) -> None:
        """Send the trials asked to the workers, a task of at most ``per_task`` trials at a time, while
        fewer than ``cap`` tasks are in flight."""
        loaded = self.loaded
        while self.unsent and len(self.flying) < self.cap:
            batch, self.unsent = self.unsent[:self.per_task], self.unsent[self.per_task:]
            key = f"tune-{loaded.spec.tune}-{batch[0][0].number}-{uuid.uuid4().hex[:6]}"
            self.flying[key] = batch
            self.ac.add(self.p.submit(levels.evaluate_batch, [(t.number, v) for t, v, _ in batch], self.doc,
                                      loaded.names, loaded.spec.level, frozenset(), self.options, key=key))

    def collect(self, fut) -> None:
        """The rows of a finished task (and of their twins that waited), each to be told in its turn."""
        batch = self.flying.pop(fut.key)
        rows = {r.variant: r for r in fut.result()}
        fut.release()
        out = self.out
        for trial, values, h in batch:
            row = _finish(self.loaded, rows[trial.number], values)
            row["trial"] = trial.number
            out.evaluated += 1
            out.cpu_s += row.get("cpu_s") or 0.0
            if row["verdict"] in ("pass", "fail") and not row.get("screened"):
                out.whole += 1
                out.whole_cpu_s += row.get("cpu_s") or 0.0
            self.by_hash[h] = row
            self.ready[trial.number] = (row, None)
            for twin, v in self.waiting.pop(h, []):
                out.repeated += 1
                self.ready[twin.number] = (dict(row, values=list(v), distance=distance(self.loaded, v)), trial.number)

    def run(self) -> None:
        self.advance()
        self.send()
        for fut in self.ac:
            self.collect(fut)
            self.advance()
            self.send()


class _Moves:
    """Where each trial comes from: the trials an interrupted run left (queued in the study) first,
    then a move from the incumbent (:func:`hwgen.tune.local.neighbour`) for a :data:`LOCAL_SHARE`
    of them (drawn with the tune's seed), the sampler's draw for the rest. The incumbent is the best
    feasible trial told, the base itself (trial -1) first when it passes: its values, and those it
    leaves unset (a pre-tension the protocol sets) drawn by the sampler at each move (the prototype's
    base sits on its own torsion bound, and trial 0, its protocol tensions on the grid, 0.3 % under
    it: 109 moves from trial 0 found nothing that passes); while none is feasible, the trial nearest
    feasibility (the least sum of its constraints). A share of the moves from a passing design changes
    one tendon's every value (:data:`hwgen.tune.local.WHOLE_TENDON`); a share (:data:`REPAIR_SHARE`)
    starts from the stiffest near miss, and a share (:data:`RESTART_SHARE`) from another of the
    :data:`TOP_K` best passing trials (:meth:`start`). No moves for a front or for the random baseline,
    nor once feasible trials are no longer scarce (:meth:`scarce`)."""

    def __init__(self, loaded: Loaded, study, dists: dict, base: dict):
        from optuna.trial import TrialState
        self.study, self.dists = study, dists
        self.queued = len(study.get_trials(deepcopy=False, states=(TrialState.WAITING,)))
        multi = len(loaded.objectives) > 1
        self.share = 0.0 if multi or loaded.spec.sampler in ("random", "nsga2") else LOCAL_SHARE
        self.sign = 1.0 if loaded.objectives[0][1] == "maximize" else -1.0
        told = len(study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)))
        self.rng = np.random.default_rng([loaded.spec.seed, told, 44])
        self.incumbent: tuple | None = None          # (feasible, rank, params)
        self.top: list[tuple[float, dict]] = []      # the best passing trials told: (rank, params), best first
        self.near: tuple[float, dict] | None = None  # the stiffest near miss told (:data:`NEAR_MISS`): (rank, params)
        self.tensions = [n for n in dists if n.endswith(".pretension_n")] or None
        self.told = self.passed = 0
        values, cons, ok = score(loaded, base, base)
        if ok:
            self.incumbent = (True, self.sign * values[0],
                              {n: v for n, v in zip(loaded.names, loaded.base_values) if _within(dists[n], v)})
        for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
            self.saw(t.params, t.values, t.user_attrs.get("constraints") or [BAD], bool(t.user_attrs.get("feasible")))

    def saw(self, params: dict, values, cons, ok: bool) -> None:
        self.told += 1
        self.passed += ok
        rank = self.sign * values[0] if ok else -sum(cons)
        if len(params) != len(self.dists):
            return
        if self.incumbent is None or (ok, rank) > self.incumbent[:2]:
            self.incumbent = (ok, rank, dict(params))
        if ok and all(p != params for _, p in self.top):
            self.top = sorted([*self.top, (rank, dict(params))], key=lambda e: -e[0])[:TOP_K]
        near = self.sign * values[0]
        if not ok and cons[0] <= 0 and sum(cons[1:]) <= NEAR_MISS and (self.near is None or near > self.near[0]):
            self.near = (near, dict(params))

    def start(self) -> tuple[bool, dict, list | None]:
        """(whether it passes, the values, the names a move may change: None for any) of the design the
        next move starts from: the incumbent; for a :data:`REPAIR_SHARE` of the moves, the stiffest near
        miss when it is stiffer than the incumbent (its pre-tensions, where it has any, to move);
        for a :data:`RESTART_SHARE`, another of the :data:`TOP_K` best passing trials."""
        r = self.rng.random()
        if self.incumbent[0] and self.near is not None and self.near[0] > self.incumbent[1] and r < REPAIR_SHARE:
            return False, self.near[1], self.tensions
        if len(self.top) > 1 and r >= 1 - RESTART_SHARE:
            return True, self.top[1 + int(self.rng.integers(len(self.top) - 1))][1], None
        return self.incumbent[0], self.incumbent[2], None

    def scarce(self) -> bool:
        """Whether feasible trials are still scarce (:data:`FEASIBLE_ENOUGH`): moves while they are."""
        return 0 < self.told and self.passed < FEASIBLE_ENOUGH * self.told      # none before the first result

    def ask(self):
        if self.queued > 0:
            self.queued -= 1
        elif self.share > 0 and self.incumbent is not None and self.scarce() and self.rng.random() < self.share:
            ok, values, among = self.start()
            # toward feasibility, one value at a time
            most, whole = (local.MOST_CHANGED, local.WHOLE_TENDON) if ok else (1, 0.0)
            self.study.enqueue_trial(local.neighbour(self.dists, values, self.rng, most, whole, among),
                                     user_attrs={"move": True}, skip_if_exists=False)
        return self.study.ask(self.dists)


def run(loaded: Loaded, out_root: Path, scheduler: str | None = None, workers: int | None = None,
        budget: int | None = None, cache=True, on_trial=None) -> tuple[Outcome, object]:
    """Run the tune up to ``budget`` trials told in all (default: the tune file's); returns the
    outcome and the study. ``on_trial(done, budget)`` is called as each trial is told."""
    from optuna.trial import TrialState

    folder, made = _folder(loaded, out_root)
    budget = budget or loaded.spec.budget
    study = open_study(loaded, folder)
    complete = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    by_hash = {t.user_attrs["row"]["hash"]: t.user_attrs["row"] for t in complete if "row" in t.user_attrs}
    out = Outcome(folder=folder, budget=budget, done_before=len(complete), evaluated=0, repeated=0, seconds=0.0,
                  workers=1, start_seconds=0.0, cpu_s=0.0)
    with pool(scheduler, workers) as p:
        out.workers, out.start_seconds = p.workers, p.start_seconds
        options = _options(loaded, folder, cache, p)
        t0 = time.perf_counter()
        base = base_row(loaded, study, p, options)
        _base_figures(loaded, base, made)
        if options.screen and loaded.spec.level != "lengths":
            limits = bound_limits(loaded, base)
            if limits:
                options = replace(options, stop=partial(short_of_bounds, limits))
        by_hash.setdefault(base["hash"], base)
        enqueue_base(loaded, study, base)
        search = _Search(loaded, study, p, options, base, out, by_hash, on_trial)
        search.t0 = t0
        search.run()
        out.seconds = time.perf_counter() - t0
    return out, study
