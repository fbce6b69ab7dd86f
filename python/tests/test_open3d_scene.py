# SPDX-License-Identifier: MIT
"""spacebvh.open3d.RaycastingScene against exact references: contacts for cast_rays and
test_occlusions, crossings for count_intersections and list_intersections, exact parity for
occupancy, the distances of a box, geometry ids over several add_triangles calls, Open3D's dtypes,
keys and shapes (NumPy without open3d, tensors with it), and errors naming the bad input."""

import math

import numpy as np
import pytest
from test_trimesh_contacts import box_mesh, exact_contacts, touching_rays

import spacebvh
import spacebvh.open3d as drop_in
from spacebvh.open3d import INVALID_ID, RaycastingScene


@pytest.fixture
def numpy_only(monkeypatch):
    """Results as NumPy arrays, as without open3d installed."""
    monkeypatch.setattr(drop_in, "_open3d", None)


def as_numpy(value):
    return value.numpy() if hasattr(value, "numpy") and not isinstance(value, np.ndarray) else value


def box_scene(lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0)):
    mesh = box_mesh(lo, hi)
    scene = RaycastingScene()
    assert scene.add_triangles(mesh.vertices.astype(np.float32), mesh.faces.astype(np.uint32)) == 0
    return scene, mesh


def test_cast_rays_and_occlusions_are_contacts_from_every_side(numpy_only):
    scene, mesh = box_scene()
    origins, directions = touching_rays()
    rays = np.hstack([origins, directions]).astype(np.float32)
    reference = [exact_contacts(mesh, o, d) for o, d in zip(origins, directions)]
    hit = np.array([len(hits) > 0 for hits in reference])
    assert hit.sum() == 59 and (~hit).sum() == 96  # touching rays hit, rays beside the box miss

    answer = scene.cast_rays(rays)
    assert sorted(answer) == sorted(["t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"])
    assert np.array_equal(np.isfinite(answer["t_hit"]), hit)
    expected_t = [float(hits[0][0]) if hits else math.inf for hits in reference]
    assert np.array_equal(answer["t_hit"], np.array(expected_t, dtype=np.float32))
    for ray, hits in enumerate(reference):
        nearest = {index for t, index, _ in hits if t == hits[0][0]}
        primitive = answer["primitive_ids"][ray]
        assert (primitive in nearest) if hits else primitive == INVALID_ID
        assert answer["geometry_ids"][ray] == (0 if hits else INVALID_ID)
        normal = answer["primitive_normals"][ray]
        if hits:  # the unit normal of the triangle, its orientation (v1 - v0) x (v2 - v0)
            corners = mesh.vertices[mesh.faces[primitive]]
            expected = np.cross(corners[1] - corners[0], corners[2] - corners[0])
            assert np.array_equal(normal, expected / np.linalg.norm(expected))
        else:
            assert not normal.any()
    assert np.array_equal(scene.test_occlusions(rays), hit)
    # The interval is closed: a contact at exactly tfar or tnear counts.
    t = answer["t_hit"]
    ray = int(np.flatnonzero(hit & (t > 0))[0])
    one = rays[ray : ray + 1]
    assert scene.test_occlusions(one, tfar=float(t[ray]))[0]
    assert scene.test_occlusions(one, tnear=float(t[ray]), tfar=float(t[ray]))[0]
    assert not scene.test_occlusions(one, tfar=float(np.nextafter(t[ray], 0)))[0]


def test_counts_and_lists_are_crossings(numpy_only):
    scene, mesh = box_scene()
    rng = np.random.default_rng(7)
    # Generic rays (no edge or vertex met): every contact is a crossing, counted once. float32 values,
    # as the scene traces them.
    origins = rng.uniform(-0.5, 1.5, (300, 3)).astype(np.float32).astype(np.float64)
    directions = rng.normal(size=(300, 3)).astype(np.float32).astype(np.float64)
    rays = np.hstack([origins, directions])
    reference = [exact_contacts(mesh, o, d) for o, d in zip(origins, directions)]
    counts = scene.count_intersections(rays)
    assert counts.dtype == np.int32
    assert np.array_equal(counts, [len(hits) for hits in reference])
    assert (counts == 2).sum() > 30 and (counts == 1).sum() > 30 and (counts == 0).sum() > 30
    listed = scene.list_intersections(rays)
    assert listed["ray_splits"].dtype == np.uint32 and len(listed["ray_splits"]) == len(rays) + 1
    assert np.array_equal(np.diff(listed["ray_splits"].astype(np.int64)), counts)
    expected_rays = np.repeat(np.arange(len(rays)), counts)
    assert np.array_equal(listed["ray_ids"], expected_rays)
    expected_t = np.array([float(t) for hits in reference for t, _, _ in hits], dtype=np.float32)
    assert np.allclose(listed["t_hit"], expected_t, rtol=1e-6)
    assert np.array_equal(listed["primitive_ids"], [index for hits in reference for _, index, _ in hits])
    assert not listed["geometry_ids"].any()
    # Touching rays from outside cross the closed box an even number of times.
    origins, directions = touching_rays()
    assert np.all(scene.count_intersections(np.hstack([origins, directions])) % 2 == 0)


