"""The process's freed heap handed back to the system."""
from __future__ import annotations


def trim() -> None:
    """glibc's malloc_trim(0) over every arena: the pages freed by VTK, numpy, manifold3d and the
    CAD kernel go back to the system (glibc keeps them otherwise, most of all in the arenas of
    threads that have finished their work, and a process's resident memory only grows); nothing
    where there is no glibc."""
    import ctypes
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass
