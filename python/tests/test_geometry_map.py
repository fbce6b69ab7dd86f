# SPDX-License-Identifier: MIT
"""spacebvh.GeometryMap, the one-pass binding behind spacebvh.open3d's ray queries and occupancy.

Its answers are checked against the exact Fraction reference (python/tests/test_trimesh_contacts.py) on a
box, and against the general calls they stand for (Tracer.intersect, RayQueries.all, .count, .contains,
mapped to geometry and primitive ids in NumPy) on a built-in scene and on the shared bunny when
../shared is there; the same on 1 and 2 threads, for float32 and float64 rows and strided rows; bad
input raises errors that name it.
"""

import os
from pathlib import Path

import numpy as np
import pytest
from test_trimesh_contacts import box_mesh, exact_contacts, touching_rays

import spacebvh

SCENES = Path(os.environ.get("SPACEBVH_SCENES") or Path(__file__).resolve().parents[2].parent / "shared" / "scenes")
INVALID = 0xFFFFFFFF


def unit_normals(triangles):
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0).astype(np.float32)


def setup(scene, counts):
    """(map, tracer, queries, triangles) over a scene whose triangles are `counts` geometries in turn."""
    tree = spacebvh.build(scene, "binned")
    triangles = np.asarray(scene.triangles(), dtype=np.float64)
    return spacebvh.GeometryMap(counts, unit_normals(triangles)), spacebvh.Tracer(tree), spacebvh.RayQueries(tree)


def ids_of(triangle, counts):
    """Geometry and primitive ids of combined triangle numbers (-1: INVALID)."""
    starts = np.cumsum([0] + list(counts))
    geometry = np.searchsorted(starts, triangle, side="right") - 1
    hit = triangle >= 0
    return np.where(hit, geometry, INVALID), np.where(hit, triangle - starts[np.clip(geometry, 0, None)], INVALID)


def random_rays(scene, count, seed):
    rng = np.random.default_rng(seed)
    lo, hi = (np.array(b) for b in scene.bounds)
    return np.hstack([rng.uniform(lo, hi, (count, 3)), rng.normal(size=(count, 3))]).astype(np.float32)


def check_against_general_calls(scene, counts, rays, points):
    """Every GeometryMap answer equals the general call it stands for, mapped in NumPy, on 1 and 2 threads."""
    geometry_map, tracer, queries = setup(scene, counts)
    normals = unit_normals(np.asarray(scene.triangles(), dtype=np.float64))
    o, d = rays[:, :3], rays[:, 3:]
    t, triangle, u, v = tracer.intersect(o, d)
    index_ray, listed, lt, lu, lv, _ = queries.all(o, d, points=False)
    for threads in (1, 2):
        cast = geometry_map.cast_rays(tracer, rays, threads=threads)
        geometry, primitive = ids_of(triangle, counts)
        hit = triangle >= 0
        assert np.array_equal(cast["t_hit"], t.astype(np.float32))
        assert np.array_equal(cast["geometry_ids"], geometry) and np.array_equal(cast["primitive_ids"], primitive)
        assert np.array_equal(cast["primitive_uvs"], np.where(hit[:, None], np.stack([u, v], axis=1), 0))
        assert np.array_equal(cast["primitive_normals"], np.where(hit[:, None], normals[triangle], 0))
        assert np.array_equal(geometry_map.test_occlusions(tracer, rays, threads=threads), tracer.occluded(o, d))
        count = geometry_map.count_intersections(queries, rays, threads=threads)
        assert count.dtype == np.int32 and np.array_equal(count, queries.count(o, d))
        every = geometry_map.list_intersections(queries, rays, threads=threads)
        splits = np.concatenate([[0], np.cumsum(np.bincount(index_ray, minlength=len(rays)))])
        assert np.array_equal(every["ray_splits"], splits) and np.array_equal(every["ray_ids"], index_ray)
        geometry, primitive = ids_of(listed, counts)
        assert np.array_equal(every["geometry_ids"], geometry) and np.array_equal(every["primitive_ids"], primitive)
        assert np.array_equal(every["t_hit"], lt.astype(np.float32))
        assert np.array_equal(every["primitive_uvs"], np.stack([lu, lv], axis=1).astype(np.float32))
        occupancy = geometry_map.compute_occupancy(queries, points, threads=threads)
        assert occupancy.dtype == np.float32 and np.array_equal(occupancy, queries.contains(points))
    return geometry_map, tracer, queries


