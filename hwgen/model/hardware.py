"""Fasteners and other bought hardware: their sizes from the table shipped with hwgen
(data/fasteners.csv), each row with its source, and the two ways a design picks a stock screw.

A row is (item, size, dimension, value in mm, source). ``size`` is the thread (M2, M3), a pin's
diameter (Ø3), or ``any`` when the figure does not depend on it; a ``lengths`` row lists the stock
lengths, shortest first."""
from __future__ import annotations

from ..fasteners import Dimension, size, table    # noqa: F401  (the table's reader, as the model uses it)


NUT_PLAY = size("nut trap", "any", "play")     # added to a nut's width and height: the room its trap gives it


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
