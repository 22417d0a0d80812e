"""What a tune leaves in ``OUT/tunes/<name>/``: trials.parquet, best.yaml, summary.md, convergence.png.

- ``trials.parquet``: every trial told, one row each: ``trial``, ``hash``, one column per free
  parameter, ``verdict``, ``feasible``, ``violation`` (the sum of its constraint values), one
  column per objective and per bound, ``distance`` (from the base), ``failed_checks`` (JSON: each
  failing or warning check's id, severity, measured value and limit), ``same_as`` (the trial whose
  evaluation of the same design it was told), ``move`` (a move from the incumbent, not the sampler's
  draw: :mod:`hwgen.tune.local`), ``message``, ``cpu_s``. Trial -1 is the base.
- ``best.yaml``: the base design's file with only the tuned values (and the tune file's ``set``)
  changed, its comments kept (ruamel.yaml's round trip), and its ``design`` named
  ``<design>-<tune>`` so that its build does not replace the base's.
- ``summary.md``: the best against the base, which parameters mattered (Optuna's PED-ANOVA
  importance over the feasible trials), the front when there are several objectives, and, when
  no trial passes, which constraints bind.
- ``convergence.png``: each trial's objective and the best so far (one objective), or the first two
  objectives with the front drawn (several).
"""
from __future__ import annotations

import copy
import io
import json
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from .. import designfile
from ..atomic import atomic_path, write_text
from ..outputs.plots import pyplot, save
from ..params import SAFE_NAME
from ..sweep import spec as sweep_spec
from ..sweep.records import Failure
from . import results
from .spec import Loaded

TOP_FAILURES = 8


def trials(study) -> list[dict]:
    """The told trials, in order, each as its row with the trial's number, values and verdicts."""
    from optuna.trial import TrialState
    out = []
    for t in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
        row = dict(t.user_attrs.get("row") or {})
        row.update(trial=t.number, objectives=list(t.values), constraints=t.user_attrs.get("constraints", []),
                   feasible=bool(t.user_attrs.get("feasible")), same_as=t.user_attrs.get("same_as"),
                   move=bool(t.user_attrs.get("move")))
        out.append(row)
    return out


def base(loaded: Loaded, study) -> dict:
    from .run import score
    row = dict(study.user_attrs["base_row"])
    values, cons, ok = score(loaded, row, row)
    row.update(trial=-1, objectives=values, constraints=cons, feasible=ok, same_as=None)
    return row


def bounds(loaded: Loaded) -> list[str]:
    g = loaded.spec.goal
    return [f"{name} ≥ {b}" for name, b in g.at_least.items()] + [f"{name} ≤ {b}" for name, b in g.at_most.items()]


def best(loaded: Loaded, rows: list[dict], rejected=()) -> tuple[dict | None, list[dict]]:
    """(the best feasible trial, the front): one objective, the best value (ties: the earlier
    trial); several, the feasible trials no other feasible trial dominates, and as the best the
    front's best in the first objective. Designs whose hash is in ``rejected`` (their build failed
    a check) are left out."""
    signs = [1.0 if how == "maximize" else -1.0 for _, how in loaded.objectives]
    ok = [r for r in rows if r["feasible"] and r.get("hash") not in rejected]
    if not ok:
        return None, []

    def key(r):
        return [s * v for s, v in zip(signs, r["objectives"])]
    front = [r for r in ok if not any(all(a >= b for a, b in zip(key(o), key(r))) and key(o) != key(r) for o in ok)]
    seen, uniq = set(), []
    for r in sorted(front, key=lambda r: (-key(r)[0], r["trial"])):
        if r["hash"] not in seen:
            seen.add(r["hash"])
            uniq.append(r)
    return uniq[0], uniq


# ---------------------------------------------------------------- trials.parquet

