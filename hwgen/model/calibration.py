"""What a lab's pushes say about its robot (`hwgen compare`; numpy and scipy only): the measured
samples read and checked, the paper's eq. (4) fitted per state and disk with the repetitions'
uncertainty, each measured β against the prediction for the pushes the lab made (the same
statics, :mod:`hwgen.model.experiment`), and the values the paper does not give fitted to the
measured β by least squares.

Eq. (4) as the paper fits it: F = β x + η_l over ``experiment.fit_window_samples`` samples either
side of each repetition's peak (the sample of the largest displacement), one β for the
repetitions of a disk and an η each. Its interval: with two repetitions or more, the spread of
the repetitions' own slopes (mean ± t(0.975, n − 1) s/√n, Student's t); with one, the slope's
standard error from the regression (± 1.96 σ).

The calibration. The fields with a range in ``experiment.ranges`` (the line's EA, the tie-off's
give, the eyelets' friction, the strip's E) are fitted to the measured β (each weighted by its
interval) by scipy's ``least_squares``, each from its design value, with its range as a prior (the
range taken as ± 2 σ of a normal prior: a field the pushes cannot tell apart from another stays
near its design value instead of wandering). Each fitted value's interval is ± 1.96 standard
errors from the Jacobian at the solution (scaled up by the reduced χ² when that is above 1: the
model then misses more than the measurements' scatter), the correlation between the fields said
alongside: a tendon's EA and its tie-off's give both set its spring, and only friction and the
segments' lengths tell them apart.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.optimize import least_squares

from ..errors import InputError, echo
from . import experiment as ex
from . import push as pu
from . import stiffness as sf

COLUMNS = ("state", "disk", "repetition", "displacement_mm", "force_n")
UNITS = {"displacement": ("mm", "displacement_mm"), "force": ("n", "force_n")}
MIN_SAMPLES = 3                   # a push with fewer samples fits no slope
FORCE_UNITS = 10.0                # a force over this many times the load cell's range is not in newtons
DISPLACEMENT_MM = (0.01, 1000.0)  # a push whose travel lies outside this is not in millimetres
MAX_BYTES = 200 << 20            # the largest measurement file read
MAX_ROWS = 2_000_000              # the most sample lines read (30 S/s over 9 states × 11 disks × 3 pushes is ~10⁵)
RELATIVE_FLOOR = 0.01             # a measured β is never weighted as known better than 1 %
PRIOR_SIGMAS = 2.0                # a range is ± this many σ of its field's prior
DIFF_STEP = 0.02                  # the least-squares Jacobian's step, in prior σ
XTOL = 1e-3                       # ... and its steps' end: a thousandth of a prior σ, far inside any fitted interval
FTOL = 1e-4                       # ... or a step that changes the misfit by under this share
Z95 = stats.norm.ppf(0.975)
SCHEMA = {"tendon_material.axial_stiffness_n": (1.001, 1e7), "tendon_material.tie_off_compliance_mm_per_n": (0.0, 10.0),
          "tendon_material.eyelet_friction": (0.0, 2.0), "backbone.modulus_gpa": (1.001, 400.0)}   # what the schema takes


# ------------------------------------------------------------------ the measured samples

@dataclass(frozen=True)
class Push:
    """One repetition at one disk of one state: its samples in the order recorded."""

    state: str
    disk: int
    repetition: int
    x: np.ndarray
    force: np.ndarray
    first_row: int


def _bad(path, row: int | None, column: str, message: str) -> InputError:
    return InputError(path, f"row {row}: {column}" if row is not None else column, message)


def _header(path, names: list[str]) -> None:
    """Every column there, and a column in other units named for what it is."""
    got = [n.strip().lower() for n in names]
    missing = [c for c in COLUMNS if c not in got]
    if not missing:
        return
    for c in missing:
        quantity = c.rsplit("_", 1)[0]
        other = [g for g in got if g.startswith(quantity + "_") and g != c]
        if other:
            raise _bad(path, None, "header", f"column {echo(other[0])}: hwgen reads {quantity} in "
                                             f"{UNITS[quantity][0]} as {c}; convert it and name the column {c}")
    raise _bad(path, None, "header", f"missing column{'s' if len(missing) > 1 else ''} {', '.join(missing)}; a "
                                     f"measurement has {', '.join(COLUMNS)} (template.csv)")


def _number(path, row: int, column: str, text: str, whole: bool = False) -> float:
    try:
        v = float(text)
    except ValueError:
        raise _bad(path, row, column, f"{echo(text)} is not a number") from None
    if not math.isfinite(v) or (whole and v != int(v)):
        raise _bad(path, row, column, f"{echo(text)} is not a {'whole' if whole else 'finite'} number")
    return v


def read_bytes(path) -> bytes:
    """A measurement file's bytes, at most :data:`MAX_BYTES`."""
    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_BYTES + 1)
    except OSError as e:
        raise InputError(path, "<document>", f"cannot read the file ({e.strerror or e})") from None
    if len(raw) > MAX_BYTES:
        raise InputError(path, "<document>", f"larger than {MAX_BYTES >> 20} MiB")
    return raw


