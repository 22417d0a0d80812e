"""The `lengths` level: what the plan alone says about many variants at once (numpy and the taut
kernel; no CadQuery).

Variants that share the robot's skeleton (stations, backbone length, disk thicknesses, tendon
count, sweeps) are evaluated together, as arrays with a leading variant axis:

- the eyelet centres of eq. (3) at every station (:func:`hwgen.model.routing.tendon_paths`);
- each eyelet hole sized as :func:`hwgen.model.plan.make_plan` sizes it: its axis on the bisector of the
  tendon's straight segments (or the disk normal), shared where tendons meet, its diameter
  d/cos α + t·tan α + clearance for the worst angle α over ``disks.eyelets.sweep_deg``. The tip
  disk is sized without the turn toward the tensioner's drum (that needs the tensioner's
  layout, which this level does not make): the full plan's tip eyelets can only be larger.
  Where holes sized so would run into each other the disk takes the plan's own holes
  (:func:`hwgen.model.plan.eyelet_holes`: one opening around those tendons);
- eq. (2) through the hole centres over ``hwgen check``'s bending sweep (±check angle, its step);
- the taut path of the nominal print through those holes (:func:`hwgen.model.taut.sweep`, every
  variant of a group a "sample" of one call), from the hole on the base disk's outer face to a
  point :data:`END_RUN_MM` beyond the tip disk along the backbone (where ``hwgen check`` ends a
  tendon that has no tensioner run);
- plan-level clearances: the least wall between two holes of a disk, a hole and the disk's rim,
  a hole and the strip's slot (a hole inside the slot is a strip crossing, counted apart; no wall
  is left between tendons routed into one opening);
- the disks' and the strip's mass from their plan volumes (plates less holes and slot; hubs,
  tensioner and mount not included).
"""
from __future__ import annotations

import json
from collections import defaultdict

import numpy as np

from ..checks.lengths import sweep_angles
from ..checks.taut import END_RUN_MM
from ..model import kinematics as kin
from ..model import taut
from ..model.fixing import disk_thicknesses
from ..model.materials import printed_density
from ..model.routing import TendonPath, tendon_paths
from ..model.scatter import basis
from ..model.specs import slot_size
from ..model.holes import hole_diameter
from ..model.plan import SAME_POSITION_MM, SWEEP_STEP_DEG as SIZING_STEP_DEG, eyelet_holes
from ..params import Design
from .records import Failure

# what hwgen check and the plan use, so a variant's figures are theirs
check_angles = sweep_angles


def _skeleton(d: Design) -> tuple:
    """What variants evaluated together must share."""
    return (d.stations, d.backbone.length, disk_thicknesses(d), sum(2 if t.routing.mirror else 1 for t in d.tendons),
            d.disks.eyelets.sweep_deg, d.disks.eyelets.axis, d.check_angle_deg, d.check.step_deg)


def _placed(stations, kappa, x, z):
    """Eyelet points in robot coordinates, eq. (1): (..., K, N) each of X, Y, Z for points (..., 1, N)."""
    R, p = kin.frames(stations, kappa)                     # (K, N, 3, 3), (K, N, 3)
    c, s = R[..., 1, 1], R[..., 2, 1]
    return np.broadcast_to(x, np.broadcast_shapes(x.shape, c.shape)), p[..., 1] - s * z, p[..., 2] + c * z


def centre_lengths(stations, kappa, xz: np.ndarray) -> np.ndarray:
    """eq. (2) for points ``xz`` (..., N, 2) at each curvature: (..., K)."""
    x, z = xz[..., None, :, 0], xz[..., None, :, 1]
    X, Y, Z = _placed(stations, kappa, x, z)
    return np.sqrt(np.diff(X, axis=-1) ** 2 + np.diff(Y, axis=-1) ** 2 + np.diff(Z, axis=-1) ** 2).sum(axis=-1)


