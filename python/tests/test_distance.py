# SPDX-License-Identifier: MIT
"""Point queries (spacebvh.DistanceQueries) against an independent exact reference written here with
Python's fractions on the float32 triangles: the nearest triangle (ties to the smaller id) and the
squared distance, on lattices through a subdivided box's faces, edges and vertices, points on the
surface and near vertices; signs, occupancy and winding numbers of a closed box; shapes, dtypes and
errors of the API.
"""

import math
from fractions import Fraction

import numpy as np
import pytest

import spacebvh


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _segment_d2(p, a, b):
    e, d = _sub(b, a), _sub(p, a)
    t = min(max(_dot(d, e) / _dot(e, e), Fraction(0)), Fraction(1))
    r = (d[0] - t * e[0], d[1] - t * e[1], d[2] - t * e[2])
    return _dot(r, r)


def exact_d2(p, tri):
    """The squared distance from p to the closed triangle: the plane's where the projection lies
    inside, else the smallest of the three segments'."""
    a, b, c = tri
    n = _cross(_sub(b, a), _sub(c, a))
    s = _dot(_sub(p, a), n) / _dot(n, n)
    q = (p[0] - s * n[0], p[1] - s * n[1], p[2] - s * n[2])
    if all(_dot(_cross(_sub(y, x), _sub(q, x)), n) >= 0 for x, y in ((a, b), (b, c), (c, a))):
        return s * s * _dot(n, n)
    return min(_segment_d2(p, a, b), _segment_d2(p, b, c), _segment_d2(p, c, a))


def grid_box(n):
    """A closed, outward-oriented box [0, 2n]^3 of n x n quads per face: (vertices, faces)."""
    vertices, faces = [], []
    for axis in range(3):
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            for i in range(n):
                for j in range(n):
                    quad = []
                    for di, dj in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = 2.0 * n * side
                        p[a1], p[a2] = 2.0 * (i + di), 2.0 * (j + dj)
                        quad.append(len(vertices))
                        vertices.append(p)
                    a, b, c, d = quad
                    if side == 0:
                        b, d = d, b
                    faces += [(a, b, c), (a, c, d)]
    return np.array(vertices), np.array(faces)


@pytest.fixture(scope="module")
def box():
    vertices, faces = grid_box(2)
    scene = spacebvh.mesh(vertices.astype(np.float32), faces)
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "spatial"))
    triangles = [tuple(tuple(Fraction(float(c)) for c in vertices[v]) for v in f) for f in faces]
    return queries, triangles


def lattice(n, step=0.5):
    r = np.arange(-1.0, 2 * n + 1.0 + step / 2, step)
    return np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)


def wrong_against_reference(queries, triangles, points, exact=None):
    """The points whose nearest triangle (ties to the smaller id) or squared distance (beyond its
    documented bound, taken generously) differs from the exact ones over every triangle in Fractions:
    (index, point, triangle found, triangle expected) each. Each exact squared distance is appended to
    `exact` where one is given."""
    found = queries.closest_points(points)
    wrong = []
    for k, p in enumerate(points):
        q = tuple(Fraction(float(c)) for c in p)
        d2 = [exact_d2(q, t) for t in triangles]
        best = min(d2)
        if exact is not None:
            exact.append(best)
        expected = d2.index(best)  # the first: ties go to the smaller id
        got = int(found["triangle_ids"][k])
        err = abs(Fraction(float(found["distance"][k])) ** 2 - best)
        if got != expected or err > Fraction(2**-40) * (1 + best + _dot(q, q)) * 64:
            wrong.append((k, tuple(p), got, expected))
    return wrong


def check_against_reference(queries, triangles, points):
    wrong = wrong_against_reference(queries, triangles, points)
    assert not wrong, wrong[:5]


def test_lattice_through_faces_edges_and_vertices(box):
    queries, triangles = box
    check_against_reference(queries, triangles, lattice(2)[::2])


