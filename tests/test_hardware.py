"""The fastener table (hwgen/data/fasteners.csv) and the two ways a stock screw is chosen."""
from __future__ import annotations

import pytest

from hwgen import cache

from hwgen.model import hardware


def test_every_row_says_where_its_figure_comes_from():
    rows = hardware.table().values()
    assert rows
    for r in rows:
        assert r.source.strip(), r
        values = r.value if isinstance(r.value, tuple) else (r.value,)
        assert all(v > 0 for v in values), r
        if isinstance(r.value, tuple):
            assert list(r.value) == sorted(set(r.value)), r          # stock lengths: shortest first, once each


def test_the_standards_hwgen_names_are_the_rows_it_reads():
    assert hardware.nut("M3") == (5.5, 2.4) and hardware.nut("M2") == (4.0, 1.6)       # ISO 4032
    assert "ISO 4032" in hardware.table()[("hex nut", "M3", "across_flats")].source
    assert hardware.clearance_hole("M3") == 3.4 and hardware.clearance_holes()[3.4] == "M3"   # ISO 273 normal
    # a nut's trap is wider than the nut, and the nut is wider than its screw's clearance hole
    for thread in ("M2", "M3"):
        af, _ = hardware.nut(thread)
        assert hardware.clearance_hole(thread) < af < af + hardware.size("nut trap", "any", "play")


def test_one_value_per_concept_across_the_modules():
    """The constants the model, the CAD and the outputs use are the table's: one nut play for the
    tensioner and the base mount, one M3 nut, one list of stock screw lengths."""
    from hwgen.cad import fixtures as cad_fixtures
    from hwgen.model import fixtures, screws
    from hwgen.model.tensioner_layout import sizes
    from hwgen.outputs import bom
    assert fixtures.NUT_PLAY == sizes.NUT_PLAY == hardware.size("nut trap", "any", "play")
    assert (fixtures.NUT_AF, fixtures.NUT_THICK) == sizes.NUT["M3"] == hardware.nut("M3")
    assert sizes.SCREW_LENGTHS["M3"] == cad_fixtures.SCREW_LENGTHS
    assert screws.WASHER_OD == hardware.size("washer", "M3", "outer_diameter")
    assert bom.ISO273_NORMAL == hardware.clearance_holes()
    assert sizes.M2_CLEARANCE == hardware.clearance_hole("M2") and sizes.INSERT["M3"] == hardware.insert("M3")


@pytest.mark.parametrize("need", [0.5, 5.9, 6.0, 6.1, 13.2, 24.99, 25.0, 49.0, 50.0])
def test_a_screw_through_a_nut_is_the_shortest_that_reaches(need):
    stock = hardware.lengths("socket head cap screw", "M3")
    n = hardware.shortest_reaching(stock, need)
    assert n >= need and all(s < need for s in stock if s < n)


def test_a_screw_longer_than_any_stock_gets_the_longest():
    stock = hardware.lengths("socket head cap screw", "M3")
    assert hardware.shortest_reaching(stock, stock[-1] + 1) == stock[-1]


@pytest.mark.parametrize("room", [4.0, 4.5, 7.99, 8.0, 13.2, 20.0, 100.0])
def test_a_screw_in_a_blind_body_is_the_longest_that_ends_inside(room):
    stock = hardware.lengths("button head screw", "M2")
    n = hardware.longest_within(stock, room)
    assert n <= room and all(s > room for s in stock if s > n)


def test_no_screw_is_short_enough_for_too_little_room():
    stock = hardware.lengths("button head screw", "M2")
    assert hardware.longest_within(stock, stock[0] - 0.5) is None


def test_the_part_cache_is_keyed_by_the_tables_the_solids_read():
    """A cached part made with another fastener (or material) table is not reused: the tables are
    among the files the part cache's key is taken from, beside the model's and the CAD's code."""
    names = {f.name for f in cache.code_files(cache.SOLID_CODE)}
    assert {"fasteners.csv", "materials.csv", "hardware.py", "fixtures.py"} <= names