def table(loaded: Loaded, rows: list[dict]) -> pa.Table:
    state = loaded.state
    cols: dict[str, list] = {"trial": [], "hash": []}
    for n in loaded.names:
        cols[n] = []
    objectives = [n for n, _ in loaded.objectives if n != "distance"]      # distance: its own column
    extra = ["verdict", "feasible", "violation", *objectives, *bounds(loaded), "distance",
             "failed_checks", "same_as", "move", "message", "cpu_s"]
    for c in extra:
        cols[c] = []
    g = loaded.spec.goal
    bound_names = [*g.at_least, *g.at_most]
    for r in rows:
        cols["trial"].append(r["trial"])
        cols["hash"].append(r.get("hash"))
        for n, v in zip(loaded.names, r.get("values") or [None] * len(loaded.names)):
            cols[n].append(v)
        cols["verdict"].append(r.get("verdict"))
        cols["feasible"].append(r["feasible"])
        cols["violation"].append(float(sum(r["constraints"])))
        for (n, _), v in zip(loaded.objectives, r["objectives"]):
            if n != "distance":
                cols[n].append(v if results.value(n, r, state) is not None else None)
        for label, n in zip(bounds(loaded), bound_names):
            cols[label].append(results.value(n, r, state))
        cols["distance"].append(r.get("distance"))
        cols["failed_checks"].append(json.dumps(r.get("failures") or []))
        cols["same_as"].append(r.get("same_as"))
        cols["move"].append(bool(r.get("move")))
        cols["message"].append(r.get("message"))
        cols["cpu_s"].append(r.get("cpu_s"))
    arrays = {}
    for name, vals in cols.items():
        if name in loaded.names and any(isinstance(v, str) or isinstance(v, bool) for v in vals if v is not None):
            vals = [None if v is None else json.dumps(v) for v in vals]
        arrays[name] = pa.array(vals, type=pa.float64() if name in _floats(loaded) else None)
    return pa.table(arrays)


def _floats(loaded: Loaded) -> set[str]:
    return {*(n for n, _ in loaded.objectives), *bounds(loaded), "distance", "violation", "cpu_s"}


def write_trials(loaded: Loaded, rows: list[dict], path: Path) -> None:
    with atomic_path(path) as tmp:
        pq.write_table(table(loaded, rows), tmp)


# ---------------------------------------------------------------- best.yaml

def best_yaml(loaded: Loaded, row: dict) -> str:
    """The base file's text with the ``set`` and the trial's values put in, its comments kept, and
    its design renamed ``<design>-<tune>``."""
    from ruamel.yaml import YAML
    y = YAML()                     # round trip: comments, order and quoting kept
    y.preserve_quotes = True
    y.width = 4096
    y.indent(mapping=2, sequence=4, offset=2)     # hwgen's files: list items two in, their keys four
    doc = y.load(loaded.base_path.read_text())
    changes = dict(loaded.spec.set)
    changes.update((n, v) for n, v, b in zip(loaded.names, row["values"], loaded.base_values) if v != b)
    layered = "base" in doc
    if layered:                    # best.yaml lives elsewhere: its base named where it is
        doc["base"] = str(designfile.base_file(loaded.base_path, doc["base"]).resolve())
    for path, value in changes.items():
        _put(doc, sweep_spec.parse_path(path), value, loaded.base, layered)
    name = f"{doc['design']}-{loaded.spec.tune}"
    doc["design"] = name if SAFE_NAME.match(name) else f"tuned-{loaded.spec.tune}"
    buf = io.StringIO()
    y.dump(doc, buf)
    head = (f"# hwgen tune {loaded.spec.tune}: {loaded.base_path.name} with the tuned values (trial "
            f"{row['trial']}) and the tune file's 'set' changed; renamed so that its build does not replace the "
            f"base's\n")
    return head + buf.getvalue()


def _put(doc, keys: list, value, merged: dict, layered: bool) -> None:
    """Set (or, for None, drop) the value at ``keys`` in a round-trip document, making the mappings
    on the way (a mapping merges with its base's; a list the file leaves to its base is copied
    whole from the merged design ``merged``); a float that is a whole number stays a float only where the optimiser gave one.
    In a file with a base, None is written as null (it removes the base's value)."""
    node = doc
    for n, (k, nxt) in enumerate(zip(keys, keys[1:])):
        if isinstance(k, int):
            node = node[k]
        else:
            if k not in node or node[k] is None:
                try:
                    there = designfile.value_at(merged, keys[:n + 1])
                except KeyError:
                    there = None
                node[k] = copy.deepcopy(there) if isinstance(there, list) else [] if isinstance(nxt, int) else {}
            node = node[k]
    last = keys[-1]
    if value is None:
        if layered:
            node[last] = None
        elif not isinstance(last, int) and last in node:
            del node[last]
        return
    if isinstance(value, float):
        value = round(value, 6)
    node[last] = value


