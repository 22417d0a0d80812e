"""Intervals on a line: what is left of a span once some bands are taken out (plain Python)."""
from __future__ import annotations


def interval_difference(lo: float, hi: float, bands: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of [lo, hi] outside every band (bands may overlap and come in any order), in
    order, none empty."""
    out, at = [], lo
    for a, b in sorted(bands):
        if a > at:
            out.append((at, min(a, hi)))
        at = max(at, b)
        if at >= hi:
            break
    if at < hi:
        out.append((at, hi))
    return [(a, b) for a, b in out if b > a]
