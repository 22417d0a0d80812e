"""The process's freed heap handed back to the system."""
from __future__ import annotations

import contextlib


def trim() -> None:
    """glibc's malloc_trim(0) over every arena: the pages freed by VTK, numpy, manifold3d and the
    CAD kernel go back to the system (glibc keeps them otherwise, most of all in the arenas of
    threads that have finished their work, and a process's resident memory only grows); nothing
    where there is no glibc."""
    import ctypes
    with contextlib.suppress(OSError, AttributeError):     # no glibc: nothing to trim
        ctypes.CDLL("libc.so.6").malloc_trim(0)
