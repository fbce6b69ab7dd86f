# SPDX-License-Identifier: MIT
"""spacebvh.dask on a real local cluster of two worker processes: ray and point queries over Dask
arrays in several chunks give exactly one process's answers, and each worker loads the tree file
once however many chunks and calls it serves."""

import numpy as np
import pytest

import spacebvh

da = pytest.importorskip("dask.array")
pytest.importorskip("distributed")
import spacebvh.dask as sdask  # noqa: E402  (after the skips: it needs dask)


def uv_sphere(offset, rings=24, segments=48):
    """A closed unit sphere of latitude rings, centred at (offset, offset, offset), float64."""
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack(np.meshgrid(theta, phi, indexing="ij"), axis=-1).reshape(-1, 2)
    body = np.stack(
        [np.sin(ring[:, 0]) * np.cos(ring[:, 1]), np.sin(ring[:, 0]) * np.sin(ring[:, 1]), np.cos(ring[:, 0])], 1
    )
    vertices = np.vstack([[0, 0, 1], body, [0, 0, -1]]) + offset
    at = lambda r, s: 1 + r * segments + s % segments  # noqa: E731
    faces = [(0, at(0, s), at(0, s + 1)) for s in range(segments)]
    bottom = len(vertices) - 1
    faces += [(bottom, at(rings - 2, s + 1), at(rings - 2, s)) for s in range(segments)]
    for r in range(rings - 2):
        for s in range(segments):
            faces += [(at(r, s), at(r + 1, s), at(r + 1, s + 1)), (at(r, s), at(r + 1, s + 1), at(r, s + 1))]
    return vertices, np.array(faces)


@pytest.fixture(scope="module")
def cluster_queries(tmp_path_factory):
    """A scene given as a Scene object (a float64 mesh: sent to the workers once) and its tree file."""
    scene = spacebvh.mesh(*uv_sphere(1000.0))
    bvh = spacebvh.build(scene, "spatial")
    path = tmp_path_factory.mktemp("tree") / "sphere.sbvh"
    bvh.save(str(path))
    with sdask.DaskQueries(scene, path, n_workers=2, threads=1) as queries:
        yield scene, bvh, queries


def test_two_workers_answer_as_one_process(cluster_queries):
    scene, bvh, queries = cluster_queries
    rng = np.random.default_rng(5)
    origins = rng.uniform(998.5, 1001.5, (20_000, 3))
    directions = rng.normal(size=(20_000, 3))
    points = rng.uniform(998.5, 1001.5, (20_000, 3))
    o, d, p = (da.from_array(a, chunks=(1_500, 3)) for a in (origins, directions, points))

    tracer, crossings = spacebvh.Tracer(bvh), spacebvh.RayQueries(bvh)
    t, primitive, u, v = (x.compute() for x in queries.intersect(o, d))
    expected = tracer.intersect(origins, directions)
    for got, want in zip((t, primitive, u, v), expected):
        assert got.dtype == want.dtype and np.array_equal(got, want)
    assert np.array_equal(queries.occluded(o, d).compute(), tracer.occluded(origins, directions))
    assert np.array_equal(queries.first_primitive(o, d).compute(), crossings.first_primitive(origins, directions))
    assert np.array_equal(queries.count(o, d).compute(), crossings.count(origins, directions))
    inside = queries.contains(p).compute()
    assert np.array_equal(inside, crossings.contains(points))
    assert 0 < inside.sum() < len(points)  # both answers occur
    distances = spacebvh.DistanceQueries(bvh)
    assert np.array_equal(queries.signed_distance(p).compute(), distances.signed_distance(points))
    assert np.array_equal(queries.distance(p).compute(), distances.distance(points))

    # Each worker loaded the tree once, whatever the chunks and calls it served; both served some.
    loads = queries.client.run(lambda: __import__("spacebvh.dask").dask._load_count)
    assert sorted(loads.values()) == [1, 1], loads


def test_bad_arguments_are_named(cluster_queries, tmp_path):
    _, _, queries = cluster_queries
    with pytest.raises(ValueError, match=r"origins must be a \(n, 3\) array"):
        queries.intersect(da.zeros((10, 2)), da.zeros((10, 3)))
    with pytest.raises(ValueError, match="differ in length"):
        queries.count(da.zeros((10, 3)), da.zeros((9, 3)))
    with pytest.raises(FileNotFoundError, match="tree_file"):
        sdask.DaskQueries("builtin:interior", tmp_path / "missing.sbvh", client=queries.client)