# ---------------------------------------------------------------- summary.md

def _fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v).replace("|", "\\|")


def importances(loaded: Loaded, rows: list[dict]) -> dict[str, dict[str, float]] | str:
    """Each objective's parameter importances (PED-ANOVA) over the feasible trials, or why there are none."""
    import optuna
    from optuna.importance import PedAnovaImportanceEvaluator
    from .run import distributions
    ok = [r for r in rows if r["feasible"] and r.get("same_as") is None]
    if len(ok) < 4:
        return f"{len(ok)} feasible trials of their own: too few to say which parameters mattered"
    dists = distributions(loaded)
    study = optuna.create_study(directions=[how for _, how in loaded.objectives])
    study.add_trials([optuna.trial.create_trial(params=dict(zip(loaded.names, r["values"])), distributions=dists,
                                                values=r["objectives"]) for r in ok])
    out = {}
    for i, (name, _) in enumerate(loaded.objectives):
        try:
            imp = optuna.importance.get_param_importances(
                study, evaluator=PedAnovaImportanceEvaluator(), target=lambda t, i=i: t.values[i])
        except (RuntimeError, ValueError) as e:
            return f"not computed ({e})"
        out[name] = dict(imp)
    return out


def markdown(loaded: Loaded, rows: list[dict], base_row: dict, outcome=None, built: dict | None = None,
             stiffness: dict | None = None, rejected=None) -> str:
    rejected = rejected or {}
    best_row, front = best(loaded, [base_row, *rows], rejected)       # the base is a candidate like any trial
    g = loaded.spec.goal
    goal = "pass every check, nearest the base" if g.pass_ else ", ".join(f"{how} {n}" for n, how in
                                                                          loaded.objectives)
    n_ok = sum(r["feasible"] for r in rows)
    base_ok = bool(base_row["feasible"])
    lines = [f"# Tune {loaded.spec.tune}", "",
             f"Base design: `{loaded.base_path.name}`" + (f" with {', '.join(f'`{k}`' for k in loaded.spec.set)} set"
                                                         if loaded.spec.set else "") + f"; level {loaded.spec.level}; "
             f"goal: {goal}" + (f", subject to {', '.join(bounds(loaded))}" if bounds(loaded) else "")
             + (f"; required even as warnings: {', '.join(g.require)}" if g.require else "") + ".", "",
             *([f"Statics (the study `hwgen stiffness` runs, the plan's estimated masses): state "
                f"{loaded.state}, {g.orientation}, eyelets "
                f"{'frictionless' if g.friction == 'none' else 'stuck (every segment held at its eyelets)'}; each "
                f"tendon tensioned by the paper's protocol, or at its own `pretension_n` where the design gives one.",
                ""] if loaded.states else []),
             f"{len(rows)} trials told, {n_ok} feasible (the base, trial -1, "
             f"{'feasible' if base_ok else 'infeasible'} besides), "
             f"{sum(1 for r in rows if r.get('same_as') is not None)} told from an earlier trial of the same design."]
    if outcome is not None:
        lines += ["", f"This run: {outcome.evaluated} trials evaluated in {outcome.seconds:.1f} s on "
                      f"{outcome.workers} worker(s) ({outcome.cpu_s / max(outcome.evaluated, 1):.2f} s of CPU a "
                      f"trial)" + (f"; the best found {outcome.first_best_s:.1f} s in" if outcome.first_best_s
                                   else "") + "."]
    lines += ["", "## The best against the base", ""]
    if best_row is None:
        lines += ["No trial passes. " + binding(loaded, rows)]
    else:
        state = loaded.state
        who = "The base itself (trial -1): no trial passes further" if best_row["trial"] < 0 else f"Trial {best_row['trial']}"
        lines += [f"{who} (`best.yaml`).", "", "| | base | best |", "|---|---:|---:|"]
        for n, b, v in zip(loaded.names, loaded.base_values, best_row["values"]):
            lines.append(f"| `{n}` | {_fmt(b)} | {_fmt(v)} |")
        shown = [n for n, _ in loaded.objectives] + [*g.at_least, *g.at_most]
        for n in dict.fromkeys(shown + ["coupling", "least_tension_n", "mass_g"]):
            if results.check_name(n, loaded.spec.level, ("",))[0] and not results.is_statics(n):
                continue
            lines.append(f"| {n} | {_fmt(results.value(n, base_row, state))} | "
                         f"{_fmt(results.value(n, best_row, state))} |")
        lines.append(f"| verdict ({loaded.spec.level}) | {base_row['verdict']} | {best_row['verdict']} |")
    fails = [f.id for f in map(Failure.of, base_row.get("failures") or []) if f.fails or f.id in g.require]
    if fails:
        lines += ["", "The base fails: " + ", ".join(sorted(set(fails))) + "."]
    if built:
        lines += ["", "## The best, built", "", built["text"]]
    if rejected:
        lines += ["", f"Set aside after their build ({len(rejected)}; the tune's level does not screen for what "
                      f"failed): " + "; ".join(f"`{h[:12]}` {', '.join(ids)}" for h, ids in rejected.items()) + "."]
    if stiffness:
        lines += ["", f"## Stiffness per tendon state (hwgen stiffness: the plan's masses; {g.orientation}, "
                      f"friction {g.friction})", "",
                  "| state | tip N/mm, base | tip N/mm, best | least N/mm, base | least N/mm, best | "
                  "torsion N·mm/rad, base | torsion, best |", "|---|---:|---:|---:|---:|---:|---:|"]
        for s in stiffness["base"]:
            b = stiffness["best"].get(s)
            a = stiffness["base"][s]
            lines.append(f"| {s} | {a['tip_stiffness']:.4f} | {b['tip_stiffness']:.4f} | {a['least_stiffness']:.4f} |"
                         f" {b['least_stiffness']:.4f} | {a['tip_torsion']:.0f} | {b['tip_torsion']:.0f} |")
    lines += ["", "## Which parameters mattered", ""]
    imp = importances(loaded, rows)
    if isinstance(imp, str):
        lines.append(imp + ".")
    else:
        lines += ["PED-ANOVA importance (Optuna's `PedAnovaImportanceEvaluator`: how much each parameter's distribution in the best 10 % differs from all) over the feasible trials, per objective:",
                  "", "| parameter | " + " | ".join(imp) + " |", "|---|" + "---:|" * len(imp)]
        for n in loaded.names:
            lines.append(f"| `{n}` | " + " | ".join(f"{imp[o].get(n, 0.0):.2f}" for o in imp) + " |")
    if len(loaded.objectives) > 1:
        lines += ["", f"## The front ({len(front)} designs no feasible trial beats in every objective)", "",
                  "| trial | " + " | ".join(loaded.names) + " | " + " | ".join(n for n, _ in loaded.objectives) + " |",
                  "|---|" + "---:|" * (len(loaded.names) + len(loaded.objectives))]
        for r in front[:50]:
            lines.append(f"| {r['trial']} | " + " | ".join(_fmt(v) for v in r["values"]) + " | "
                         + " | ".join(_fmt(v) for v in r["objectives"]) + " |")
    if best_row is not None:
        lines += bound_fronts(loaded, [base_row, *rows], best_row)
    if n_ok < len(rows):
        lines += near_misses(loaded, rows, best_row, base_row)
    if best_row is not None and n_ok < len(rows):
        lines += ["", "## What kept the others out", "", binding(loaded, rows)]
    return "\n".join(lines) + "\n"