def read_measured(path, raw: bytes, plan) -> list[Push]:
    """The pushes of a measurement CSV (:data:`COLUMNS`; lines with neither displacement nor force,
    a template's, skipped), checked against the design: its states, its disks, units that fit the
    load cell's range. Raises :class:`hwgen.errors.InputError` naming the row and column."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise InputError(path, "<document>", "not UTF-8 text: a CSV with the columns of template.csv") from None
    states = [s.name for s in sf.states(plan)]
    n_disks = len(plan.stations)
    reader = csv.reader(io.StringIO(text))
    header = next(reader, None)
    if header is None:
        raise _bad(path, None, "header", "the file is empty; a measurement has " + ", ".join(COLUMNS))
    _header(path, header)
    col = {n.strip().lower(): i for i, n in enumerate(header)}
    samples: dict[tuple, list] = {}
    for row, line in enumerate(reader, start=2):
        if row > MAX_ROWS:
            raise _bad(path, row, "<document>", f"more than {MAX_ROWS} lines")
        if not any(v.strip() for v in line):
            continue
        get = {c: (line[col[c]].strip() if col[c] < len(line) else "") for c in COLUMNS}
        if not get["displacement_mm"] and not get["force_n"]:
            continue                                        # a line of the template not filled in
        if get["state"] not in states:
            raise _bad(path, row, "state", f"{echo(get['state'])} is not a state of this design (its states: "
                                           f"{', '.join(states)})")
        disk = int(_number(path, row, "disk", get["disk"], whole=True))
        if not 2 <= disk <= n_disks:
            raise _bad(path, row, "disk", f"{disk} is not a disk that can be pushed: 2 to {n_disks}, counted from 1 "
                                          f"at the clamped base")
        rep = int(_number(path, row, "repetition", get["repetition"], whole=True))
        if rep < 1:
            raise _bad(path, row, "repetition", f"{rep}: repetitions count from 1")
        x = _number(path, row, "displacement_mm", get["displacement_mm"])
        f = _number(path, row, "force_n", get["force_n"])
        limit = FORCE_UNITS * plan.experiment.load_cell_range_n
        if abs(f) > limit:
            raise _bad(path, row, "force_n", f"{f:g} N is over {FORCE_UNITS:g} times the "
                                             f"{plan.experiment.load_cell_range_n:g} N load cell's range "
                                             f"(experiment.load_cell_range_n): newtons? (mN are 1000 times more)")
        samples.setdefault((get["state"], disk, rep), []).append((x, f, row))
    if not samples:
        raise _bad(path, None, "<document>", "no samples: every line's displacement_mm and force_n are empty")
    return [_push(path, key, rows) for key, rows in samples.items()]


def _push(path, key: tuple, rows: list) -> Push:
    arr = np.array([(x, f) for x, f, _ in rows])
    first = rows[0][2]
    where = f"state {key[0]}, disk {key[1]}, repetition {key[2]}"
    if len(rows) < MIN_SAMPLES:
        raise _bad(path, first, "displacement_mm", f"{where}: {len(rows)} samples, eq. (4) needs {MIN_SAMPLES}")
    travel = float(np.ptp(arr[:, 0]))
    if not DISPLACEMENT_MM[0] <= travel <= DISPLACEMENT_MM[1]:
        raise _bad(path, first, "displacement_mm", f"{where}: the arm travels {travel:g} mm: millimetres? (metres "
                                                   f"are 1000 times less, µm 1000 times more)")
    return Push(*key, arr[:, 0], arr[:, 1], first)


# ------------------------------------------------------------------ eq. (4) on the measurements

def window(p: Push, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples of a push eq. (4) is fitted to (:func:`hwgen.model.push.peak_window`)."""
    w = pu.peak_window(p.x, samples)
    return p.x[w], p.force[w]


def fit_measured(pushes: list[Push], samples: int) -> list[dict]:
    """Per state and disk (in the order first met): eq. (4)'s β over its repetitions, the
    repetitions' own slopes and β's interval (see the module's docstring), the travel of each push."""
    groups: dict[tuple, list[Push]] = {}
    for p in pushes:
        groups.setdefault((p.state, p.disk), []).append(p)
    out = []
    for (state, disk), ps in groups.items():
        ps.sort(key=lambda p: p.repetition)
        win = [window(p, samples) for p in ps]
        X = np.concatenate([w[0] for w in win])
        F = np.concatenate([w[1] for w in win])
        R = np.concatenate([np.full(len(w[0]), i) for i, w in enumerate(win)])
        beta = pu.eq4(X, F, R)
        each = [pu.eq4(w[0], w[1], np.zeros(len(w[0]))) for w in win]
        if len(ps) >= 2:
            half = stats.t.ppf(0.975, len(ps) - 1) * float(np.std(each, ddof=1)) / math.sqrt(len(ps))
        else:
            half = Z95 * _slope_error(win[0][0], win[0][1])
        out.append({"state": state, "disk": disk, "repetitions": len(ps), "measured_n_per_mm": beta,
                    "each_n_per_mm": each, "interval": [beta - half, beta + half],
                    "travel_mm": float(np.mean([np.ptp(p.x) for p in ps])),
                    "samples": int(len(X))})
    return out


