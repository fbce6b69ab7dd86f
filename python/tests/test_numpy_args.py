# SPDX-License-Identifier: MIT
"""NumPy arguments: dtypes, memory orders and broadcasting read in place; errors that name the
argument; float64 meshes keeping their precision at large coordinates; thread limits."""

import math
import threading

import numpy as np
import pytest

import spacebvh


def grid_mesh(n=6, dtype=np.float32, offset=(0.0, 0.0, 0.0)):
    """An n x n grid of unit squares in the plane z = offset[2] (2 n^2 triangles), shifted by offset."""
    xs, ys = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    vertices = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1).astype(np.float64) + np.asarray(offset)
    faces = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
            faces += [[a, b, c], [a, c, d]]
    return vertices.astype(dtype), np.array(faces, dtype=np.int64)


def down_rays(count, n=6, seed=5, height=1.0, offset=(0.0, 0.0, 0.0)):
    """Rays from above the grid straight down, at random points over it."""
    rng = np.random.default_rng(seed)
    origins = np.column_stack(
        [rng.uniform(0.05, n - 0.05, count), rng.uniform(0.05, n - 0.05, count), np.full(count, height)]
    )
    return origins + np.asarray(offset), np.tile([0.0, 0.0, -1.0], (count, 1))


@pytest.fixture(scope="module")
def grid():
    vertices, faces = grid_mesh()
    scene = spacebvh.mesh(vertices, faces)
    tracer = spacebvh.Tracer(spacebvh.build(scene, "binned"), "binary")
    origins, directions = down_rays(300)
    return vertices, faces, tracer, origins.astype(np.float32), directions.astype(np.float32)


def test_error_is_runtime_and_value_error():
    assert issubclass(spacebvh.Error, RuntimeError)
    assert issubclass(spacebvh.Error, ValueError)


@pytest.mark.parametrize(
    "index_dtype", [np.int8, np.uint8, np.int16, np.uint16, np.int32, np.uint32, np.int64, np.uint64]
)
def test_faces_of_any_integer_dtype(grid, index_dtype):
    vertices, faces, tracer, origins, directions = grid
    expected = tracer.intersect(origins, directions)
    scene = spacebvh.mesh(vertices, faces.astype(index_dtype))
    np.testing.assert_array_equal(scene.triangles(), vertices[faces])
    got = spacebvh.Tracer(spacebvh.build(scene, "binned"), "binary").intersect(origins, directions)
    for a, b in zip(got, expected):
        np.testing.assert_array_equal(a, b)


def test_memory_orders_and_views_read_in_place(grid):
    vertices, faces, tracer, origins, directions = grid
    expected = tracer.intersect(origins, directions)
    fortran = spacebvh.mesh(np.asfortranarray(vertices), np.asfortranarray(faces))
    np.testing.assert_array_equal(fortran.triangles(), vertices[faces])
    # A strided view: every other column of a wider array, and faces reversed twice.
    wide = np.zeros((vertices.shape[0], 6), dtype=np.float32)
    wide[:, ::2] = vertices
    strided = spacebvh.mesh(wide[:, ::2], faces[::-1][::-1])
    np.testing.assert_array_equal(strided.triangles(), vertices[faces])
    # Rays: Fortran order, a transposed view, float64.
    for o, d in (
        (np.asfortranarray(origins), np.asfortranarray(directions)),
        (np.ascontiguousarray(origins.T).T, directions),
        (origins.astype(np.float64), directions.astype(np.float64)),
    ):
        got = tracer.intersect(o, d)
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)
    # Python lists are accepted too.
    t, primitive, _, _ = tracer.intersect(origins[:3].tolist(), directions[:3].tolist())
    np.testing.assert_array_equal(primitive, expected[1][:3])


def test_one_direction_or_origin_is_shared_by_every_ray(grid):
    _, _, tracer, origins, directions = grid
    expected = tracer.intersect(origins, directions)
    for shared in ([0.0, 0.0, -1.0], np.array([[0.0, 0.0, -1.0]], dtype=np.float32), (0, 0, -1)):
        got = tracer.intersect(origins, shared)
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(tracer.occluded(origins, [0, 0, -1]), np.ones(len(origins), dtype=bool))
    # One eye, many directions: from above the grid's centre, towards each ray's hit point.
    eye = np.array([3.0, 3.0, 2.0], dtype=np.float32)
    target = origins * [1, 1, 0]
    t, primitive, _, _ = tracer.intersect(eye, target - eye)
    assert np.all(primitive >= 0)
    np.testing.assert_allclose(t, 1.0, rtol=1e-5)  # the target lies on the plane, one direction length away


