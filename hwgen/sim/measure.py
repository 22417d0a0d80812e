"""The MuJoCo model measured as a lab would use it, read back from robot.xml by its names.

Equilibrium. MuJoCo's own forces (``mj_forward`` with the robot at rest: joint springs, tendon
springs, the drum servos, gravity, applied forces) are driven to zero by Newton's method on
their Jacobian (central differences of MuJoCo's generalised forces), gravity brought in over a
few steps from the weightless robot so each solve starts near its answer. The stiffness at a
point is force over displacement of a small push there, j K⁻¹ jᵀ with K that Jacobian and j the
point's (``mj_jacSite``): the tangent stiffness, as the statics takes it from its Hessian. The
dynamics are checked apart: the model stepped as it is, from its keyframe, for
:data:`DYNAMICS_S` under gravity.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

MM = 1e-3
DYNAMICS_S = 2.0                  # s of simulated time under gravity, from a keyframe
GRAVITY_STEPS = (0.25, 0.5, 0.75, 1.0)
FD_STEP = 1e-7                    # rad or m: central differences of MuJoCo's forces
NEWTON_TOL = 1e-11                # rad or m: the last Newton step is this small
NEWTON_ITER = 60


def _mujoco():
    import mujoco
    return mujoco


@dataclass(frozen=True)
class Extra:
    """Loads besides the model's own: tendons pulled with a tension (name -> N, as a
    tension-controlled drive pulls them) and a force at the tip site (N, world frame)."""

    pulls: tuple = ()              # (tendon, N) pairs
    push: tuple | None = None


NONE = Extra()


@dataclass
class Sim:
    """A loaded robot.xml and the names the measurements read."""

    model: object
    data: object
    tip: int                       # the tip site
    gravity: np.ndarray

    @staticmethod
    def load(path) -> "Sim":
        mj = _mujoco()
        m = mj.MjModel.from_xml_path(str(path))
        return Sim(m, mj.MjData(m), m.site("tip").id, np.array(m.opt.gravity))

    def keyframe(self, name: str) -> None:
        mj = _mujoco()
        mj.mj_resetDataKeyframe(self.model, self.data, self.model.key(name).id)
        mj.mj_forward(self.model, self.data)

    def tendon_jacobian(self, name: str) -> np.ndarray:
        """d(length)/dq of a tendon at the data's pose (after a forward pass)."""
        mj, m = _mujoco(), self.model
        dense = np.zeros((m.ntendon, m.nv))
        mj.mju_sparse2dense(dense, self.data.ten_J, m.ten_J_rownnz, m.ten_J_rowadr, m.ten_J_colind)
        return dense[m.tendon(name).id]


def _forces(sim: Sim, q: np.ndarray, extra: Extra) -> np.ndarray:
    """The net generalised force on the robot at rest at ``q`` (zero at an equilibrium), with
    ``extra``'s loads."""
    mj, m, d = _mujoco(), sim.model, sim.data
    d.qpos[:] = q
    d.qvel[:] = 0.0
    d.qfrc_applied[:] = 0.0
    mj.mj_forward(m, d)
    f = d.qfrc_smooth + d.qfrc_constraint
    for t, tau in extra.pulls:
        f = f - tau * sim.tendon_jacobian(t)
    if extra.push is not None:
        jacp = np.zeros((3, m.nv))
        mj.mj_jacSite(m, d, jacp, None, sim.tip)
        f = f + np.asarray(extra.push, float) @ jacp
    return f


