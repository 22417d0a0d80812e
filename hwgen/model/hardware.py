"""Fasteners and other bought hardware: their sizes from the table shipped with hwgen
(data/fasteners.csv), each row with its source, and the two ways a design picks a stock screw.

A row is (item, size, dimension, value in mm, source). ``size`` is the thread (M2, M3), a pin's
diameter (Ø3), or ``any`` when the figure does not depend on it; a ``lengths`` row lists the stock
lengths, shortest first."""
from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cache
from importlib import resources


@dataclass(frozen=True, kw_only=True)
class Dimension:
    item: str
    size: str
    dimension: str
    value: float | tuple[float, ...]     # mm; a list of stock lengths for ``lengths``
    source: str


def _number(text: str) -> float | int:
    return int(text) if text.strip().lstrip("-").isdigit() else float(text)


@cache
def table() -> dict[tuple[str, str, str], Dimension]:
    """Every row of data/fasteners.csv by (item, size, dimension)."""
    text = resources.files("hwgen").joinpath("data/fasteners.csv").read_text(encoding="utf-8")
    out = {}
    for r in csv.DictReader(text.splitlines()):
        words = r["value_mm"].split()
        value = tuple(_number(w) for w in words) if r["dimension"] == "lengths" else float(r["value_mm"])
        key = (r["item"], r["size"], r["dimension"])
        if key in out:
            raise ValueError(f"data/fasteners.csv gives {key} twice")
        out[key] = Dimension(item=r["item"], size=r["size"], dimension=r["dimension"], value=value,
                             source=r["source"])
    return out


def size(item: str, size: str, dimension: str) -> float:
    """One dimension of a fastener, mm."""
    value = table()[(item, size, dimension)].value
    if isinstance(value, tuple):
        raise TypeError(f"{item} {size}: {dimension} is a list of lengths")
    return value


def lengths(item: str, size: str) -> tuple[float, ...]:
    """The stock lengths of an item of this size (or of any size), shortest first, mm."""
    t = table()
    return (t.get((item, size, "lengths")) or t[(item, "any", "lengths")]).value


def nut(thread: str) -> tuple[float, float]:
    """(across flats, height) of an ISO 4032 hex nut, mm."""
    return size("hex nut", thread, "across_flats"), size("hex nut", thread, "height")


def insert(thread: str) -> tuple[float, float]:
    """(bore it is melted into, length) of a heat-set insert, mm."""
    return size("heat-set insert", thread, "bore"), size("heat-set insert", thread, "length")


def clearance_holes() -> dict[float, str]:
    """ISO 273 normal clearance hole diameter -> thread."""
    return {d.value: d.size for d in table().values() if d.item == "clearance hole" and d.dimension == "normal"}


def clearance_hole(thread: str) -> float:
    """The ISO 273 normal clearance hole of a thread, mm."""
    return size("clearance hole", thread, "normal")


def shortest_reaching(stock: tuple[float, ...], need: float) -> float:
    """The shortest stock length at least ``need`` long: a screw that must reach through a nut.
    Longer than every stock length: the longest (the caller's check finds it short)."""
    return next((n for n in stock if n >= need), stock[-1])


def longest_within(stock: tuple[float, ...], room: float) -> float | None:
    """The longest stock length no longer than ``room``: a screw that must end inside a blind
    body. None when even the shortest is too long."""
    fits = [n for n in stock if n <= room + 1e-9]
    return max(fits) if fits else None