def test_wrong_shapes_name_the_argument(grid):
    vertices, faces, tracer, origins, directions = grid
    with pytest.raises(spacebvh.Error, match=r"vertices must have shape \(n, 3\), not \(\d+, 2\)"):
        spacebvh.mesh(vertices[:, :2], faces)
    with pytest.raises(spacebvh.Error, match=r"faces must have shape \(m, 3\), not \(\d+, 4\)"):
        spacebvh.mesh(vertices, np.zeros((2, 4), dtype=np.int32))
    with pytest.raises(spacebvh.Error, match=r"origins must have shape \(n, 3\) or \(3,\), not \(4,\)"):
        tracer.intersect(np.zeros(4), directions)
    with pytest.raises(spacebvh.Error, match=r"directions must have shape"):
        tracer.intersect(origins, np.zeros((len(origins), 3, 1)))
    with pytest.raises(spacebvh.Error, match="differ in length"):
        tracer.intersect(origins[:5], directions[:4])
    with pytest.raises(spacebvh.Error, match="tmax must be a number or an array of 300"):
        tracer.intersect(origins, directions, 0.0, np.ones(7))


def test_wrong_dtypes_raise_type_error_naming_the_argument(grid):
    vertices, faces, tracer, origins, directions = grid
    with pytest.raises(TypeError, match="faces must be an array of integers.*float"):
        spacebvh.mesh(vertices, faces.astype(np.float64))
    with pytest.raises(TypeError, match="vertices must be an array of real numbers.*complex"):
        spacebvh.mesh(vertices.astype(np.complex64), faces)
    with pytest.raises(TypeError, match="origins"):
        tracer.intersect(origins.astype(bool), directions)
    with pytest.raises(TypeError, match="directions"):
        tracer.intersect(origins, np.array([["a", "b", "c"]]))
    with pytest.raises(TypeError, match="tmin"):
        tracer.intersect(origins, directions, True)


def test_other_real_dtypes_are_converted(grid):
    vertices, faces, tracer, origins, directions = grid
    # Integer vertices and float16 rays: exact in float64, so the same answers.
    scene = spacebvh.mesh(vertices.astype(np.int32), faces)
    assert scene.dtype == np.float64
    t, primitive, _, _ = spacebvh.Tracer(spacebvh.build(scene)).intersect(
        origins.astype(np.float64), directions.astype(np.float16)
    )
    np.testing.assert_array_equal(primitive, tracer.intersect(origins, directions)[1])
    big_endian = spacebvh.mesh(vertices.astype(">f8"), faces.astype(">i4"))
    np.testing.assert_array_equal(big_endian.triangles(), vertices[faces])


def test_non_finite_input_names_the_element(grid):
    vertices, faces, tracer, origins, directions = grid
    for bad_value in (np.nan, np.inf, -np.inf):
        bad = vertices.astype(np.float64)
        bad[4, 1] = bad_value
        with pytest.raises(spacebvh.Error, match="vertices: vertex 4 has a coordinate that is not finite"):
            spacebvh.mesh(bad, faces)
    too_far = vertices.astype(np.float64)
    too_far[0, 0] = 1e300
    with pytest.raises(spacebvh.Error, match="vertex 0 lies beyond float32's range"):
        spacebvh.mesh(too_far, faces)
    with pytest.raises(spacebvh.Error, match="faces: triangle 1 uses vertex -1"):
        spacebvh.mesh(vertices, np.array([[0, 1, 2], [0, -1, 2]]))
    with pytest.raises(spacebvh.Error, match="faces: triangle 0 uses vertex 18446744073709551615|outside"):
        spacebvh.mesh(vertices, np.array([[0, 1, 2**64 - 1]], dtype=np.uint64))
    with pytest.raises(spacebvh.Error, match="faces: no triangles"):
        spacebvh.mesh(vertices, np.zeros((0, 3), dtype=np.int32))
    bad_origins = origins.copy()
    bad_origins[17, 2] = np.nan
    with pytest.raises(spacebvh.Error, match="ray 17"):
        tracer.intersect(bad_origins, directions)
    bad_directions = directions.astype(np.float64)
    bad_directions[250] = [0.0, 0.0, 1e300]  # finite in float64, not in float32
    with pytest.raises(spacebvh.Error, match="ray 250"):
        tracer.occluded(origins, bad_directions)
    with pytest.raises(spacebvh.Error, match="ray 3"):
        tracer.intersect(origins, directions, 0.0, np.where(np.arange(len(origins)) == 3, np.nan, 1.0))


def test_first_bad_ray_is_named_whatever_the_thread_count(grid):
    _, _, tracer, origins, directions = grid
    many_o = np.tile(origins, (200, 1))
    many_d = np.tile(directions, (200, 1))
    many_d[[40_001, 50_000, 59_999]] = 0.0
    for threads in (1, 2, 0):
        with pytest.raises(spacebvh.Error, match="ray 40001"):
            tracer.intersect(many_o, many_d, threads=threads)