BINDS = 0.02            # a bound binds at the best when the best is within this share of it
NEAR_MISSES = 5
FRONT_ROWS = 12


def _stops(loaded: Loaded, r: dict, base_row: dict) -> tuple[str, str, str]:
    """(what stops an infeasible trial, how far, its fix): the constraint it breaks furthest, a
    check (its message and the check's own fix) or a bound of the goal (the figure against it)."""
    from .run import _violation
    g = loaded.spec.goal
    worst = None
    for f in map(Failure.of, r.get("failures") or []):
        if g.binds(f):
            v = _violation(f)
            if worst is None or v > worst[0]:
                worst = (v, f.id, f.message or "", f.fix)
    for label, c, (n, how) in zip(bounds(loaded), r["constraints"][1:],
                                  [*((n, "≥") for n in g.at_least), *((n, "≤") for n in g.at_most)]):
        if c > 0 and (worst is None or c > worst[0]):
            b = (g.at_least | g.at_most)[n]
            ref = results.value(n, base_row, loaded.state) if b == "base" else b
            got = results.value(n, r, loaded.state)
            worst = (c, label, f"{n} {_fmt(got)} against {_fmt(ref)}", "")      # a bound of the goal: no check's fix
    if worst is None:
        return r.get("verdict") or "-", r.get("message") or "", ""
    return worst[1], worst[2], worst[3]


