# SPDX-License-Identifier: MIT
"""The hierarchical generalized winding number (Barill et al.'s far field to Taylor order 0, 1, 2)
against the direct sum in extended precision, written here: every answer within the bound that
winding_number_bound returns, the bound finite where the expansion converges, and the error falling
with the order and with beta. On an open box (winding numbers strictly between 0 and 1 inside) and on
the shared bunny (an open scan) when ../shared is there.
"""

import os
from pathlib import Path

import numpy as np
import pytest
from test_distance import grid_box, lattice

import spacebvh

SCENES = Path(os.environ.get("SPACEBVH_SCENES") or Path(__file__).resolve().parents[2].parent / "shared" / "scenes")


def reference_windings(triangles, points):
    """The direct sum of each point's solid angles in NumPy's long double (64-bit mantissa on x86-64):
    Van Oosterom and Strackee's formula, independent of the library's code."""
    t = np.asarray(triangles, dtype=np.longdouble)
    out = []
    for point in np.asarray(points, dtype=np.longdouble):
        a, b, c = t[:, 0] - point, t[:, 1] - point, t[:, 2] - point
        la, lb, lc = (np.sqrt(np.sum(x * x, axis=1)) for x in (a, b, c))
        det = np.sum(a * np.cross(b, c), axis=1)
        den = la * lb * lc + np.sum(a * b, axis=1) * lc + np.sum(a * c, axis=1) * lb + np.sum(b * c, axis=1) * la
        out.append(np.sum(2 * np.arctan2(det, den)) / (4 * np.pi))
    return np.array(out, dtype=np.float64)


def check_orders(queries, points, expected, betas):
    """Each (beta, order): every value within its bound of the reference; returns the largest error and
    the median bound of each, for the callers' checks of how they fall."""
    errors = {}
    for beta in betas:
        for order in (0, 1, 2):
            value, bound = queries.winding_number_bound(points, beta, order=order)
            assert np.array_equal(value, queries.winding_number(points, beta, order=order))
            error = np.abs(value - expected)
            # The reference itself is within about 1e-15 of the exact sum on these meshes.
            assert np.all(error <= bound + 1e-13), (beta, order, np.max(error - bound))
            assert np.all(np.isfinite(bound)), (beta, order)
            errors[beta, order] = (np.max(error), np.median(bound))
    return errors


def open_box():
    vertices, faces = grid_box(4)
    return vertices, faces[32:]  # without the face x = 0


def test_open_box_within_the_bound_and_falling_with_order_and_beta():
    vertices, faces = open_box()
    queries = spacebvh.DistanceQueries(spacebvh.build(spacebvh.mesh(vertices.astype(np.float32), faces), "binned"))
    rng = np.random.default_rng(3)
    points = np.concatenate([rng.uniform(-4, 12, (400, 3)), lattice(4, 0.75)[::5]])
    points = points[queries.distance(points) > 0]
    expected = reference_windings(vertices[faces], points)
    errors = check_orders(queries, points, expected, (1.5, 2.0, 4.0))
    for beta in (2.0, 4.0):
        # Each order is closer than the one before, and its bound tighter.
        assert errors[beta, 2][0] < errors[beta, 1][0] < errors[beta, 0][0], errors
        assert errors[beta, 2][1] < errors[beta, 1][1] < errors[beta, 0][1], errors
    assert errors[4.0, 2][0] < errors[2.0, 2][0] and errors[4.0, 2][1] < errors[2.0, 2][1]
    assert errors[4.0, 2][0] < 1e-3, errors
    # The direct sum (accuracy 0) is within its own, far smaller, bound.
    value, bound = queries.winding_number_bound(points)
    assert np.all(np.abs(value - expected) <= bound + 1e-13) and np.max(bound) < 1e-9


def test_points_on_the_surface_are_principal_values_or_have_bounds_that_cover_the_jump():
    vertices, faces = open_box()
    queries = spacebvh.DistanceQueries(spacebvh.build(spacebvh.mesh(vertices.astype(np.float32), faces), "binned"))
    # Inside a triangle, on a diagonal shared by two, on a grid line, at a vertex. The winding number
    # jumps by 1 across the surface: inside a triangle the sum takes that triangle's principal value
    # (half the jump, as the reference does); on edges and vertices the bound covers the jump.
    on_surface = np.array([[3.5, 2.5, 8.0], [3.0, 3.0, 8.0], [8.0, 3.0, 2.0], [8.0, 2.0, 2.0]])
    expected = reference_windings(vertices[faces], on_surface)
    for accuracy in (0.0, 2.0):
        for order in (0, 2):
            value, bound = queries.winding_number_bound(on_surface, accuracy, order=order)
            assert np.abs(value[0] - expected[0]) <= bound[0] + 1e-13, (accuracy, order)
            assert accuracy > 0 or bound[0] < 1e-9
            assert np.all(bound[1:] >= 0.5), (accuracy, order, bound)


def test_order_is_checked():
    vertices, faces = open_box()
    queries = spacebvh.DistanceQueries(spacebvh.build(spacebvh.mesh(vertices.astype(np.float32), faces), "binned"))
    for order in (-1, 3):
        with pytest.raises(spacebvh.Error, match="order"):
            queries.winding_number(np.zeros(3), 2.0, order=order)


@pytest.mark.skipif(not (SCENES / "bunny" / "bunny.obj").exists(), reason=f"no shared bunny under {SCENES}")
def test_shared_bunny_within_the_bound():
    scene = spacebvh.load_scene(str(SCENES / "bunny" / "bunny.obj"))
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "binned"), threads=2)
    triangles = np.asarray(scene.triangles(), dtype=np.float64)
    lo, hi = (np.array(b) for b in scene.bounds)
    rng = np.random.default_rng(5)
    points = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (120, 3))
    # And points near the surface: off triangle centroids along their normals by a thousandth of the size.
    picked = triangles[rng.integers(0, len(triangles), 40)]
    normals = np.cross(picked[:, 1] - picked[:, 0], picked[:, 2] - picked[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    offsets = 1e-3 * np.max(hi - lo) * rng.choice([-1.0, 1.0], (40, 1))
    points = np.concatenate([points, picked.mean(axis=1) + offsets * normals])
    expected = reference_windings(triangles, points)
    errors = check_orders(queries, points, expected, (2.0, 4.0))
    assert errors[2.0, 2][0] < errors[2.0, 0][0], errors
    # The same answers for any thread count.
    assert np.array_equal(queries.winding_number(points, 2.0, threads=1), queries.winding_number(points, 2.0))
