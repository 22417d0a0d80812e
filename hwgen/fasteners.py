"""The fastener table shipped with hwgen (data/fasteners.csv), read: one row per (item, size,
dimension), each with its standard or source. The schema's defaults (a clearance hole) and the
model (:mod:`hwgen.model.hardware`: nuts, inserts, stock screws) read it here."""
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
