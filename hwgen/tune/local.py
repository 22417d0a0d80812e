"""Moves around the incumbent: the feasible-first half of a tune's search.

A design that passes every check is a narrow island in its space (the prototype's derived space:
599 of 600 TPE trials infeasible, most of them on eq. (2)'s length budget). TPE ranks the
infeasible trials by their violation only, and so, with nothing feasible but the base, it closes
on the boundary of the violation from outside and stays there. A trial drawn a few grid steps
from the best feasible design found so far (the base first) lands on the island far more often,
and each feasible one it finds is also a good trial for TPE to model.

:func:`neighbour` draws such a trial: one to three free parameters changed, a number by a
normal step of a share of its range (:data:`SCALES`, one drawn per move: small moves refine, large
ones cross to the next basin; at least one grid step), a choice to another of its choices. From an
incumbent that does not pass yet, one parameter a move: the prototype's base sits on its own torsion
bound, trial 0 (its tensions on the grid) 0.3 % under it, and moves of up to three parameters from
there found no trial that passes in 40 (each changed routing breaks eq. (2) or the torsion far more
than the one tension that restores it).
From an incumbent that passes, a share of the moves (:data:`WHOLE_TENDON`) changes every value of one
tendon at once (its routing, pre-tension and termination; each choice among them half the time): the
prototype's climbs of 1-3 values stalled at 1.12x and 1.26x with C2's and the helix's routing still the
base's, where a helix of other half turns is stiffer only at another phase and amplitude together (at
even k its lever is -aL² sin φ/(kπ): nothing at the base's phase 0).
Pure: the values and the generator in, the values out (the generator is the tune's, seeded, so a
seed draws the same moves).
"""
from __future__ import annotations

import math

import numpy as np

from ..designfile import parse_path

SCALES = (0.02, 0.06, 0.2)      # the normal step's spread, a share of the parameter's range
MOST_CHANGED = 3                # free parameters changed by one move, at most
WHOLE_TENDON = 0.3              # of the moves from a passing incumbent, those that change one tendon's every value


def _number(dist, v: float, rng: np.random.Generator, scale: float) -> float | int:
    """A number near ``v`` within an Optuna distribution (on its grid where it has one), never ``v``."""
    lo, hi = dist.low, dist.high
    step = getattr(dist, "step", None)
    span = hi - lo
    if getattr(dist, "log", False):
        x = math.exp(math.log(v) + rng.normal(0.0, scale * math.log(hi / lo)))
        x = min(max(x, lo), hi)
        return int(round(x)) if isinstance(lo, int) else x
    if step is None:
        return float(min(max(v + rng.normal(0.0, scale * span), lo), hi))
    steps = int(round(rng.normal(0.0, scale * span) / step))
    if steps == 0:
        steps = 1 if rng.random() < 0.5 else -1
    n_max = int(round(span / step))
    n = int(round((v - lo) / step)) + steps
    if n < 0 or n > n_max:                 # off the end: the other way (a value at a bound still moves)
        n = int(round((v - lo) / step)) - steps
    n = min(max(n, 0), n_max)
    x = lo + n * step
    return int(x) if isinstance(lo, int) and isinstance(step, int) else round(float(x), 9)


def tendon_of(name: str) -> tuple:
    """The tendon a free parameter belongs to (``('tendons', 2)`` of ``tendons[2].routing.function.a``;
    another field, its first key)."""
    return tuple(parse_path(name)[:2])


def _picks(names: list, rng: np.random.Generator, most: int, whole: float) -> tuple[list, float]:
    """(the names a move changes, the chance each choice among them changes): one tendon's every value
    for a share ``whole`` of the moves (choices half the time), else 1 to ``most`` names at random."""
    tendons = sorted({tendon_of(n) for n in names})
    if whole > 0 and len(tendons) > 1 and rng.random() < whole:
        tendon = tendons[int(rng.integers(len(tendons)))]
        return [n for n in names if tendon_of(n) == tendon], 0.5
    changed = min(int(rng.geometric(0.5)), most, len(names))     # 1 half the time, 2 a quarter, ...
    return [names[int(i)] for i in rng.choice(len(names), size=changed, replace=False)], 1.0


def neighbour(dists: dict, values: dict, rng: np.random.Generator, most: int = MOST_CHANGED,
              whole: float = 0.0, among: list | None = None) -> dict:
    """Parameters a move from ``values`` (name -> value over the distributions ``dists``): at most
    ``most`` of them changed (of the names ``among``, where given), or, for a share ``whole`` of the
    moves, one tendon's every value (see the module's docstring). A parameter with no value (the base
    leaves it unset) is drawn whole."""
    picks, choice_p = _picks(list(among or dists), rng, most, whole)
    scale = SCALES[int(rng.integers(len(SCALES)))]
    out = dict(values)
    for name in picks:
        dist, v = dists[name], values.get(name)
        choices = getattr(dist, "choices", None)
        if choices is not None:
            if v in choices and choice_p < 1.0 and rng.random() >= choice_p:
                continue
            others = [c for c in choices if c != v] or list(choices)
            out[name] = others[int(rng.integers(len(others)))]
        elif v is None or not dist.low <= v <= dist.high:
            out[name] = _number(dist, dist.low + rng.random() * (dist.high - dist.low), rng, scale)
        else:
            out[name] = _number(dist, v, rng, scale)
    return out