def plane_scene(z, dtype):
    """A 2 x 2 square in the plane z, centred on (z, z) in x and y (far from the origin when z is)."""
    vertices = np.array([[z - 1, z - 1, z], [z + 1, z - 1, z], [z + 1, z + 1, z], [z - 1, z + 1, z]], dtype=np.float64)
    return spacebvh.mesh(vertices.astype(dtype), np.array([[0, 1, 2], [0, 2, 3]]))


def test_float64_mesh_keeps_precision_at_large_coordinates():
    z = 5e5
    scene = plane_scene(z, np.float64)
    assert scene.dtype == np.float64
    np.testing.assert_allclose(scene.origin, (z, z, z))
    tracer = spacebvh.Tracer(spacebvh.build(scene, "binned"), "binary")
    origins = np.array([[z + 0.25, z - 0.5, z + 0.01]] * 2)
    directions = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    t, primitive, u, v = tracer.intersect(origins, directions)
    assert t.dtype == np.float64
    # 0.01 above the surface: away from it no hit, towards it a hit at t = 0.01.
    assert primitive[0] == -1 and math.isinf(t[0])
    assert primitive[1] >= 0
    assert t[1] == pytest.approx(0.01, rel=1e-4)
    np.testing.assert_array_equal(tracer.occluded(origins, directions), [False, True])
    points = scene.hit_points(primitive, u, v)
    assert points.dtype == np.float64
    assert np.isnan(points[0]).all()
    np.testing.assert_allclose(points[1], [z + 0.25, z - 0.5, z], rtol=0, atol=1e-6)
    lo, hi = scene.bounds
    np.testing.assert_allclose(lo, (z - 1, z - 1, z))
    np.testing.assert_allclose(hi, (z + 1, z + 1, z))
    # Rays the module generates come back in the caller's frame and trace to the same answers.
    ray_origins, ray_directions = spacebvh.random_rays(scene, 64, seed=2)
    assert ray_origins.dtype == np.float64
    assert np.all(np.abs(ray_origins - z) < 2)


def test_float32_mesh_at_large_coordinates_loses_that_precision():
    # The reason for the float64 frame: in float32 the origin 0.01 above the plane rounds onto it
    # (spacing 1/32 at 5e5), so the ray cast away from the surface starts on it and hits at t = 0.
    z = 5e5
    scene = plane_scene(z, np.float32)
    assert scene.dtype == np.float32 and scene.origin == (0.0, 0.0, 0.0)
    tracer = spacebvh.Tracer(spacebvh.build(scene, "binned"), "binary")
    t, primitive, _, _ = tracer.intersect(np.array([[z + 0.25, z - 0.5, z + 0.01]]), np.array([[0.0, 0.0, 1.0]]))
    assert primitive[0] >= 0 and t[0] == 0.0


def test_float64_mesh_answers_equal_float32_mesh_near_origin(grid):
    # A small mesh near the origin: the float64 frame changes no answer.
    vertices, faces, tracer, origins, directions = grid
    scene = spacebvh.mesh(vertices.astype(np.float64) - [3.0, 3.0, 0.0], faces)  # centred on the origin
    t64, p64, _, _ = spacebvh.Tracer(spacebvh.build(scene), "binary").intersect(origins - [3.0, 3.0, 0.0], directions)
    t32, p32, _, _ = tracer.intersect(origins, directions)
    np.testing.assert_array_equal(p64, p32)
    np.testing.assert_allclose(t64, t32, rtol=1e-6)


def test_threads_limit_and_same_answers(grid):
    _, _, tracer, origins, directions = grid
    many_o, many_d = np.tile(origins, (50, 1)), np.tile(directions, (50, 1))
    results = [tracer.intersect(many_o, many_d, threads=n) for n in (1, 2, 0)]
    for other in results[1:]:
        for a, b in zip(results[0], other):
            np.testing.assert_array_equal(a, b)
    with pytest.raises(spacebvh.Error, match="threads must be >= 0"):
        tracer.intersect(origins, directions, threads=-1)
    with pytest.raises(spacebvh.Error, match="threads must be >= 0"):
        spacebvh.Tracer(spacebvh.build(tracer.scene), threads=-2)


def test_concurrent_calls_from_python_threads(grid):
    # The GIL is released during traversal: calls from several Python threads run side by side and
    # each gets its own, identical answers.
    _, _, tracer, origins, directions = grid
    many_o, many_d = np.tile(origins, (100, 1)), np.tile(directions, (100, 1))
    expected = tracer.intersect(many_o, many_d)
    answers = [None] * 4

    def work(i):
        answers[i] = tracer.intersect(many_o, many_d, threads=1)

    workers = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    for answer in answers:
        for a, b in zip(answer, expected):
            np.testing.assert_array_equal(a, b)
