"""hwgen's numba kernels compiled onto disk ahead (``python -m hwgen.sim.kernels``, run by ``make
bytecode``), as the bytecode is: numba compiles a kernel the first time a process calls it and keeps
it in ``__pycache__`` beside its source (``cache=True``), which on a fresh checkout costs the first
build, the first test worker (and each worker that gets there before the other wrote it) about 25 s
of CPU for the taut path and the bench's push, and a few more for the Cosserat rod.

Each kernel is called once on a tiny problem through the function that calls it in hwgen: numba
compiles one version per argument type (dtype, dimensions, memory layout), and these callers fix
every argument's (contiguous float64 and int64 arrays), so the version compiled here is the one a
build loads. What the tiny problems return is not used. Loading what is already on disk takes
about a second.
"""
from __future__ import annotations

import numpy as np


def _taut() -> None:
    """:func:`hwgen.model.taut.sweep` and :func:`~hwgen.model.taut.shortest`: one tendon straight
    through two disks 10 mm apart, 5 mm off the strip."""
    from ..model import taut
    basis = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])          # the disk plane's x and z
    ch = taut.Chains(stations=np.array([0.0, 10.0]), C=np.array([[[5.0, 0.0, 0.0]] * 2]),
                     E=np.array([[basis, basis]]), r=np.full((1, 2), 0.5), hole_disk=np.array([0, 1]),
                     dy=np.zeros((1, 2)), chain=np.array([[0, 1]]), anchor=np.array([[[5.0, -2.0, 0.0]]]),
                     end=np.array([[[5.0, 2.0, 0.0]]]))
    taut.sweep(ch, [0.0, 5.0], 10.0)
    taut.shortest([5.0, -2.0, 0.0], [5.0, 12.0, 0.0], np.array([[5.0, 0.0, 0.0], [5.0, 10.0, 0.0]]),
                  np.array([basis, basis]), np.full(2, 0.5))


def _push() -> None:
    """:func:`hwgen.model.push.repeat`: a block on a spring carrying one eyelet of a tensioned line
    (its base-side segment lengthened, its tip-side one shortened by the block's travel), pushed
    out 1 mm and back."""
    from scipy.linalg import cho_factor

    from ..model import friction, push
    k0, ka, kb, tension = 2.0, 30.0, 10.0, 5.0
    stuck, free = np.array([[k0 + ka + kb]]), np.array([[k0]])
    b = friction.Bounds(eq=None, tendons=("T",), rows=np.array([[1.0], [-1.0]]), springs=np.array([ka, kb]),
                        tension=np.array([tension, tension]), owner=("T", "T"), eyelets=np.array([[0, 1]]),
                        turns=np.array([0.8]), factors={"stuck": cho_factor(stuck), "none": cho_factor(free)})
    push.repeat(push.lines(b, 0.2, np.array([[1.0]])), 0, 1.0, 1)


def _cosserat() -> None:
    """:func:`hwgen.sim.cosserat_kernel.rk4` as :mod:`hwgen.sim.cosserat` calls it: one straight
    state (at the origin, unturned, unloaded) over 1 mm in two steps."""
    from .cosserat_kernel import rk4
    state = np.zeros((1, 13))
    state[0, 3] = 1.0                                               # the quaternion's w
    rk4(state, 1.0, 2, np.ones(3), np.ones(3), np.zeros(3), np.empty((2, 3)))


def compile_all() -> None:
    _taut()
    _push()
    _cosserat()


if __name__ == "__main__":
    compile_all()
