"""What the statics cannot say: the first bending mode of each tendon state, its frequency and its
damping, as robot.xml has them.

Linearisation. About a state's equilibrium q (from its keyframe, as a user of robot.xml starts
it), M ẍ + D ẋ + K x = 0 with M MuJoCo's mass matrix there (``mj_fullM``), K = −∂f/∂q and
D = −∂f/∂q̇ of MuJoCo's own forces (central differences: joint springs and damping, tendons,
servos, gravity). The modes are the eigenvalues λ of [[0, I], [−M⁻¹K, −M⁻¹D]]: natural frequency
|λ|/2π, damping ratio −Re λ/|λ|. The first bending mode is the lowest whose tip moves most along
z, the flexible direction (from the undamped problem K φ = ω² M φ, then the damped eigenvalue
nearest iω).

Ring-down. The check: the model released from q displaced along that mode's shape (the tip 1 mm
off along z) and stepped as it is, the tip's z fitted with a decaying cosine (scipy's curve_fit)
over :data:`RING_PERIODS` periods: frequency and damping ratio as the integrator has them.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.linalg import eig, eigh
from scipy.optimize import curve_fit

from . import measure

FD_VEL = 1e-6               # rad/s or m/s: central differences of MuJoCo's forces in q̇
RING_PERIODS = 8            # periods of the first mode a ring-down is fitted over
RING_AMPLITUDE_MM = 1.0     # the tip's initial offset along z


def _mujoco():
    import mujoco
    return mujoco


def mass_matrix(sim: measure.Sim, q: np.ndarray) -> np.ndarray:
    """MuJoCo's joint-space inertia at q (robot at rest), kg and kg·m²."""
    mj, m, d = _mujoco(), sim.model, sim.data
    d.qpos[:] = q
    d.qvel[:] = 0.0
    mj.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mj.mj_fullM(m, d, M)
    return M


def damping_matrix(sim: measure.Sim, q: np.ndarray) -> np.ndarray:
    """D = −∂f/∂q̇ at q, central differences (the velocity-quadratic forces cancel), symmetrised."""
    mj, m, d = _mujoco(), sim.model, sim.data
    n = m.nv
    D = np.empty((n, n))

    def force(v):
        d.qpos[:] = q
        d.qvel[:] = v
        mj.mj_forward(m, d)
        return d.qfrc_smooth + d.qfrc_constraint

    for i in range(n):
        e = np.zeros(n)
        e[i] = FD_VEL
        D[:, i] = -(force(e) - force(-e)) / (2 * FD_VEL)
    force(np.zeros(n))
    return 0.5 * (D + D.T)


def _tip_rows(sim: measure.Sim, q: np.ndarray) -> np.ndarray:
    mj, m, d = _mujoco(), sim.model, sim.data
    d.qpos[:] = q
    mj.mj_forward(m, d)
    jacp = np.zeros((3, m.nv))
    mj.mj_jacSite(m, d, jacp, None, sim.tip)
    return jacp


def _first(sim: measure.Sim, q: np.ndarray, K: np.ndarray, M: np.ndarray) -> tuple[float, np.ndarray, float]:
    """(ω², shape, the shape's tip motion along z) of the lowest undamped mode that moves the tip
    most along z."""
    w2, phi = eigh(K, M)
    tip = _tip_rows(sim, q) @ phi
    up = [i for i in range(len(w2)) if w2[i] > 0]
    k = next((i for i in up if abs(tip[2, i]) >= max(abs(tip[0, i]), abs(tip[1, i]))), up[0])
    return float(w2[k]), phi[:, k], float(tip[2, k])


def undamped_hz(sim: measure.Sim, q: np.ndarray) -> float:
    """The first bending mode's frequency at q without damping, Hz."""
    w2, _, _ = _first(sim, q, measure.stiffness_matrix(sim, q, measure.NONE), mass_matrix(sim, q))
    return math.sqrt(w2) / (2 * math.pi)


def first_bending(sim: measure.Sim, q: np.ndarray) -> dict:
    """The first bending mode at the equilibrium q (see the module's docstring): its frequency
    (Hz), damping ratio, undamped frequency, and its shape (for :func:`ring_down`)."""
    K = measure.stiffness_matrix(sim, q, measure.NONE)
    M = mass_matrix(sim, q)
    D = damping_matrix(sim, q)
    w2, phi, tip_z = _first(sim, q, K, M)
    omega = math.sqrt(w2)
    n = len(q)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    lam = eig(A, right=False)
    lam = lam[lam.imag > 0]
    near = lam[np.argmin(np.abs(lam - 1j * omega))]
    shape = phi * (RING_AMPLITUDE_MM * measure.MM / tip_z)
    return {"frequency_hz": float(abs(near) / (2 * math.pi)), "damping_ratio": float(-near.real / abs(near)),
            "undamped_hz": omega / (2 * math.pi), "shape": shape}


def _decay(t, c, a, sigma, omega, phase):
    return c + a * np.exp(-sigma * t) * np.cos(omega * t + phase)


def fit_ring(t: np.ndarray, z: np.ndarray, guess_hz: float) -> dict:
    """A decaying cosine fitted to z(t): its natural frequency (Hz) and damping ratio."""
    w = 2 * math.pi * guess_hz
    p0 = (float(np.mean(z)), float(z[0] - np.mean(z)), 0.01 * w, w, 0.0)
    (c, a, sigma, omega, _), _ = curve_fit(_decay, t, z, p0=p0, maxfev=20000)
    wn = math.hypot(omega, sigma)
    return {"frequency_hz": wn / (2 * math.pi), "damping_ratio": sigma / wn}


def ring_down(sim: measure.Sim, q: np.ndarray, mode: dict) -> dict:
    """The model released from q displaced along ``mode``'s shape and stepped as it is; the tip's z
    fitted (see the module's docstring)."""
    mj, m, d = _mujoco(), sim.model, sim.data
    d.qpos[:] = measure.moved(sim, q, mode["shape"])
    d.qvel[:] = 0.0
    d.qacc_warmstart[:] = 0.0
    mj.mj_forward(m, d)
    steps = int(math.ceil(RING_PERIODS / mode["frequency_hz"] / m.opt.timestep))
    z = np.empty(steps)
    for i in range(steps):
        mj.mj_step(m, d)
        z[i] = d.site_xpos[sim.tip][2]
    t = np.arange(1, steps + 1) * m.opt.timestep
    try:
        fitted = fit_ring(t, z / measure.MM, mode["frequency_hz"])
    except RuntimeError as e:                       # curve_fit found no decaying cosine
        fitted = {"frequency_hz": None, "damping_ratio": None, "failed": str(e)}
    return {**fitted, "seconds": steps * m.opt.timestep}