def test_points_on_the_surface_and_near_vertices(box):
    queries, triangles = box
    rng = np.random.default_rng(3)
    vertices = np.array([[float(c) for c in v] for t in triangles for v in t])
    near = vertices[rng.integers(0, len(vertices), 200)] + rng.uniform(-1, 1, (200, 3)) * 2.0**-30
    tri = np.array([[[float(c) for c in v] for v in t] for t in triangles])
    pick = tri[rng.integers(0, len(tri), 200)]
    u = rng.uniform(0, 1, (200, 1))
    v = rng.uniform(0, 1, (200, 1)) * (1 - u)
    on = pick[:, 0] + u * (pick[:, 1] - pick[:, 0]) + v * (pick[:, 2] - pick[:, 0])
    check_against_reference(queries, triangles, np.concatenate([near, on]))


def test_result_keys_shapes_and_dtypes(box):
    queries, _ = box
    points = np.zeros((2, 5, 3), np.float32) + np.float32(-1)
    r = queries.closest_points(points)
    assert set(r) == {"points", "distance", "triangle_ids", "barycentrics", "feature"}
    assert r["points"].shape == (2, 5, 3) and r["points"].dtype == np.float64
    assert r["distance"].shape == (2, 5) and r["distance"].dtype == np.float64
    assert r["triangle_ids"].dtype == np.uint32 and r["barycentrics"].shape == (2, 5, 2)
    assert r["feature"].dtype == np.uint8
    assert np.all(r["feature"] >= 4)  # the corner (0, 0, 0) is a vertex
    one = queries.closest_points(np.array([2.0, 2.0, -1.0]))
    assert one["distance"].shape == () and float(one["distance"]) == 1.0
    assert one["points"].shape == (3,) and tuple(one["points"]) == (2.0, 2.0, 0.0)
    assert queries.distance(points).shape == (2, 5)
    assert queries.signed_distance(points).shape == (2, 5)
    assert queries.winding_number(points).shape == (2, 5)
    assert queries.occupancy(points).dtype == np.bool_
    # The point is the triangle's at the reported barycentrics.
    tri = np.array(grid_box(2)[0])[np.array(grid_box(2)[1])][one["triangle_ids"]]
    u, v = one["barycentrics"]
    assert np.allclose(tri[0] + u * (tri[1] - tri[0]) + v * (tri[2] - tri[0]), one["points"])


def test_max_distance_misses(box):
    queries, _ = box
    r = queries.closest_points(np.array([[2.0, 2.0, -1.0], [2.0, 2.0, -3.0]]), max_distance=1.0)
    assert r["distance"][0] == 1.0 and math.isinf(r["distance"][1])
    assert r["triangle_ids"][1] == 0xFFFFFFFF and np.all(np.isnan(r["points"][1]))
    assert math.isinf(queries.distance(np.array([2.0, 2.0, -3.0]), 1.0))


def test_signs_occupancy_and_winding_numbers(box):
    queries, _ = box
    points = lattice(2, 0.5)
    inside = np.all((points > 0) & (points < 4), axis=1)
    outside = np.any((points < 0) | (points > 4), axis=1)
    off = inside | outside
    d = queries.distance(points)
    assert np.all(d[~off] == 0)
    for sign in ("parity", "winding"):
        s = queries.signed_distance(points, sign=sign)
        assert np.array_equal(s[off], np.where(inside, -d, d)[off])
    assert np.array_equal(queries.occupancy(points)[off], inside[off])
    w = queries.winding_number(points[off])
    assert np.all(np.abs(w - inside[off]) < 1e-9)
    assert np.all(np.abs(queries.winding_number(points[off], accuracy=2.0) - inside[off]) < 0.05)


def test_float64_mesh_far_from_the_origin():
    vertices, faces = grid_box(1)
    scene = spacebvh.mesh(vertices + 1.0e6, faces)
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "binned"))
    r = queries.closest_points(np.array([1.0e6 + 1.0, 1.0e6 + 1.0, 1.0e6 - 0.5]))
    assert float(r["distance"]) == 0.5
    assert np.array_equal(r["points"], [1.0e6 + 1.0, 1.0e6 + 1.0, 1.0e6])
    assert float(queries.signed_distance(np.array([1.0e6 + 1.0, 1.0e6 + 1.0, 1.0e6 + 0.5]))) == -0.5


