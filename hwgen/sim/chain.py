"""The strip as a chain of rigid links and elastic hinges, cut and sprung as the statics cuts and
springs it.

The statics (:class:`hwgen.model.statics.Model`) cuts the strip into segments of at most
``h_max`` (breaking at every disk's plate and hub, which hold it rigid or stiffer) and joins
them at each segment's middle by an elastic joint of compliance c_a = ∫ ds / K_a about each
axis: K = E·h·t³/12 about x (the flexible direction), G·J about y (torsion), E·t·h³/12 about z
(the stiff direction), the hub's section added where a hub is glued on, none over a plate.
Here the same model is built at :data:`SIM_H_MAX` and its compliances read off as they are:

* a hinge about x at every joint, of stiffness 1/c_x (the direction the robot bends in, large
  deflections included, so a hinge every few millimetres);
* one hinge about y and one about z per stretch of strip between two rigid plates (between
  two disks), of stiffness 1 / Σ c_y and 1 / Σ c_z over its joints. Between two disks nothing
  twists the strip or pushes it sideways (tendons act only at the eyelets, on the disks; the
  strip's own weight acts through its centre line), so the twist across the stretch is the same
  taken at one hinge as spread over its joints, and the sideways bend is to second order in
  the stretch's length, where the stiff direction's own deflection is 10⁻⁴ of the flexible
  one's. It keeps the prototype's chain at 84 degrees of freedom instead of 180, and MuJoCo's
  cost on a serial chain grows about as their cube.

The y and z hinges sit at the stretch's compliance-weighted middle (a link of their own where
no x hinge is there): placed at the nearest x hinge instead, up to half a link off, the stiff
direction came out 2.4 % soft on a strip held by plates every 22.5 mm.
Lengths mm, stiffness N·mm/rad.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import statics as st

SIM_H_MAX = 5.0         # mm: longest link; the tip stiffness moves by under 0.1 % from the statics' 1.5 mm


@dataclass(frozen=True)
class Hinge:
    """One place where the chain bends: arc length ``s`` and the stiffness of each hinge there
    (None: no hinge about that axis here)."""

    s: float
    flex: float | None
    twist: float | None
    side: float | None


def hinges(robot: st.Robot, h_max: float = SIM_H_MAX) -> list[Hinge]:
    """The chain's hinges, base to tip (see the module's docstring): one about x at each of the
    statics' joints, and one about y and one about z at each stretch's compliance-weighted middle."""
    model = st.Model(robot, h_max)
    comp = model.compliance
    segs = np.asarray(model.joint_seg)
    nodes = model.nodes_s
    mids = 0.5 * (nodes[segs] + nodes[segs + 1])
    runs: list[list[int]] = []
    for j, k in enumerate(segs):
        if runs and segs[runs[-1][-1]] == k - 1:
            runs[-1].append(j)
        else:
            runs.append([j])
    at: dict[float, dict] = {float(mids[j]): {"flex": 1.0 / comp[k, 0] if comp[k, 0] > 0 else None}
                             for j, k in enumerate(segs)}
    for run in runs:
        ks = segs[run]
        for axis, name in ((1, "twist"), (2, "side")):
            c = comp[ks, axis]
            if c.sum() <= 0:
                continue
            centre = float(np.sum(c * mids[run]) / c.sum())
            near = min(at, key=lambda s_: abs(s_ - centre))
            key = near if abs(near - centre) < 1e-9 else centre
            at.setdefault(key, {})[name] = 1.0 / float(c.sum())
    return [Hinge(s_, v.get("flex"), v.get("twist"), v.get("side")) for s_, v in sorted(at.items())]
