# SPDX-License-Identifier: MIT
"""Tracer.hits: the closest hits of only the rays that hit, with their points, in one call.

Checked against an exact rational reference on a box touched at edges and vertices (near the origin
and far from it), and against Tracer.intersect filtered in NumPy with Scene.hit_points, bit for bit,
on a built-in scene with many rays (several blocks of the compaction) at any thread count.
"""

import numpy as np
import pytest
from test_trimesh_contacts import box_mesh, exact_contacts, touching_rays

import spacebvh


def tracer_of(vertices, faces, threads=0):
    return spacebvh.Tracer(spacebvh.build(spacebvh.mesh(vertices, faces), "binned"), threads=threads)


@pytest.mark.parametrize("offset", [0.0, 2.0**20 + 0.25])
@pytest.mark.parametrize("threads", [1, 2])
def test_hits_are_the_exact_nearest_contacts(offset, threads):
    mesh = box_mesh(lo=(offset,) * 3, hi=(offset + 1.0,) * 3)
    origins, directions = touching_rays()
    origins = origins + offset
    reference = [exact_contacts(mesh, o, d) for o, d in zip(origins, directions)]
    index_ray, primitive, points = tracer_of(mesh.vertices, mesh.faces, threads).hits(origins, directions)
    assert index_ray.dtype == np.int64 and primitive.dtype == np.int64 and points.dtype == np.float64
    assert np.array_equal(index_ray, [ray for ray, hits in enumerate(reference) if hits])
    assert points.shape == (len(index_ray), 3)
    for k, ray in enumerate(index_ray):
        hits = reference[ray]
        assert primitive[k] in {index for t, index, _ in hits if t == hits[0][0]}, (ray, primitive[k])
        expected = [float(x) for x in hits[0][2]]
        if offset == 0.0:
            assert np.array_equal(points[k], expected), (ray, points[k], expected)
        else:  # a float64 mesh keeps its precision far from the origin
            np.testing.assert_allclose(points[k], expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_hits_equal_intersect_filtered_with_hit_points(dtype):
    scene = spacebvh.load_scene("builtin:" + spacebvh.builtin_scenes()[0])
    corners = scene.triangles().astype(np.float64).reshape(-1, 3) + (3e4 if dtype == np.float64 else 0.0)
    faces = np.arange(len(corners)).reshape(-1, 3)
    vertices = corners.astype(dtype)
    origins, directions = spacebvh.random_rays(spacebvh.mesh(vertices, faces), 20000, seed=3)
    rng = np.random.default_rng(4)
    tmin, tmax = rng.uniform(0, 0.1, len(origins)), rng.uniform(0.5, 50, len(origins))
    answers = []
    for threads in (1, 2, 0):
        tracer = tracer_of(vertices, faces, threads)
        _t, primitive, u, v = tracer.intersect(origins, directions, tmin, tmax)
        hit = np.flatnonzero(primitive >= 0)
        assert 0 < len(hit) < len(origins)  # hits and misses in every block
        got = tracer.hits(origins, directions, tmin, tmax)
        assert got[2].dtype == dtype
        assert np.array_equal(got[0], hit)
        assert np.array_equal(got[1], primitive[hit])
        assert np.array_equal(got[2], tracer.scene.hit_points(primitive[hit], u[hit], v[hit]))
        index_ray, index_tri, none = tracer.hits(origins, directions, tmin, tmax, points=False)
        assert none is None and np.array_equal(index_ray, hit) and np.array_equal(index_tri, primitive[hit])
        answers.append(got)
    for got in answers[1:]:
        assert all(np.array_equal(a, b) for a, b in zip(got, answers[0]))


def test_no_rays_and_no_hits():
    mesh = box_mesh()
    tracer = tracer_of(mesh.vertices, mesh.faces)
    index_ray, primitive, points = tracer.hits(np.zeros((0, 3)), np.zeros((0, 3)))
    assert index_ray.shape == (0,) and primitive.shape == (0,) and points.shape == (0, 3)
    index_ray, primitive, points = tracer.hits(np.full((3, 3), 5.0), [0.0, 0.0, 1.0])
    assert index_ray.shape == (0,) and primitive.shape == (0,) and points.shape == (0, 3)


def test_bad_input_names_the_argument():
    mesh = box_mesh()
    tracer = tracer_of(mesh.vertices, mesh.faces)
    origins, directions = touching_rays()
    bad = origins.copy()
    bad[7, 1] = np.nan
    with pytest.raises(spacebvh.Error, match="origins"):
        tracer.hits(bad, directions)
    with pytest.raises(spacebvh.Error, match="directions"):
        tracer.hits(origins, directions[:, :2])
    with pytest.raises(spacebvh.Error, match="threads"):
        tracer.hits(origins, directions, threads=-1)