def _directions(stations, kappa, xz):
    """Unit segment directions into and out of each disk in its own frame: (..., K, N, 3) each, NaN
    where there is no segment (as :func:`hwgen.model.kinematics.segment_directions_local`).

    The robot bends about x, so a segment's x run does not change with the curvature: it is
    worked out once, and each component is filled in place rather than stacked."""
    R, p = kin.frames(stations, kappa)                       # (K, N, 3, 3), (K, N, 3)
    c, s = R[..., 1, 1], R[..., 2, 1]                        # (K, N)
    x, z = xz[..., None, :, 0], xz[..., None, :, 1]          # (..., 1, N)
    dx = np.diff(x, axis=-1)                                 # (..., 1, N-1)
    dy, dz = np.diff(p[..., 1] - s * z, axis=-1), np.diff(p[..., 2] + c * z, axis=-1)   # (..., K, N-1)
    n = np.sqrt(dx * dx + dy * dy + dz * dz)
    dx, dy, dz = dx / n, dy / n, dz / n
    shape = dy.shape[:-1] + (len(stations), 3)
    into, out = np.empty(shape), np.empty(shape)
    into[..., 0, :] = out[..., -1, :] = np.nan               # no segment into the base disk, none out of the tip
    for v, at, cc, ss in ((into, np.s_[1:], c[:, 1:], s[:, 1:]), (out, np.s_[:-1], c[:, :-1], s[:, :-1])):
        v[..., at, 0] = dx                                   # R_x(θ)ᵀ (dx, dy, dz)
        v[..., at, 1] = cc * dy + ss * dz
        v[..., at, 2] = -ss * dy + cc * dz
    return into, out


