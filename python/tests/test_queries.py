# SPDX-License-Identifier: MIT
"""Exact multi-hit queries (spacebvh.RayQueries) and the trimesh drop-in, against an independent exact
reference written here with Python's fractions on the float32 inputs.

The failure classes of ray casting in trimesh's issue tracker: rays through shared edges and vertices
(missed or doubled), duplicate hits, parity that changes run to run or with the thread count, large
coordinates, axis-aligned rays and rays in a triangle's plane.
"""

import math
from fractions import Fraction

import numpy as np
import pytest

import spacebvh

# --------------------------------------------------------------------------------------------------
# The reference: the rule of docs/queries.md from its definition, in exact rationals.


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _sign(x):
    return (x > 0) - (x < 0)


def _exact(v):
    return tuple(Fraction(float(np.float32(c))) for c in v)


def _edge_sign(o, d, p, q):
    """Sign of d . ((p - o) x (q - o)); an exact zero takes the sign the perturbation of the origin
    by e x + e^2 y + e^3 z gives it: the first nonzero component of d x (q - p)."""
    s = _sign(_dot(d, _cross(_sub(p, o), _sub(q, o))))
    if s:
        return s
    for c in _cross(d, _sub(q, p)):
        if c:
            return _sign(c)
    return 0


def reference_hits(triangles, origin, direction, tmin=0.0, tmax=math.inf):
    """Every crossing as sorted (t, triangle) pairs, exactly."""
    o, d = _exact(origin), _exact(direction)
    hits = []
    for index, (v0, v1, v2) in enumerate(triangles):
        n = _cross(_sub(v1, v0), _sub(v2, v0))
        if n == (0, 0, 0):
            continue
        s = _edge_sign(o, d, v1, v2)
        if s == 0 or _edge_sign(o, d, v2, v0) != s or _edge_sign(o, d, v0, v1) != s:
            continue
        denominator = _dot(n, d)
        if denominator == 0:
            continue
        t = _dot(n, _sub(v0, o)) / denominator
        if math.isfinite(tmin) and t < Fraction(float(np.float32(tmin))):
            continue
        if math.isfinite(tmax) and t > Fraction(float(np.float32(tmax))):
            continue
        hits.append((t, index))
    return sorted(hits)


def exact_triangles(vertices, faces):
    return [tuple(_exact(vertices[i]) for i in face) for face in faces]


# --------------------------------------------------------------------------------------------------
# Meshes: a closed box of n x n quads per face with integer coordinates (exact rays through its
# vertices and edge midpoints), consistently oriented outwards.


def grid_box(n, size=None):
    size = 2 * n if size is None else size
    vertices, faces, index = [], [], {}

    def vertex(p):
        key = tuple(p)
        if key not in index:
            index[key] = len(vertices)
            vertices.append(key)
        return index[key]

    step = size / n
    for axis in range(3):
        a1, a2 = (axis + 1) % 3, (axis + 2) % 3
        for side in (0, 1):
            for i in range(n):
                for j in range(n):

                    def corner(di, dj):
                        p = [0.0, 0.0, 0.0]
                        p[axis] = size if side else 0.0
                        p[a1] = (i + di) * step
                        p[a2] = (j + dj) * step
                        return vertex(p)

                    a, b, c, d = corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)
                    if side == 0:
                        b, d = d, b
                    faces.append((a, b, c))
                    faces.append((a, c, d))
    return np.array(vertices, dtype=np.float32), np.array(faces, dtype=np.int64)


def queries_for(vertices, faces, builder="binned", threads=0):
    return spacebvh.RayQueries(spacebvh.build(spacebvh.mesh(vertices, faces), builder), threads=threads)


def check_all_hits(queries, triangles, origins, directions, tmin=0.0, tmax=math.inf):
    index_ray, primitive, t, u, v, points = queries.all(origins, directions, tmin, tmax)
    counts = queries.count(origins, directions, tmin, tmax)
    first_t, first_primitive, _, _, _ = queries.first(origins, directions, tmin, tmax)
    anys = queries.any(origins, directions, tmin, tmax)
    assert np.array_equal(queries.first_primitive(origins, directions, tmin, tmax), first_primitive)
    # Without t, u, v: the same crossings and points.
    lean = queries.all(origins, directions, tmin, tmax, details=False)
    assert np.array_equal(lean[0], index_ray) and np.array_equal(lean[1], primitive) and np.array_equal(lean[5], points)
    assert lean[2].shape == lean[3].shape == lean[4].shape == (0,)
    assert np.all(np.diff(index_ray) >= 0)
    for r in range(len(origins)):
        expected = reference_hits(triangles, origins[r], directions[r], tmin, tmax)
        mine = index_ray == r
        assert sorted(primitive[mine].tolist()) == sorted(i for _, i in expected), (r, origins[r], directions[r])
        assert np.all(np.diff(t[mine]) >= 0)
        for tt, i in expected:
            k = np.nonzero(mine & (primitive == i))[0][0]
            assert abs(t[k] - float(tt)) <= 1e-9 * max(1.0, abs(float(tt)))
        assert counts[r] == len(expected)
        assert anys[r] == bool(expected)
        if expected:
            assert first_primitive[r] in [i for tt, i in expected if tt == expected[0][0]] or (
                abs(first_t[r] - float(expected[0][0])) <= 1e-12 * max(1.0, abs(float(expected[0][0])))
            )
        else:
            assert first_primitive[r] == -1


# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("builder", ["binned", "spatial"])
def test_random_rays_match_the_reference(builder):
    vertices, faces = grid_box(3)
    queries = queries_for(vertices, faces, builder)
    triangles = exact_triangles(vertices, faces)
    rng = np.random.default_rng(5)
    origins = rng.uniform(-2.0, 8.0, (150, 3)).astype(np.float32)
    directions = rng.normal(size=(150, 3)).astype(np.float32)
    check_all_hits(queries, triangles, origins, directions)
    check_all_hits(queries, triangles, origins, directions, 0.5, 4.0)


def test_rays_through_vertices_and_edges_cross_once():
    vertices, faces = grid_box(3)
    queries = queries_for(vertices, faces)
    triangles = exact_triangles(vertices, faces)
    targets = np.concatenate(
        [
            vertices,
            (vertices[faces[:, 0]] + vertices[faces[:, 1]]) / 2,
            (vertices[faces[:, 1]] + vertices[faces[:, 2]]) / 2,
        ]
    )
    for origin in ([1.5, 2.5, 3.5], [3.0, 3.0, 3.0], [0.5, 5.5, 2.0]):
        origins = np.tile(np.float32(origin), (len(targets), 1))
        directions = (targets - origins).astype(np.float32)
        counts = queries.count(origins, directions)
        assert np.all(counts == 1)  # from inside a closed box: out once, wherever it leaves
        check_all_hits(queries, triangles, origins[::7], directions[::7])
        # The whole line: in once and out once.
        assert np.all(queries.count(origins - 64 * directions, directions) == 2)
        assert np.all(queries.contains(origins))


def test_axis_aligned_and_coplanar_rays():
    vertices, faces = grid_box(2)
    queries = queries_for(vertices, faces)
    triangles = exact_triangles(vertices, faces)
    # Along grid lines: through vertices and edges of the bottom and top faces, and inside side faces.
    xs, ys = np.meshgrid(np.arange(0, 5, 1.0), np.arange(0, 5, 1.0))
    origins = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, -3.0)]).astype(np.float32)
    directions = np.tile(np.float32([0, 0, 1]), (len(origins), 1))
    check_all_hits(queries, triangles, origins, directions)
    inner = (origins[:, 0] > 0) & (origins[:, 0] < 4) & (origins[:, 1] > 0) & (origins[:, 1] < 4)
    assert np.all(queries.count(origins, directions)[inner] == 2)
    assert np.all(queries.count(origins, directions) % 2 == 0)
    # In the plane z = 0 of the bottom face: never hits it.
    origins = np.float32([[-1, -1, 0], [-1, 2, 0], [2, -1, 0], [-1, 1, 0]])
    directions = np.float32([[1, 1, 0], [1, 0, 0], [0, 1, 0], [1, 2, 0]])
    index_ray, primitive, *_ = queries.all(origins, directions)
    normals = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    assert np.all(normals[primitive][:, 2] == 0)
    check_all_hits(queries, triangles, origins, directions)


def test_duplicate_rays_and_triangles():
    vertices, faces = grid_box(2)
    doubled = np.concatenate([faces, faces])
    queries = queries_for(vertices, doubled)
    origins = np.tile(np.float32([1.5, 1.5, -3.0]), (50, 1))
    index_ray, primitive, t, *_ = queries.all(origins, [0, 0, 1])
    assert np.all(np.bincount(index_ray) == 4)  # two surfaces, each twice
    per_ray = primitive.reshape(50, 4)
    assert np.all(per_ray == per_ray[0])
    assert per_ray[0][0] + len(faces) == per_ray[0][1]  # equal t: by triangle
    assert not queries.contains([[1.5, 1.5, 1.5]])[0]  # parity counts each copy