def _slope_error(x: np.ndarray, f: np.ndarray) -> float:
    """The standard error of a straight line's slope fitted to (x, f)."""
    res = stats.linregress(x, f)
    return float(res.stderr)


# ------------------------------------------------------------------ measured against predicted

def _strokes(measured: list[dict]) -> dict:
    return {(m["state"], m["disk"]): m["travel_mm"] for m in measured}


def compared(plan, measured: list[dict], bench: ex.Bench) -> dict:
    """Each measured β beside the prediction for the pushes the lab made (their travel), with its band;
    ``within``: the measured interval meets the band."""
    states = list(dict.fromkeys(m["state"] for m in measured))
    pred = ex.predict(plan, strokes=_strokes(measured), which=states, bench=bench)
    by = {(r["state"], r["disk"]): r for r in pred["rows"]}
    rows = []
    for m in measured:
        p = by.get((m["state"], m["disk"]))
        if p is None:
            continue
        lo, hi = p["beta_low_n_per_mm"], p["beta_high_n_per_mm"]
        rows.append({**m, "predicted_n_per_mm": p["beta_n_per_mm"], "low_n_per_mm": lo, "high_n_per_mm": hi,
                     "push_mm": p["push_mm"], "within": bool(m["interval"][0] <= hi and m["interval"][1] >= lo)})
    x = plan.experiment
    settings = {"push_toward": x.push_toward, "orientation": x.orientation}
    return {"rows": rows, "prediction": {"rows": pred["rows"], "endpoint_ratio": pred["endpoint_ratio"],
                                         "sets": pred["sets"], "settings": settings}}


# ------------------------------------------------------------------ the calibration

def calibrate(plan, measured: list[dict], bench: ex.Bench) -> dict:
    """The ranged fields fitted to the measured β (see the module's docstring): per field its design
    value, the fitted value and its 95 % interval, and the fit's χ² and correlations."""
    rng = [(f, lo, hi) for f, lo, hi in plan.experiment.ranges]
    if not rng:
        return {"fitted": {}, "note": "no experiment.ranges: nothing to fit"}
    base = ex.nominal(plan)
    fields = [f for f, _, _ in rng]
    scale = np.array([(hi - lo) / (2 * PRIOR_SIGMAS) or max(abs(base[f]), 1e-3) for f, lo, hi in rng])
    centre = np.array([base[f] for f in fields])
    floor = np.array([SCHEMA[f][0] for f in fields])
    ceiling = np.array([SCHEMA[f][1] for f in fields])
    states = list(dict.fromkeys(m["state"] for m in measured))
    beta = np.array([m["measured_n_per_mm"] for m in measured])
    sigma = np.array([max((m["interval"][1] - m["interval"][0]) / (2 * Z95), RELATIVE_FLOOR * abs(m["measured_n_per_mm"]))
                      for m in measured])
    strokes = _strokes(measured)
    keys = [(m["state"], m["disk"]) for m in measured]

    def values(z):
        return {**base, **dict(zip(fields, np.clip(centre + scale * z, floor, ceiling)))}

    def residuals(z):
        p = ex.predict_nominal(plan, values(z), strokes, states, bench)
        return np.r_[(np.array([p[k] for k in keys]) - beta) / sigma, z / PRIOR_SIGMAS]

    sol = least_squares(residuals, np.zeros(len(fields)), bounds=((floor - centre) / scale, (ceiling - centre) / scale),
                        diff_step=DIFF_STEP, x_scale=1.0, method="trf", xtol=XTOL, ftol=FTOL)
    J = sol.jac
    dof = max(1, len(beta) - len(fields))
    chi2 = float(np.sum(sol.fun[: len(beta)] ** 2))
    try:
        cov = np.linalg.inv(J.T @ J) * max(1.0, chi2 / dof)
    except np.linalg.LinAlgError:
        cov = np.linalg.pinv(J.T @ J) * max(1.0, chi2 / dof)
    sd = np.sqrt(np.diag(cov))
    best = values(sol.x)
    corr = cov / np.outer(sd, sd)
    fitted = {f: {"design": base[f], "value": float(best[f]), "low": float(best[f] - Z95 * scale[i] * sd[i]),
                  "high": float(best[f] + Z95 * scale[i] * sd[i]), "range": [lo, hi]}
              for i, (f, lo, hi) in enumerate(rng)}
    return {"fitted": fitted, "chi2": chi2, "dof": dof, "evaluations": int(sol.nfev), "jacobians": int(sol.njev),
            "correlation": {f: {g: float(corr[i, j]) for j, g in enumerate(fields) if g != f}
                            for i, f in enumerate(fields)},
            "prior": f"each range as ± {PRIOR_SIGMAS:g} σ of a normal prior about the design's value"}