def test_geometry_ids_over_several_meshes(numpy_only):
    scene = RaycastingScene()
    first = box_mesh()
    second = box_mesh((3.0, 0.0, 0.0), (4.0, 1.0, 1.0))
    triangle = np.array([[6.0, 0.0, 0.0], [7.0, 0.0, 0.0], [7.0, 1.0, 0.0]])
    assert scene.add_triangles(first.vertices, first.faces) == 0
    assert scene.add_triangles(second.vertices.astype(np.float32), second.faces.astype(np.uint32)) == 1
    assert scene.add_triangles(triangle, np.array([[0, 1, 2]])) == 2
    # Rays straight down through the middle of each geometry, and one between them.
    rays = np.array([[x, 0.25, 5.0, 0.0, 0.0, -1.0] for x in (0.5, 3.5, 6.75, 2.0)], dtype=np.float32)
    answer = scene.cast_rays(rays)
    assert np.array_equal(answer["geometry_ids"], [0, 1, 2, INVALID_ID])
    assert np.array_equal(answer["t_hit"], np.array([4.0, 4.0, 5.0, math.inf], dtype=np.float32))
    for ray, mesh in ((0, first), (1, second)):  # the top face's triangle, numbered in its own mesh
        corners = mesh.vertices[mesh.faces[answer["primitive_ids"][ray]]]
        assert np.all(corners[:, 2] == 1.0)
    assert answer["primitive_ids"][2] == 0
    listed = scene.list_intersections(rays)
    assert np.array_equal(listed["geometry_ids"], [0, 0, 1, 1, 2])
    assert np.array_equal(scene.count_intersections(rays), [2, 2, 1, 0])


@pytest.mark.parametrize("shape", [(), (5,), (2, 3), (2, 1, 4)])
def test_shapes_and_dtypes(numpy_only, shape):
    scene, _ = box_scene()
    rng = np.random.default_rng(3)
    rays = rng.uniform(-1, 2, shape + (6,)).astype(np.float32)
    points = rng.uniform(-1, 2, shape + (3,))
    answer = scene.cast_rays(rays)
    for key, width, dtype in (
        ("t_hit", (), np.float32),
        ("geometry_ids", (), np.uint32),
        ("primitive_ids", (), np.uint32),
        ("primitive_uvs", (2,), np.float32),
        ("primitive_normals", (3,), np.float32),
    ):
        assert answer[key].shape == shape + width and answer[key].dtype == dtype, key
    assert scene.test_occlusions(rays).shape == shape and scene.test_occlusions(rays).dtype == bool
    assert scene.count_intersections(rays).shape == shape
    occupancy = scene.compute_occupancy(points)
    assert occupancy.shape == shape and occupancy.dtype == np.float32
    inside = np.all((points > 0) & (points < 1), axis=-1)
    assert np.array_equal(occupancy, inside.astype(np.float32))
    assert np.array_equal(scene.compute_occupancy(points, nsamples=3), occupancy)


def test_open3d_tensors_in_and_out():
    o3d = pytest.importorskip("open3d")
    scene = RaycastingScene()
    mesh = box_mesh()
    scene.add_triangles(
        o3d.core.Tensor(mesh.vertices.astype(np.float32)), o3d.core.Tensor(mesh.faces.astype(np.uint32))
    )
    rays = o3d.core.Tensor(np.array([[0.5, 0.5, -1, 0, 0, 1], [5, 5, 5, 1, 0, 0]], dtype=np.float32))
    answer = scene.cast_rays(rays)
    assert isinstance(answer["t_hit"], o3d.core.Tensor)
    assert answer["t_hit"].numpy().tolist() == [1.0, math.inf]
    assert isinstance(scene.compute_occupancy(np.array([[0.5, 0.5, 0.5]])), o3d.core.Tensor)
    # A TriangleMesh is one geometry.
    assert scene.add_triangles(o3d.t.geometry.TriangleMesh.create_box()) == 1


def test_same_answers_as_open3d_on_generic_rays():
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(11)
    sphere = o3d.t.geometry.TriangleMesh.create_sphere(1.0, 20)
    ours, theirs = RaycastingScene(), o3d.t.geometry.RaycastingScene()
    for scene in (ours, theirs):
        scene.add_triangles(sphere)
    rays = np.hstack([rng.uniform(-2, 2, (2000, 3)), rng.normal(size=(2000, 3))]).astype(np.float32)
    mine, open3d = ours.cast_rays(rays), theirs.cast_rays(o3d.core.Tensor(rays))
    same = mine["primitive_ids"].numpy() == open3d["primitive_ids"].numpy()
    assert same.mean() > 0.99  # where they differ, a ray meets an edge up to rounding
    assert np.allclose(mine["t_hit"].numpy()[same], open3d["t_hit"].numpy()[same], rtol=1e-5)
    assert np.allclose(mine["primitive_normals"].numpy()[same], open3d["primitive_normals"].numpy()[same], atol=1e-6)
    assert np.allclose(mine["primitive_uvs"].numpy()[same], open3d["primitive_uvs"].numpy()[same], atol=1e-4)