def test_containment_is_stable_and_matches_parity():
    vertices, faces = grid_box(3)
    rng = np.random.default_rng(3)
    points = np.concatenate([rng.uniform(-1, 7, (3000, 3)), vertices, rng.integers(0, 7, (500, 3))]).astype(np.float32)
    first = queries_for(vertices, faces).contains(points)
    for _ in range(10):
        for threads in (1, 2):
            assert np.array_equal(queries_for(vertices, faces, threads=threads).contains(points), first)
            assert np.array_equal(queries_for(vertices, faces).contains(points, threads=threads), first)
    inside = np.all((points > 0) & (points < 6), axis=1)
    assert np.array_equal(first[inside], np.ones(inside.sum(), bool))
    outside = np.any((points < 0) | (points > 6), axis=1)
    assert not first[outside].any()
    # Points on the surface against the exact parity count.
    triangles = exact_triangles(vertices, faces)
    direction = np.float32(spacebvh.containment_direction())
    for p, answer in zip(points[3000:3200], first[3000:3200]):
        assert answer == (len(reference_hits(triangles, p, direction)) % 2 == 1)


def test_large_coordinates_keep_float64_precision():
    vertices, faces = grid_box(2, size=1.0)
    for offset in (5e5, 1e7):
        v64 = vertices.astype(np.float64) + offset
        queries = spacebvh.RayQueries(spacebvh.build(spacebvh.mesh(v64, faces)))
        # 0.01 above the top face, cast up: away from the box, no hit; cast down: the top face first.
        origin = np.array([[offset + 0.3, offset + 0.6, offset + 1.01]])
        assert not queries.any(origin, [0.0, 0.0, 1.0])[0]
        t, primitive, u, v, points = queries.first(origin, [0.0, 0.0, -1.0])
        assert primitive[0] >= 0
        assert abs(t[0] - 0.01) < 1e-6
        assert np.allclose(points[0], [offset + 0.3, offset + 0.6, offset + 1.0], rtol=0, atol=1e-6)


def test_bad_input_is_an_error():
    vertices, faces = grid_box(1)
    queries = queries_for(vertices, faces)
    with pytest.raises(spacebvh.Error):
        queries.all([[0, 0, 0], [1, 1, 1]], [[0, 0, 1], [0, 0, 1], [0, 0, 1]])
    with pytest.raises((spacebvh.Error, TypeError)):
        queries.contains([[0, 0, float("nan")]])
    # The first bad row is named, wherever the rows' blocks are read.
    points = np.zeros((100_000, 3))
    points[[70_000, 40_000], 1] = np.inf
    with pytest.raises(spacebvh.Error, match="points: row 40000 is not finite"):
        queries.contains(points)
    with pytest.raises(spacebvh.Error):
        queries.all([[0, 0, 0]], [[0, 0, 1]], max_hits=-1)


# --------------------------------------------------------------------------------------------------
# The trimesh drop-in (when trimesh is installed).


def test_trimesh_drop_in():
    trimesh = pytest.importorskip("trimesh")
    import spacebvh.trimesh as drop_in

    box = trimesh.creation.box(extents=[2, 2, 2])
    ray = drop_in.RayMeshIntersector(box, scale_to_box=False)
    # From the centre through every vertex: exactly one hit each (trimesh#2317).
    origins = np.zeros_like(box.vertices)
    assert ray.intersects_any(origins, box.vertices).all()
    locations, index_ray, index_tri = ray.intersects_location(origins, box.vertices)
    assert np.array_equal(np.bincount(index_ray, minlength=len(origins)), np.ones(len(origins), int))
    assert np.allclose(locations, box.vertices)
    assert locations.dtype == np.float64 and index_ray.dtype == np.int64 and index_tri.dtype == np.int64
    # Multiple hits sorted by ray and then by distance; max_hits caps them.
    origins = np.array([[0.1, 0.2, -5.0], [0.3, -0.4, 5.0]])
    directions = np.array([[0, 0, 1.0], [0, 0, -1.0]])
    index_tri, index_ray, locations = ray.intersects_id(origins, directions, True, 100, True)
    assert index_ray.tolist() == [0, 0, 1, 1]
    assert locations[0][2] == -1.0 and locations[1][2] == 1.0 and locations[2][2] == 1.0
    index_tri, index_ray = ray.intersects_id(origins, directions, multiple_hits=True, max_hits=1)
    assert index_ray.tolist() == [0, 1]
    first = ray.intersects_first(origins, directions)
    assert first.dtype == np.int64 and np.array_equal(first, index_tri)
    assert ray.contains_points([[0, 0, 0], [3, 0, 0], [0.99, 0.99, -0.99]]).tolist() == [True, False, True]
    # patch(): new meshes use it.
    drop_in.patch()
    try:
        mesh = trimesh.creation.icosphere()
        assert isinstance(mesh.ray, drop_in.RayMeshIntersector)
        assert mesh.contains([[0, 0, 0], [2, 0, 0]]).tolist() == [True, False]
    finally:
        drop_in.unpatch()
