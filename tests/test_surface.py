"""The exact signed distance to a mesh (hwgen.checks.surface), against every triangle tried."""
from __future__ import annotations

import numpy as np
import pytest

from hwgen.checks.surface import SurfaceDistance, closest_on_triangles


def _brute(mesh, points):
    """Unsigned distance from each point to the closest of all the mesh's triangles."""
    tri = np.asarray(mesh.triangles)
    out = []
    for p in points:
        rep = np.repeat(p[None], len(tri), axis=0)
        q = closest_on_triangles(rep, tri[:, 0], tri[:, 1], tri[:, 2])
        out.append(np.sqrt(((rep - q) ** 2).sum(axis=1).min()))
    return np.asarray(out)


@pytest.fixture(scope="module")
def part():
    """A box with a 40-sided prism standing on it (long thin triangles and short ones), points in and
    around it, and which of them are inside."""
    import trimesh
    box = trimesh.creation.box((10.0, 6.0, 4.0))
    prism = trimesh.creation.cylinder(2.0, 8.0, sections=40, transform=trimesh.transformations.translation_matrix((0, 0, 5.0)))
    mesh = trimesh.boolean.union([box, prism], engine="manifold")
    rng = np.random.default_rng(3)
    points = rng.uniform((-7, -5, -4), (7, 5, 11), size=(300, 3))
    in_box = np.all(np.abs(points) < (5.0, 3.0, 2.0), axis=1)
    return mesh, points, in_box | _in_prism(points)


def _in_prism(points):
    """Inside the 40-gon prism (its flats 2 cos(π/40) from the axis), z from 1 to 9."""
    ang = np.arctan2(points[:, 1], points[:, 0])
    sector = (np.floor(ang / (2 * np.pi / 40)) + 0.5) * (2 * np.pi / 40)
    flat = points[:, 0] * np.cos(sector) + points[:, 1] * np.sin(sector)
    return (flat < 2.0 * np.cos(np.pi / 40)) & (points[:, 2] > 1.0) & (points[:, 2] < 9.0)


def test_distance_is_the_least_over_every_triangle_and_signed_inside(part):
    mesh, points, inside = part
    d = SurfaceDistance(mesh)(points)
    assert np.abs(d) == pytest.approx(_brute(mesh, points), abs=1e-12)
    assert inside.any() and (~inside).any()
    assert np.array_equal(d < 0, inside)


def test_points_beyond_max_dist_are_bounded_and_the_others_exact(part):
    """With max_dist the points nearer than it get their exact distance (the same bits as without);
    the others either that or max_dist itself, a lower bound."""
    mesh, points, _ = part
    sd = SurfaceDistance(mesh)
    full = sd(points)
    for max_dist in (0.3, 1.0, 2.5):
        got = sd(points, max_dist=max_dist)
        near = np.abs(full) <= max_dist
        assert near.any() and (~near).any()
        assert np.array_equal(got[near], full[near])
        bounded = got != full
        assert bounded.any() and not (bounded & near).any()
        assert np.all(got[bounded] == max_dist) and np.all(np.abs(full[bounded]) >= max_dist)