def test_exact_on_a_box_and_hostile_rays():
    box = box_mesh()
    scene = spacebvh.mesh(box.vertices, box.faces)
    geometry_map, tracer, queries = setup(scene, [4, 8])  # two geometries: faces 0-3 and 4-11
    rng = np.random.default_rng(11)
    origins = rng.uniform(-0.5, 1.5, (200, 3)).astype(np.float32).astype(np.float64)
    directions = rng.normal(size=(200, 3)).astype(np.float32).astype(np.float64)
    touching_origins, touching_directions = touching_rays()
    rays = np.vstack([np.hstack([origins, directions]), np.hstack([touching_origins, touching_directions])])
    points = rng.uniform(-0.5, 1.5, (500, 3))
    check_against_general_calls(scene, [4, 8], rays, points)
    # Generic rays against the Fractions: every contact is a crossing, listed once in order of t.
    reference = [exact_contacts(box, o, d) for o, d in zip(origins, directions)]
    every = geometry_map.list_intersections(queries, rays[: len(origins)])
    assert np.array_equal(np.diff(every["ray_splits"]), [len(hits) for hits in reference])
    expected = np.array([index for hits in reference for _, index, _ in hits])
    assert np.array_equal(every["geometry_ids"], (expected >= 4).astype(np.uint32))
    assert np.array_equal(every["primitive_ids"], np.where(expected >= 4, expected - 4, expected))
    exact_t = np.array([float(t) for hits in reference for t, _, _ in hits])
    assert np.allclose(every["t_hit"], exact_t, rtol=1e-6)
    # Touching rays: every one meets the box as a contact (cast_rays) and crosses it evenly.
    touching = np.hstack([touching_origins, touching_directions])
    expected_contact = [bool(exact_contacts(box, o, d)) for o, d in zip(touching_origins, touching_directions)]
    assert np.array_equal(geometry_map.test_occlusions(tracer, touching), expected_contact)
    assert np.array_equal(np.isfinite(geometry_map.cast_rays(tracer, touching)["t_hit"]), expected_contact)
    assert np.all(geometry_map.count_intersections(queries, touching) % 2 == 0)