def _unique(arr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct items along the first axis (by their bytes) and each item's index among them."""
    keys: dict[bytes, int] = {}
    inv = np.empty(len(arr), int)
    for i, a in enumerate(arr):
        inv[i] = keys.setdefault(np.ascontiguousarray(a).tobytes(), len(keys))
    first = np.empty(len(keys), int)
    first[inv[::-1]] = np.arange(len(arr))[::-1]
    return arr[first], inv


def _holes(ds: list[Design], paths: list[list[TendonPath]], stations, xz: np.ndarray, thick: np.ndarray):
    """Hole axes (V, T, N, 3), diameters (V, T, N) and centres (V, T, N, 2) as the plan sizes and
    places them, per tendon (a hole repeated for each of its tendons), and the masks (V, N, T, T)
    of tendon pairs that pass one hole and of those among them routed apart (an overlap).

    The directions over the sizing sweep are worked out once per distinct tendon path (a sweep
    over one tendon's routing repeats every other tendon in every variant); a hole shared by
    several tendons is then sized against its shared axis, disk by disk. Where holes sized so
    would run into each other the plan merges them into one opening
    (:func:`hwgen.model.plan.eyelet_holes`); those few disks take the plan's own holes.

    ``ds`` share their process, tendon material, disks and strip; ``paths``: each one's tendons."""
    d = ds[0]
    a = d.disks.eyelets.sweep_deg
    kap = kin.kappas_for_angles(np.linspace(-a, a, int(round(2 * a / SIZING_STEP_DEG)) + 1), d.backbone.length)
    V, T, N = xz.shape[:3]
    uxz, inv = _unique(xz.reshape(V * T, N, 2))
    into, out = _directions(stations, kap, uxz)             # (U, K, N, 3)
    if d.disks.eyelets.axis == "normal":
        own = np.broadcast_to(np.array([0.0, 1.0, 0.0]), (len(uxz), N, 3))
    else:
        rest_in, rest_out = _directions(stations, np.zeros(1), uxz)
        b = np.nan_to_num(rest_in[:, 0]) + np.nan_to_num(rest_out[:, 0])
        own = b / np.linalg.norm(b, axis=-1, keepdims=True)                  # (U, N, 3)

    def worst_against(u, axes):          # (len(u), N): largest angle of tendons u to axes (len(u), N, 3)
        w = np.zeros(axes.shape[:2])
        for seg in (into[u], out[u]):
            cos = np.abs(np.einsum("uknj,unj->ukn", seg, axes))
            least = np.min(np.where(np.isnan(cos), np.inf, cos), axis=1)     # the largest angle: arccos falls
            w = np.fmax(w, np.where(np.isinf(least), -1, np.arccos(np.clip(least, -1, 1))))
        return w

    uworst = worst_against(np.arange(len(uxz)), own)
    ax = own[inv].reshape(V, T, N, 3).copy()
    worst = uworst[inv].reshape(V, T, N).copy()
    gap = np.moveaxis(np.linalg.norm(xz[:, :, None] - xz[:, None, :], axis=-1), -1, 1)   # (V, N, T, T)
    share = gap < SAME_POSITION_MM
    uidx = inv.reshape(V, T)
    memo: dict[tuple, tuple[np.ndarray, float]] = {}
    for v, i in zip(*np.nonzero(share.sum(axis=(2, 3)) > T)):
        for t in range(T):
            members = list(np.flatnonzero(share[v, i, t]))
            if len(members) < 2 or members[0] != t:
                continue
            key = (i, *uidx[v, members])
            if key not in memo:
                u = uidx[v, members]
                g = own[u, i].sum(axis=0)
                g /= np.linalg.norm(g)
                w = -1.0
                for seg in (into[u, :, i], out[u, :, i]):          # (members, K, 3)
                    ang = np.arccos(np.clip(np.abs(seg @ g), -1, 1))
                    if not np.all(np.isnan(ang)):
                        w = max(w, float(np.nanmax(ang)))
                memo[key] = (g, max(w, 0.0))
            ax[v, members, i], worst[v, members, i] = memo[key]   # a shared hole: the worst of its tendons
    p = d.process
    dia = hole_diameter(d.tendon_material.diameter, thick, worst, p.hole_clearance, p.min_hole)
    centre = xz.copy()
    joined = share.copy()
    r = np.moveaxis(dia, 1, 2) / 2                                          # (V, N, T)
    clash = ~share & (gap < r[..., :, None] + r[..., None, :])
    for v in np.flatnonzero(clash.any(axis=(1, 2, 3))):
        names = [q.name for q in paths[v]]
        u = uidx[v]               # the directions this level already has, by tendon
        rest = {q.name: own[u[t]] for t, q in enumerate(paths[v])}
        sweeps = {q.name: (into[u[t]], out[u[t]]) for t, q in enumerate(paths[v])}
        for i, holes in eyelet_holes(ds[v], paths[v], np.flatnonzero(clash[v].any(axis=(1, 2))), rest, sweeps).items():
            for h in holes:
                k = np.array([names.index(t) for t in h.tendons])
                ax[v, k, i], dia[v, k, i], centre[v, k, i] = h.axis, h.diameter, (h.x, h.z)
                joined[v, i, k[:, None], k[None, :]] = True
    return ax, dia, centre, joined, joined & ~share


def _clearances(d: Design, xz: np.ndarray, dia: np.ndarray, joined: np.ndarray,
                overlap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(V,) least wall of any disk (hole to hole, hole to rim, hole to slot) and (V,) holes inside
    the slot, for holes centred at ``xz`` (V, T, N, 2). Two tendons of one hole have no wall between
    them: none is needed where they share a position, and none is left (0) where the hole joins
    tendons routed apart, as ``hwgen check`` counts ``eyelet.wall.eyelet``."""
    V, T, N = dia.shape
    r = dia / 2                                              # (V, T, N)
    pts = np.moveaxis(xz, 1, 2)                              # (V, N, T, 2)
    rr = np.moveaxis(r, 1, 2)                                # (V, N, T)
    dist = np.linalg.norm(pts[:, :, :, None] - pts[:, :, None, :], axis=-1)
    wall = dist - rr[..., :, None] - rr[..., None, :]
    wall = np.where(overlap, 0.0, np.where(joined, np.inf, wall))   # one hole (and a hole with itself)
    least = wall.reshape(V, -1).min(axis=1)
    R = d.disks.outer_diameter / 2
    rim = R - (np.linalg.norm(pts, axis=-1) + rr)
    least = np.minimum(least, rim.reshape(V, -1).min(axis=1))
    sw, st = slot_size(d.backbone.height, d.backbone.thickness, d.disks.slot_clearance)
    hw, ht = sw / 2, st / 2
    ox = np.maximum(np.abs(pts[..., 0]) - hw, 0.0)
    oz = np.maximum(np.abs(pts[..., 1]) - ht, 0.0)
    inside = (ox == 0) & (oz == 0)
    slot = np.where(inside, np.inf, np.hypot(ox, oz) - rr)
    least = np.minimum(least, slot.reshape(V, -1).min(axis=1))
    return least, inside.reshape(V, -1).sum(axis=1)


def _mass(d: Design, dia: np.ndarray, joined: np.ndarray, thick: np.ndarray) -> np.ndarray:
    """(V,) g: disk plates less their holes (a hole of several tendons once) and slot, and the strip."""
    rho, _ = printed_density(d.process)
    first = ~np.triu(joined, 1).any(axis=2)                  # (V, N, T): the first tendon of its hole
    holes = (np.pi * (np.moveaxis(dia, 1, 2) / 2) ** 2 * first).sum(axis=2)    # (V, N) mm²
    sw, st = slot_size(d.backbone.height, d.backbone.thickness, d.disks.slot_clearance)
    plate = np.pi * (d.disks.outer_diameter / 2) ** 2 - sw * st
    disks = ((plate - holes) * thick).sum(axis=1) * rho / 1000
    bb = d.backbone
    strip = bb.height * bb.thickness * (bb.length + bb.extra_tip + (bb.extra_base or 0.0)) * bb.density_g_cm3 / 1000
    return disks + strip


def evaluate(designs: list[Design]) -> list[dict]:
    """The lengths level's figures for each design, in order (see the module's docstring)."""
    groups: dict[tuple, list[int]] = defaultdict(list)
    for i, d in enumerate(designs):
        groups[_skeleton(d)].append(i)
    out: list[dict | None] = [None] * len(designs)
    for idx in groups.values():
        for i, row in zip(idx, _group([designs[i] for i in idx])):
            out[i] = row
    return out


def _group(ds: list[Design]) -> list[dict]:
    d0 = ds[0]
    stations = np.asarray(d0.stations, float)
    thick = np.asarray(disk_thicknesses(d0), float)
    paths = [tendon_paths(d) for d in ds]
    xz = np.stack([np.stack([p.points for p in ps]) for ps in paths])            # (V, T, N, 2)
    V, T, N = xz.shape[:3]
    ang = check_angles(d0.check_angle_deg, d0.check.step_deg)
    k0 = int(np.flatnonzero(ang == 0)[0])
    uxz, inv = _unique(xz.reshape(V * T, N, 2))
    Lc = centre_lengths(stations, kin.kappas_for_angles(ang, d0.backbone.length), uxz)   # (U, K)
    centre = np.abs(Lc - Lc[..., k0:k0 + 1]).max(axis=-1)[inv].reshape(V, T)
    # hole sizing, clearances and mass take each design's process and material: per design where they differ
    ax = np.empty((V, T, N, 3))
    dia = np.empty((V, T, N))
    centre_xz = np.empty((V, T, N, 2))
    overlaps = np.empty(V, int)
    sliding: list[list[str]] = [[] for _ in range(V)]
    least = np.empty(V)
    crossings = np.empty(V, int)
    mass = np.empty(V)
    for key, members in _by(ds, lambda d: (d.process, d.tendon_material.diameter, d.disks, d.backbone)).items():
        m = np.asarray(members)
        d = ds[m[0]]
        a_, dia_, c_, joined, overlap = _holes([ds[k] for k in m], [paths[k] for k in m], stations, xz[m], thick)
        ax[m], dia[m], centre_xz[m] = a_, dia_, c_
        least[m], crossings[m] = _clearances(d, c_, dia_, joined, overlap)
        mass[m] = _mass(d, dia_, joined, thick)
        overlaps[m] = overlap.any(axis=(2, 3)).sum(axis=1)
        for j, k in enumerate(m):
            sliding[k] = shared_sliding([q.name for q in paths[k]], [q.channel for q in paths[k]],
                                        ds[k].tensioner.actuating_channel, joined[j])
    # the nominal print's taut path: each distinct chain (a tendon's holes, anchor and end) one sample
    free = np.array([[d.tendon_material.diameter] for d in ds])                 # (V, 1)
    chains = np.concatenate([centre_xz.reshape(V, T, -1), ax.reshape(V, T, -1), dia,
                             np.broadcast_to(free[:, :, None], (V, T, 1))], axis=-1).reshape(V * T, -1)
    uch, cinv = _unique(chains)
    S = len(uch)
    uxz_, uax = uch[:, :2 * N].reshape(S, N, 2), uch[:, 2 * N:5 * N].reshape(S, N, 3)
    udia, ud = uch[:, 5 * N:6 * N], uch[:, 6 * N]
    C = np.zeros((S, N, 3))
    C[..., 0], C[..., 2] = uxz_[..., 0], uxz_[..., 1]
    r = np.maximum(0.0, (udia - ud[:, None]) / 2)
    anchor = np.stack([uxz_[:, 0, 0], np.full(S, -thick[0] / 2), uxz_[:, 0, 1]], axis=-1)[:, None]
    end = np.stack([uxz_[:, -1, 0], np.full(S, thick[-1] / 2 + END_RUN_MM), uxz_[:, -1, 1]], axis=-1)[:, None]
    ch = taut.Chains(stations=stations, C=C, E=basis(uax), r=r, hole_disk=np.arange(N), dy=np.zeros((S, N)),
                     chain=np.arange(N)[None], anchor=anchor, end=end)
    L, L0, _ = taut.sweep(ch, ang, d0.backbone.length)
    tautd = np.abs(L[:, 0] - L0[:, 0, None]).max(axis=-1)[cinv].reshape(V, T)
    L0 = L0[:, 0][cinv].reshape(V, T)
    rows = []
    for v, d in enumerate(ds):
        tendons = [{"name": p.name, "channel": p.channel, "budget_mm": p.budget_mm,
                    "centre_mm": float(centre[v, t]), "taut_mm": float(tautd[v, t]),
                    "rest_mm": float(L0[v, t])} for t, p in enumerate(paths[v])]
        rows.append({"tendons": tendons, "clearance_mm": float(least[v]), "strip_crossings": int(crossings[v]),
                     "overlapping_eyelets": int(overlaps[v]), "shared_sliding": sliding[v],
                     "shared_sliding_severity": d.check.shared_sliding,
                     "mass_g": float(mass[v]), "min_wall_mm": d.process.min_wall})
    return rows


def shared_sliding(names: list[str], channels: list[str], actuating: str, joined: np.ndarray) -> list[str]:
    """"DRIVEN+OTHER@station" for every disk past the base (where the lines end in their seats)
    on which a tendon of the actuating channel passes one opening with another tendon (``joined``
    (N, T, T): tendons of one hole), as ``hwgen check``'s ``eyelet.shared_sliding`` finds it."""
    out = []
    for i, t, u in zip(*np.nonzero(joined[1:])):
        if t != u and channels[t] == actuating and (channels[u] != actuating or t < u):
            out.append(f"{names[t]}+{names[u]}@{i + 1}")
    return out


def _by(items, key) -> dict:
    out: dict = defaultdict(list)
    for i, it in enumerate(items):
        out[key(it)].append(i)
    return out


def verdict(row: dict) -> tuple[str, str, dict]:
    """(verdict, message, summary figures) of a lengths row: a budgeted tendon over its budget by
    eq. (2) through the hole centres, or a wall thinner than the process's minimum, fails."""
    budgeted = [t for t in row["tendons"] if t["budget_mm"] is not None]
    fails = [f.message for f in failures(row) if f.fails]
    figures = {"centre_mm": max((t["centre_mm"] for t in budgeted), default=None),
               "taut_mm": max((t["taut_mm"] for t in budgeted), default=None),
               "decoupled": all(t["centre_mm"] <= t["budget_mm"] for t in budgeted),
               "clearance_mm": row["clearance_mm"], "mass_g": row["mass_g"],
               "per_tendon": json.dumps(row["tendons"])}
    return ("fail" if fails else "pass"), "; ".join(fails), figures


def failures(row: dict) -> list[Failure]:
    """What fails in a lengths row, one :class:`~hwgen.sweep.records.Failure` a rule: a budgeted tendon
    over its budget by eq. (2) through the hole centres (``tendon.length``), tendons routed into one
    opening (``eyelet.overlap``), a driven tendon through one opening with another
    (``eyelet.shared_sliding``), a wall under the process's minimum (``eyelet.wall``)."""
    out = [Failure(id="tendon.length", message=f"{t['name']} changes {t['centre_mm']:.3f} mm by eq. (2), budget "
                                               f"{t['budget_mm']:g} mm",
                   measured=t["centre_mm"], limit=t["budget_mm"], where=t["name"])
           for t in row["tendons"] if t["budget_mm"] is not None and t["centre_mm"] > t["budget_mm"]]
    if row.get("overlapping_eyelets"):
        out.append(Failure(id="eyelet.overlap", message=f"tendons routed into each other share one opening on "
                                                        f"{row['overlapping_eyelets']} disk(s)"))
    if row.get("shared_sliding"):
        pairs = sorted({p.split("@")[0] for p in row["shared_sliding"]})
        out.append(Failure(id="eyelet.shared_sliding",
                           message=f"{', '.join(pairs)}: a driven tendon slides through one opening with another "
                                   f"on {len(row['shared_sliding'])} disk(s)",
                           severity=row.get("shared_sliding_severity", "error"), measured=2, limit=1,
                           where=row["shared_sliding"],
                           fix="route the other tendon clear of the driven one's eyelets (its amplitude or phase: "
                               "tendons[].routing.function)"))
    if row["clearance_mm"] < row["min_wall_mm"]:
        out.append(Failure(id="eyelet.wall", message=f"least wall {row['clearance_mm']:.2f} mm, under process.min_wall "
                                                     f"{row['min_wall_mm']:g} mm",
                           measured=row["clearance_mm"], limit=row["min_wall_mm"]))
    return out