def moved(sim: Sim, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """The coordinates q (qpos) moved by dq (a velocity-space step: ball joints turn by it)."""
    out = np.array(q, float)
    _mujoco().mj_integratePos(sim.model, out, np.asarray(dq, float), 1.0)
    return out


def stiffness_matrix(sim: Sim, q: np.ndarray, extra: Extra) -> np.ndarray:
    """K = −d(forces)/dq at q, central differences, symmetrised."""
    n = sim.model.nv
    K = np.empty((n, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = FD_STEP
        K[:, i] = -(_forces(sim, moved(sim, q, e), extra) - _forces(sim, moved(sim, q, -e), extra)) / (2 * FD_STEP)
    _forces(sim, q, extra)
    return 0.5 * (K + K.T)


def _newton(sim: Sim, q: np.ndarray, extra: Extra) -> tuple[np.ndarray, int, float]:
    f = _forces(sim, q, extra)
    for it in range(NEWTON_ITER):
        K = stiffness_matrix(sim, q, extra)
        w = 1.0 / np.sqrt(np.maximum(np.abs(np.diag(K)), 1e-30))
        try:
            dq = np.linalg.solve(K, f)
        except np.linalg.LinAlgError:
            dq = np.linalg.lstsq(K, f, rcond=None)[0]
        step, size = 1.0, np.linalg.norm(f * w)
        while step > 1e-4:
            f_new = _forces(sim, moved(sim, q, step * dq), extra)
            if np.linalg.norm(f_new * w) < size or np.max(np.abs(step * dq)) < NEWTON_TOL:
                break
            step /= 2
        q, f = moved(sim, q, step * dq), f_new
        if np.max(np.abs(step * dq)) < NEWTON_TOL:
            return q, it + 1, float(np.max(np.abs(f)))
    return q, NEWTON_ITER, float(np.max(np.abs(f)))


def settle(sim: Sim, q0: np.ndarray, extra: Extra = NONE) -> tuple[np.ndarray, int, float]:
    """The robot at rest from ``q0`` under its loads as they are now (gravity, ctrl, ``extra``), by
    Newton's method: (coordinates, iterations, the largest generalised force left)."""
    return _newton(sim, q0, extra)


def equilibrium(sim: Sim, q0: np.ndarray, extra: Extra = NONE) -> dict:
    """The robot at rest under gravity and ``extra`` from ``q0`` (the keyframe's pose), gravity
    brought in over :data:`GRAVITY_STEPS` from the weightless robot: its coordinates, iterations,
    the largest generalised force left."""
    m = sim.model
    q, its = np.array(q0, float), 0
    try:
        for scale in (0.0, *GRAVITY_STEPS):
            m.opt.gravity[:] = sim.gravity * scale
            q, n, left = _newton(sim, q, extra)
            its += n
    finally:
        m.opt.gravity[:] = sim.gravity
    _forces(sim, q, extra)
    return {"q": q, "iterations": its, "residual": left}


def tip_stiffness(sim: Sim, q: np.ndarray, direction, extra: Extra = NONE) -> float:
    """Force over displacement of a small push at the tip site along ``direction``, N/mm (the
    tangent: j K⁻¹ jᵀ)."""
    return tip_stiffnesses(sim, q, [direction], extra)[0]


def tip_stiffnesses(sim: Sim, q: np.ndarray, directions, extra: Extra = NONE) -> list[float]:
    """:func:`tip_stiffness` along each of ``directions`` (world), from one stiffness matrix."""
    mj, m, d = _mujoco(), sim.model, sim.data
    K = stiffness_matrix(sim, q, extra)
    jacp = np.zeros((3, m.nv))
    mj.mj_jacSite(m, d, jacp, None, sim.tip)
    out = []
    for u in directions:
        j = np.asarray(u, float) @ jacp
        out.append(float(1.0 / (j @ np.linalg.solve(K, j)) * MM))
    return out


def tip_mm(sim: Sim) -> list[float]:
    return [float(v) / MM for v in sim.data.site_xpos[sim.tip]]


def centre_line(sim: Sim) -> dict:
    """The strip's centre line where it is hinged, base to tip (y, z, mm)."""
    m, d = sim.model, sim.data
    ids = [i for i in range(m.nbody) if m.body(i).name.startswith("strip_")]
    pts = [d.xpos[i] / MM for i in ids] + [d.site_xpos[sim.tip] / MM]
    return {"y_mm": [float(p[1]) for p in pts], "z_mm": [float(p[2]) for p in pts],
            "x_mm": [float(p[0]) for p in pts]}


def dynamics(sim: Sim, key: str, seconds: float = DYNAMICS_S) -> dict:
    """The model stepped as it is from keyframe ``key`` under gravity: whether it stays finite, where
    the tip goes, and how much faster than real time it steps on this core (CPU time of the steps)."""
    mj, m, d = _mujoco(), sim.model, sim.data
    sim.keyframe(key)
    steps = int(round(seconds / m.opt.timestep))
    lowest, finite = 0.0, True
    cpu, chunk = 0.0, max(1, steps // 20)
    done = 0
    while done < steps:
        n = min(chunk, steps - done)
        t = time.process_time()
        mj.mj_step(m, d, nstep=n)
        cpu += time.process_time() - t
        done += n
        finite = finite and bool(np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all())
        if not finite:
            break
        lowest = min(lowest, float(d.site_xpos[sim.tip][2]))
    return {"state": key, "seconds": done * m.opt.timestep, "finite": finite, "steps": done,
            "tip_mm": tip_mm(sim), "lowest_tip_z_mm": lowest / MM,
            "cpu_s": cpu, "real_time_factor": done * m.opt.timestep / cpu if cpu > 0 else None}
