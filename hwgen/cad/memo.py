"""Solids kept between builds: an expensive solid read back from its exact BREP instead of being
made again.

The part cache (:mod:`hwgen.pipeline.units`) keeps whole units; when a unit has to be built again
because one of its inputs changed, the costly solids inside it whose own inputs did not (the
throated wheel's gear: one tooth's sector cut and turned round, the costliest boolean; the
worm's swept thread) come from here: an edit that moves the tensioner but not
its gearing reuses both. The tensioner's channels, units of their own made in several processes
at once, share their worm, gear, drive shaft, clamp plate and wheels through it too (a build
without a cache keeps them in a store of its own): each is made once, by whichever unit comes
first. The solid :func:`kept` gives is always the one read back from its BREP's bytes, also in
the build that made it: a BREP round trip is not exact for every surface (a plane's axes are
made orthogonal again as they are read), so a solid as made and as read back may write files
that differ in a last digit; given out one way only, every build writes the same bytes
(``tests/test_cache.py``). Without an active store (:func:`kept_in`) every solid is made as before.
"""
from __future__ import annotations

import contextlib
import weakref
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from .. import cache
from . import known_mass, mass_properties
from .export import read_brep, settings, write_brep

_ACTIVE: ContextVar[cache.Store | None] = ContextVar("hwgen_kept_solids", default=None)
_SET_ASIDE: ContextVar[bool] = ContextVar("hwgen_set_aside_when_busy", default=False)
# each solid kept() gave, with the key it is kept under
_MADE_AS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class Busy(BaseException):
    """A kept solid another build is making now, met under :func:`setting_aside`: the caller sets
    the part it was building aside and comes back to it. A signal, not a failure: it derives from
    BaseException so that no handler of the kernel's failures (``except Exception``) takes it."""


KERNEL = ("cadquery", "cadquery-ocp")      # the libraries a solid (and its files) depends on


def key_of(kind: str, inputs) -> str:
    """The store's key of a kept solid (:func:`hwgen.cache.entry_key`): its kind and inputs, the
    export settings its files are written with, the code that makes solids and the CAD kernel's version."""
    return cache.entry_key("solid", (kind, inputs, settings()), code=cache.SOLID_CODE, libraries=KERNEL)


@contextmanager
def kept_in(store: cache.Store) -> Iterator[None]:
    """Within: :func:`kept` solids are read from and written to ``store``."""
    token = _ACTIVE.set(store)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


@contextmanager
def setting_aside() -> Iterator[None]:
    """Within: a kept solid whose lock another build holds raises :class:`Busy` instead of waiting."""
    token = _SET_ASIDE.set(True)
    try:
        yield
    finally:
        _SET_ASIDE.reset(token)


def kept(kind: str, inputs, make: Callable[[], object]):
    """``make()``, or the solid it made last time for the same ``kind`` and ``inputs``."""
    store = _ACTIVE.get()
    if store is None or not store.enabled:
        return make()
    key = key_of(kind, inputs)
    solid = _read(store, key)
    if solid is None:
        lock = store.try_lock(key) if _SET_ASIDE.get() else store.lock(key)   # waits while another makes it
        if lock is None:
            raise Busy(kind)
        with lock:
            solid = _read(store, key)
            if solid is None:
                made = make()
                # its volume and centroid with it: whoever reads it back finds it sound and measures
                # it for the manifest without integrating it again
                volume, com = mass_properties(made)
                data = write_brep(made)
                store.put_record(key, {"brep": store.put_bytes(data), "mass": [volume, list(com)]})
                # given out as every later reader gets it, read back from these bytes: a plane read
                # from BREP has its axes made orthogonal again, so a solid whose plane is not exactly
                # so (the end of the frame's worm's swept thread) writes a last digit differently
                # read back than as made (and again after each further round trip)
                solid = read_brep(data)
                known_mass(solid, (volume, com))
    _MADE_AS[solid] = key
    return solid


def made_as(solid) -> str | None:
    """The key :func:`kept` gave ``solid`` under (:func:`key_of`), None for a solid it did
    not give: parts whose solids have one key have one solid, made in whichever unit or process
    (the assembly holds it once)."""
    return _MADE_AS.get(solid)


def _read(store: cache.Store, key: str):
    rec = store.get_record(key)
    data = store.get_bytes(rec["brep"]) if isinstance(rec, dict) and isinstance(rec.get("brep"), str) else None
    if data is None:
        return None
    solid = read_brep(data)
    with contextlib.suppress(KeyError, TypeError, ValueError):      # measured again when asked
        volume, com = rec["mass"]
        known_mass(solid, (volume, com))
    return solid