def test_builtin_scene_rows_of_any_layout():
    scene = spacebvh.load_scene("builtin:" + spacebvh.builtin_scenes()[0])
    n = len(scene.triangles())
    counts = [n // 3, n - n // 3]
    rays = random_rays(scene, 3000, 5)
    points = random_rays(scene, 3000, 6)[:, :3]
    geometry_map, tracer, queries = check_against_general_calls(scene, counts, rays, points)
    # float64, Fortran-ordered and strided rows: the same answers as contiguous float32 ones.
    reference = geometry_map.list_intersections(queries, rays)
    wide = np.zeros((len(rays), 12), dtype=np.float32)
    wide[:, ::2] = rays
    for layout in (rays.astype(np.float64), np.asfortranarray(rays), wide[:, ::2]):
        answer = geometry_map.list_intersections(queries, layout)
        assert all(np.array_equal(answer[key], reference[key]) for key in reference)
        assert np.array_equal(
            geometry_map.cast_rays(tracer, layout)["t_hit"], tracer.intersect(rays[:, :3], rays[:, 3:])[0]
        )
    empty = geometry_map.list_intersections(queries, rays[:0])
    assert np.array_equal(empty["ray_splits"], [0]) and empty["primitive_uvs"].shape == (0, 2)


@pytest.mark.skipif(not (SCENES / "bunny" / "bunny.obj").exists(), reason=f"no shared bunny under {SCENES}")
def test_shared_bunny():
    scene = spacebvh.load_scene(str(SCENES / "bunny" / "bunny.obj"))
    rays = random_rays(scene, 20000, 9)
    check_against_general_calls(scene, [len(scene.triangles())], rays, random_rays(scene, 20000, 10)[:, :3])


def test_bad_input_is_named():
    box = box_mesh()
    scene = spacebvh.mesh(box.vertices, box.faces)
    geometry_map, tracer, queries = setup(scene, [12])
    rays = np.tile(np.array([[0.5, 0.5, -1.0, 0.0, 0.0, 1.0]], dtype=np.float32), (4, 1))
    with pytest.raises(spacebvh.Error, match=r"rays must have shape \(k, 6\).*5 columns"):
        geometry_map.cast_rays(tracer, rays[:, :5])
    with pytest.raises(spacebvh.Error, match=r"rays must have shape \(k, 6\)"):
        geometry_map.list_intersections(queries, rays[0])
    with pytest.raises(TypeError, match="rays must be an array of real numbers"):
        geometry_map.count_intersections(queries, rays.astype(str))
    bad = rays.copy()
    bad[2, 4] = np.nan
    with pytest.raises(spacebvh.Error, match="ray 2"):
        geometry_map.test_occlusions(tracer, bad)
    with pytest.raises(spacebvh.Error, match="ray 0: need 0 <= tmin <= tmax"):
        geometry_map.test_occlusions(tracer, rays, 2.0, 1.0)
    with pytest.raises(spacebvh.Error, match="query_points: row 1 is not finite"):
        geometry_map.compute_occupancy(queries, np.array([[0.5, 0.5, 0.5], [np.inf, 0.0, 0.0]]))
    with pytest.raises(spacebvh.Error, match="one row per triangle"):
        spacebvh.GeometryMap([12], np.zeros((11, 3), dtype=np.float32))
    with pytest.raises(spacebvh.Error, match=r"counts\[1\] must be >= 0"):
        spacebvh.GeometryMap([12, -1], np.zeros((12, 3), dtype=np.float32))
    with pytest.raises(spacebvh.Error, match="one row per triangle"):
        spacebvh.GeometryMap([10**15], np.zeros((12, 3), dtype=np.float32))
    smaller = spacebvh.GeometryMap([4], np.zeros((4, 3), dtype=np.float32))
    with pytest.raises(spacebvh.Error, match="over 12 triangles, the geometry map over 4"):
        smaller.cast_rays(tracer, rays)
    with pytest.raises(spacebvh.Error, match="over 12 triangles, the geometry map over 4"):
        smaller.list_intersections(queries, rays)
    with pytest.raises(spacebvh.Error, match="threads must be >= 0"):
        geometry_map.cast_rays(tracer, rays, threads=-1)


def test_the_lowest_bad_ray_is_named_across_blocks():
    """The ray queries read and trace the rows block by block: whichever blocks hold bad rays and however
    many threads run, the lowest bad ray is named, and a batch of good rays of any length (not a multiple
    of a block) answers as the general calls do."""
    scene = spacebvh.load_scene("builtin:" + spacebvh.builtin_scenes()[0])
    geometry_map, tracer, queries = setup(scene, [len(scene.triangles())])
    rays = random_rays(scene, 5000, 12)
    bad = rays.copy()
    bad[[4321, 777, 3000], [3, 0, 5]] = [np.nan, np.inf, np.nan]
    bad[1999, 3:] = 0.0  # a zero direction
    for threads in (1, 2):
        for call, over in (
            (geometry_map.cast_rays, tracer),
            (geometry_map.test_occlusions, tracer),
            (geometry_map.count_intersections, queries),
            (geometry_map.list_intersections, queries),
        ):
            with pytest.raises(spacebvh.Error, match=r"^ray 777: "):
                call(over, bad, threads=threads)
            with pytest.raises(spacebvh.Error, match=r"^ray 999: "):
                call(over, bad[1000:], threads=threads)  # rows numbered from the slice's start
        for count in (1, 255, 256, 257, 1025):
            part = rays[:count]
            t = tracer.intersect(part[:, :3], part[:, 3:])[0]
            assert np.array_equal(geometry_map.cast_rays(tracer, part, threads=threads)["t_hit"], t)
            occluded = tracer.occluded(part[:, :3], part[:, 3:])
            assert np.array_equal(geometry_map.test_occlusions(tracer, part, threads=threads), occluded)
            counts = queries.count(part[:, :3], part[:, 3:])
            assert np.array_equal(geometry_map.count_intersections(queries, part, threads=threads), counts)