def test_same_answers_for_any_thread_count_and_run(box):
    queries, _ = box
    points = np.random.default_rng(1).uniform(-2, 6, (20000, 3))
    first = queries.closest_points(points, threads=1)
    for threads in (1, 2, 0):
        again = queries.closest_points(points, threads=threads)
        for key in first:
            assert np.array_equal(first[key], again[key], equal_nan=key == "points")
        assert np.array_equal(queries.signed_distance(points, threads=threads), queries.signed_distance(points))


def test_bad_input_is_an_error(box):
    queries, _ = box
    with pytest.raises(spacebvh.Error, match="point 1"):
        queries.distance(np.array([[0.0, 0, 0], [0, np.nan, 0]]))
    with pytest.raises(spacebvh.Error, match="shape"):
        queries.distance(np.zeros((4, 2)))
    with pytest.raises(spacebvh.Error, match="max_distance"):
        queries.closest_points(np.zeros(3), max_distance=-1.0)
    with pytest.raises(spacebvh.Error, match="accuracy"):
        queries.winding_number(np.zeros(3), accuracy=-2.0)
    with pytest.raises(spacebvh.Error, match="sign"):
        queries.signed_distance(np.zeros(3), sign="majority")
    with pytest.raises(TypeError):
        queries.distance(np.array([["a", "b", "c"]]))
    with pytest.raises(spacebvh.Error, match="threads"):
        spacebvh.DistanceQueries(spacebvh.build(spacebvh.mesh(*grid_box(1)), "binned"), threads=-1)


def reference_winding(triangles, point):
    """The direct sum in extended precision (NumPy's long double, 64-bit mantissa on x86-64)."""
    t = np.asarray(triangles, dtype=np.longdouble) - np.asarray(point, dtype=np.longdouble)
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    la, lb, lc = (np.sqrt(np.sum(x * x, axis=1)) for x in (a, b, c))
    det = np.sum(a * np.cross(b, c), axis=1)
    den = la * lb * lc + np.sum(a * b, axis=1) * lc + np.sum(a * c, axis=1) * lb + np.sum(b * c, axis=1) * la
    return float(np.sum(2 * np.arctan2(det, den)) / (4 * np.pi))


def test_winding_numbers_of_an_open_box():
    vertices, faces = grid_box(2)
    faces = faces[8:]  # the box without its face x = 0: winding numbers strictly between 0 and 1 inside
    scene = spacebvh.mesh(vertices.astype(np.float32), faces)
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "spatial"))
    triangles = vertices[faces]
    rng = np.random.default_rng(8)
    points = np.concatenate([rng.uniform(-1, 5, (300, 3)), lattice(2, 0.5)[::7]])
    on_surface = queries.distance(points) == 0
    points = points[~on_surface]
    direct = queries.winding_number(points)
    expected = np.array([reference_winding(triangles, p) for p in points])
    assert np.all(np.abs(direct - expected) < 1e-12), np.max(np.abs(direct - expected))
    assert 0.05 < np.max(direct) < 0.999 and np.min(direct) > -0.5
    # The hierarchy (first order): points at least one unit from the surface, error falling with beta.
    far = queries.distance(points) >= 1.0
    for beta, tolerance in ((2.0, 5e-2), (4.0, 2e-3)):
        assert np.all(np.abs(queries.winding_number(points[far], accuracy=beta) - expected[far]) < tolerance)
    # Sign by winding: inside where >= 0.5, by the direct sum where the hierarchy is near one half;
    # points in the opening's plane, at 0.5 exactly, are within the direct sum's bound of either side.
    decided = np.abs(expected - 0.5) > 1e-9
    signed = queries.signed_distance(points, sign="winding")
    assert np.array_equal((signed < 0)[decided], (expected >= 0.5)[decided])
    assert np.count_nonzero(expected[decided] >= 0.5) > 10