def near_misses(loaded: Loaded, rows: list[dict], best_row: dict | None, base_row: dict) -> list[str]:
    """The :data:`NEAR_MISSES` infeasible trials nearest feasible (least violation) of those better in
    the (first) objective than the best, each with the one constraint that stops it furthest and
    that check's fix: where a lab's judgement (a bead on a seat, a warning stated with its reason)
    may take a better design than the search could."""
    sign = 1.0 if loaded.objectives[0][1] == "maximize" else -1.0
    bar = None if best_row is None else sign * best_row["objectives"][0]
    seen, out = set(), []
    cands = [r for r in rows if not r["feasible"] and r.get("verdict") not in ("bad input", "error")
             and results.value(loaded.objectives[0][0], r, loaded.state) is not None
             and (bar is None or sign * r["objectives"][0] > bar)]
    for r in sorted(cands, key=lambda r: (sum(r["constraints"]), -sign * r["objectives"][0], r["trial"])):
        if r.get("hash") in seen:
            continue
        seen.add(r.get("hash"))
        out.append(r)
        if len(out) == NEAR_MISSES:
            break
    name = loaded.objectives[0][0]
    head = ["", f"## Near misses ({len(out)}: the infeasible trials nearest feasible"
                + (f" of those past the best in {name}" if best_row is not None else "") + ")", ""]
    if not out:
        return head + [f"No infeasible trial beats the best in {name}."]
    head += [f"| trial | {name} | stopped by | measured | fix |", "|---|---:|---|---|---|"]
    for r in out:
        cid, what, fix = _stops(loaded, r, base_row)
        head.append(f"| {r['trial']} | {_fmt(r['objectives'][0])} | `{cid}` | {_fmt(what)} | {_fmt(fix) if fix else '-'} |")
    return head


def bound_fronts(loaded: Loaded, rows: list[dict], best_row: dict) -> list[str]:
    """For each bound of the goal that binds at the best (within :data:`BINDS`), the feasible trials no
    other beats in both the objective and that bound's result: what the bound costs."""
    if len(loaded.objectives) != 1 or loaded.objectives[0][0] == "distance":
        return []
    g = loaded.spec.goal
    name, how = loaded.objectives[0]
    s_obj = 1.0 if how == "maximize" else -1.0
    out = []
    for n, b, s_b in [*((n, b, 1.0) for n, b in g.at_least.items()), *((n, b, -1.0) for n, b in g.at_most.items())]:
        ref = results.value(n, rows[0], loaded.state) if b == "base" else b
        got = results.value(n, best_row, loaded.state)
        if ref is None or got is None or abs(got - ref) > BINDS * max(abs(ref), 1e-12):
            continue
        ok = [(s_obj * r["objectives"][0], s_b * v, r) for r in rows if r["feasible"]
              and (v := results.value(n, r, loaded.state)) is not None]
        front = {id(r): r for a, c, r in ok if not any(a2 >= a and c2 >= c and (a2, c2) != (a, c) for a2, c2, _ in ok)}
        pts = sorted(front.values(), key=lambda r: -s_obj * r["objectives"][0])[:FRONT_ROWS]
        out += ["", f"## The front: {name} against {n} (the bound {n} {'≥' if s_b > 0 else '≤'} {_fmt(ref)} binds "
                    f"at the best)", "", f"| trial | {name} | {n} |", "|---|---:|---:|"]
        out += [f"| {r['trial']} | {_fmt(r['objectives'][0])} | {_fmt(results.value(n, r, loaded.state))} |"
                for r in pts]
    return out


