"""The bench's bought parts (hwgen/data/bench_parts.csv), read: ball bearings, GT2 belts and
pulleys, ground shafts and the ISO 9409-1 robot flange, one row per (item, size, dimension) with
its standard or source, as :mod:`hwgen.fasteners` reads the fastener table."""
from __future__ import annotations

import csv
from functools import cache
from importlib import resources


@cache
def table() -> dict[tuple[str, str, str], tuple[float | tuple[float, ...], str]]:
    """(item, size, dimension) -> (value, source); a ``lengths`` row holds its stock lengths."""
    text = resources.files("hwgen").joinpath("data/bench_parts.csv").read_text(encoding="utf-8")
    out = {}
    for r in csv.DictReader(text.splitlines()):
        key = (r["item"], r["size"], r["dimension"])
        if key in out:
            raise ValueError(f"data/bench_parts.csv gives {key} twice")
        words = r["value"].split()
        value = tuple(float(w) for w in words) if r["dimension"] == "lengths" else float(r["value"])
        out[key] = (value, r["source"])
    return out


def size(item: str, size_: str, dimension: str) -> float:
    """One dimension (mm, or N for a load rating) of a bought part."""
    value = table()[(item, size_, dimension)][0]
    if isinstance(value, tuple):
        raise TypeError(f"{item} {size_}: {dimension} is a list of lengths")
    return value


def lengths(item: str) -> tuple[float, ...]:
    """The stock lengths of an item, shortest first, mm."""
    return table()[(item, "any", "lengths")][0]


def source(item: str, size_: str, dimension: str) -> str:
    return table()[(item, size_, dimension)][1]