def test_create_rays_pinhole_as_open3d():
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(5)
    intrinsic = np.array([[120.0, 0.0, 31.0], [0.0, 90.0, 22.0], [0.0, 0.0, 1.0]])
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation * np.sign(np.linalg.det(rotation))
    extrinsic[:3, 3] = rng.normal(size=3)
    theirs = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
        o3d.core.Tensor(intrinsic), o3d.core.Tensor(extrinsic), 9, 7
    )
    ours = RaycastingScene.create_rays_pinhole(intrinsic, extrinsic, 9, 7)
    assert ours.shape == theirs.shape and np.allclose(ours.numpy(), theirs.numpy(), atol=1e-6)
    center, eye, up = (rng.normal(size=3).astype(np.float32) for _ in range(3))
    theirs = o3d.t.geometry.RaycastingScene.create_rays_pinhole(
        70.0, o3d.core.Tensor(center), o3d.core.Tensor(eye), o3d.core.Tensor(up), 9, 7
    )
    ours = RaycastingScene.create_rays_pinhole(70.0, center, eye, up, 9, 7)
    assert ours.shape == theirs.shape and np.allclose(ours.numpy(), theirs.numpy(), atol=1e-6)


def box_distance(points, lo=0.0, hi=1.0):
    """The exact signed distance to the unit box's surface (negative inside), in float64."""
    outside = np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=-1)
    inside = np.minimum(points - lo, hi - points).min(axis=-1)
    return np.where(inside > 0, -inside, outside)


def test_distances_of_a_box(numpy_only):
    scene, _ = box_scene()
    rng = np.random.default_rng(9)
    points = np.vstack([rng.uniform(-1, 2, (500, 3)), [[0, 0, 0], [0.5, 0.5, 0.5], [1, 0.5, 2], [0.25, 0.5, 1.0]]])
    expected = box_distance(points)
    assert np.allclose(scene.compute_signed_distance(points), expected, atol=1e-6)
    assert np.allclose(scene.compute_distance(points), np.abs(expected), atol=1e-6)
    closest = scene.compute_closest_points(points)
    assert np.allclose(np.linalg.norm(closest["points"] - points, axis=1), np.abs(expected), atol=1e-5)
    assert not closest["geometry_ids"].any() and np.all(closest["primitive_ids"] < 12)


def test_bad_input_is_named(numpy_only):
    scene, mesh = box_scene()
    with pytest.raises(ValueError, match=r"rays must have shape \(\.\.\., 6\)"):
        scene.cast_rays(np.zeros((4, 5), dtype=np.float32))
    with pytest.raises(TypeError, match="rays must be float32 or float64"):
        scene.count_intersections(np.zeros((4, 6), dtype=np.int32))
    with pytest.raises(ValueError, match="query_points: point 1 is not finite"):
        scene.compute_occupancy(np.array([[0.0, 0, 0], [np.nan, 0, 0]]))
    with pytest.raises(ValueError, match="nsamples must be a positive odd number"):
        scene.compute_occupancy(np.zeros((1, 3)), nsamples=2)
    with pytest.raises(ValueError, match="nthreads must be >= 0"):
        scene.cast_rays(np.ones((1, 6), dtype=np.float32), nthreads=-1)
    with pytest.raises(ValueError, match=r"triangle 1 of geometry 1 has a vertex index out of range"):
        scene.add_triangles(mesh.vertices, np.array([[0, 1, 2], [0, 1, 8]]))
    with pytest.raises(ValueError, match="vertex 2 of geometry 1 is not finite"):
        scene.add_triangles(np.array([[0, 0, 0], [1, 0, 0], [0, np.inf, 0]]), np.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="device must be a CPU device"):
        RaycastingScene(device="CUDA:0")
    # A ray the core refuses (zero direction) names its row.
    with pytest.raises(spacebvh.Error, match="3"):
        scene.cast_rays(np.array([[0, 0, 0, 1, 0, 0]] * 3 + [[0, 0, 0, 0, 0, 0]], dtype=np.float32))
    # An empty scene misses every ray.
    empty = RaycastingScene()
    assert np.array_equal(empty.count_intersections(np.ones((2, 6))), [0, 0])
    assert np.all(np.isinf(empty.cast_rays(np.ones((2, 6)))["t_hit"]))