def binding(loaded: Loaded, rows: list[dict]) -> str:
    """Which constraints the infeasible trials break, most often first."""
    g = loaded.spec.goal
    counts: dict[str, int] = {}
    for r in rows:
        if r["feasible"]:
            continue
        ids = {f.id for f in map(Failure.of, r.get("failures") or []) if g.binds(f)}
        for label, c in zip(bounds(loaded), r["constraints"][1:]):
            if c > 0:
                ids.add(label)
        for i in ids:
            counts[i] = counts.get(i, 0) + 1
    bad = sum(1 for r in rows if not r["feasible"])
    if not counts:
        return f"{bad} trials infeasible."
    top = sorted(counts.items(), key=lambda kv: -kv[1])[:TOP_FAILURES]
    return (f"Of {bad} infeasible trials: " + ", ".join(f"{k} in {n}" for k, n in top)
            + " (a trial may break several).")


# ---------------------------------------------------------------- convergence.png

def convergence(loaded: Loaded, rows: list[dict], path: Path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4.5))
    rows = sorted(rows, key=lambda r: r["trial"])
    names = [n for n, _ in loaded.objectives]
    ok = [r for r in rows if r["feasible"]]
    bad = [r for r in rows if not r["feasible"]]
    if len(names) == 1:
        sign = 1.0 if loaded.objectives[0][1] == "maximize" else -1.0
        ax.scatter([r["trial"] for r in bad], [r["objectives"][0] for r in bad], marker="x", s=12, color="lightgrey",
                   label="infeasible")
        ax.scatter([r["trial"] for r in ok], [r["objectives"][0] for r in ok], s=12, color="tab:blue",
                   label="feasible")
        xs, ys, cur = [], [], None
        for r in rows:
            if r["feasible"] and (cur is None or sign * r["objectives"][0] > sign * cur):
                cur = r["objectives"][0]
            if cur is not None:
                xs.append(r["trial"])
                ys.append(cur)
        if xs:
            ax.step(xs, ys, where="post", color="tab:red", label="best so far")
        ax.set_xlabel("trial")
        ax.set_ylabel(names[0])
    else:
        _, front = best(loaded, rows)
        ax.scatter([r["objectives"][0] for r in bad], [r["objectives"][1] for r in bad], marker="x", s=12,
                   color="lightgrey", label="infeasible")
        ax.scatter([r["objectives"][0] for r in ok], [r["objectives"][1] for r in ok], s=12, color="tab:blue",
                   label="feasible")
        f = sorted(front, key=lambda r: r["objectives"][0])
        ax.plot([r["objectives"][0] for r in f], [r["objectives"][1] for r in f], "-o", color="tab:red", ms=4,
                label="front")
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"tune {loaded.spec.tune}: {len(rows)} trials, {len(ok)} feasible")
    save(plt, fig, path)


def write(loaded: Loaded, study, folder: Path, outcome=None, built=None, stiffness=None) -> dict:
    """trials.parquet, summary.md, convergence.png and (when a trial passes) best.yaml; returns
    the best row (or None) and the files written."""
    rows = trials(study)
    base_row = base(loaded, study)
    write_trials(loaded, [base_row, *rows], folder / "trials.parquet")
    files = [folder / "trials.parquet"]
    rejected = study.user_attrs.get("rejected", {})
    best_row, front = best(loaded, [base_row, *rows], rejected)
    if best_row is not None:
        write_text(folder / "best.yaml", best_yaml(loaded, best_row))
        files.append(folder / "best.yaml")
    write_text(folder / "summary.md", markdown(loaded, rows, base_row, outcome, built, stiffness, rejected))
    convergence(loaded, rows, folder / "convergence.png")
    files += [folder / "summary.md", folder / "convergence.png"]
    return {"best": best_row, "front": front, "files": files, "rows": rows, "base": base_row}

