# SPDX-License-Identifier: MIT
"""Contacts against crossings in spacebvh.trimesh, checked against an exact rational reference.

intersects_first, intersects_any and single-hit intersects_id / intersects_location are contacts:
closed triangles, so a ray that touches a box only along an edge, at a vertex, or runs in the plane
of a face to its boundary hits it, from every side (+x and -x alike). Multiple hits and
contains_points are crossings: each crossing of the surface once, so a touching ray counts an even
number. The reference (Fractions, every triangle) is independent of spacebvh's code.
"""

import itertools
from fractions import Fraction
from types import SimpleNamespace

import numpy as np
import pytest

from spacebvh.trimesh import RayMeshIntersector


def box_mesh(lo=(0.0, 0.0, 0.0), hi=(1.0, 1.0, 1.0)):
    """An axis-aligned box of 12 outward-facing triangles, as a mesh-like object of trimesh's shape."""
    vertices = np.array([[(lo, hi)[(i >> a) & 1][a] for a in range(3)] for i in range(8)], dtype=np.float64)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    faces = np.array([tri for a, b, c, d in quads for tri in ((a, b, c), (a, c, d))], dtype=np.int64)
    return SimpleNamespace(vertices=vertices, faces=faces, bounds=np.array([lo, hi], dtype=np.float64))


def exact_contacts(mesh, origin, direction):
    """Every (t, triangle) where the ray meets a closed triangle whose plane does not contain it,
    t >= 0, in exact rational arithmetic, sorted by (t, triangle)."""
    o = [Fraction(x) for x in origin]
    d = [Fraction(x) for x in direction]
    found = []
    for index, face in enumerate(mesh.faces):
        a, b, c = ([Fraction(x) for x in mesh.vertices[k]] for k in face)
        e1 = [b[i] - a[i] for i in range(3)]
        e2 = [c[i] - a[i] for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        denominator = sum(n[i] * d[i] for i in range(3))
        if denominator == 0:
            continue  # the ray is parallel to the plane (or in it): never a contact of this triangle
        t = sum(n[i] * (a[i] - o[i]) for i in range(3)) / denominator
        if t < 0:
            continue
        p = [o[i] + t * d[i] for i in range(3)]
        # Signed areas of the sub-triangles against the normal: all >= 0 means inside or on the boundary.
        inside = True
        for p0, p1 in ((a, b), (b, c), (c, a)):
            u = [p1[i] - p0[i] for i in range(3)]
            w = [p[i] - p0[i] for i in range(3)]
            cross = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            if sum(cross[i] * n[i] for i in range(3)) < 0:
                inside = False
        if inside:
            found.append((t, index, p))
    return sorted(found, key=lambda hit: (hit[0], hit[1]))


def assert_nearest_contacts(reference, first):
    """Each ray's triangle is one of its contacts at the smallest t (-1 where there is none): triangles
    tied at that t (a shared edge or vertex) may come in any of their orders."""
    for ray, hits in enumerate(reference):
        nearest = {index for t, index, _ in hits if t == hits[0][0]}
        assert (first[ray] in nearest) if hits else first[ray] == -1, (ray, first[ray], nearest)


def touching_rays():
    """Rays parallel to each axis, from both sides, in the planes of faces and along edges of the unit
    box (other coordinates from {0, 1/2, 1}), through its middle, and just beside it (misses); plus
    oblique rays that touch only an edge or a vertex."""
    rays = []
    for axis, sign in itertools.product(range(3), (1.0, -1.0)):
        others = [a for a in range(3) if a != axis]
        for first, second in itertools.product((0.0, 0.5, 1.0, 1.0 + 2.0**-20, -(2.0**-20)), repeat=2):
            origin = np.zeros(3)
            origin[axis] = -1.0 if sign > 0 else 2.0
            origin[others[0]], origin[others[1]] = first, second
            direction = np.zeros(3)
            direction[axis] = sign
            rays.append((origin, direction))
    rays += [
        (np.array([0.0, 0.0, 2.0]), np.array([1.0, 1.0, -1.0])),  # touches only the vertex (1, 1, 1)
        (np.array([2.0, 2.0, 0.0]), np.array([-1.0, -1.0, 1.0])),  # the same vertex from the other side
        (np.array([0.5, -1.0, 0.0]), np.array([0.0, 1.0, 1.0])),  # touches only the edge y = 0, z = 1
        (np.array([0.5, 1.0, 2.0]), np.array([0.0, -1.0, -1.0])),  # the same edge, reversed
        (np.array([-1.0, 0.5, 2.0]), np.array([1.0, 0.0, -1.0])),  # touches only the edge x = 0, z = 1
    ]
    origins = np.array([o for o, _ in rays])
    directions = np.array([d for _, d in rays])
    return origins, directions


@pytest.mark.parametrize("threads", [1, 2])
def test_single_hit_queries_are_contacts_from_every_side(threads):
    mesh = box_mesh()
    origins, directions = touching_rays()
    reference = [exact_contacts(mesh, o, d) for o, d in zip(origins, directions)]
    expected_hit = np.array([len(hits) > 0 for hits in reference])
    # Every axis ray in a face's plane or along an edge (9 of 25 per side) and the oblique ones hit; the
    # ones beside the box miss.
    assert expected_hit.sum() == 6 * 9 + 5 and (~expected_hit).sum() == 6 * 16
    intersector = RayMeshIntersector(mesh, threads=threads)

    assert np.array_equal(intersector.intersects_any(origins, directions), expected_hit)
    first = intersector.intersects_first(origins, directions)
    assert first.dtype == np.int64
    assert_nearest_contacts(reference, first)

    index_tri, index_ray = intersector.intersects_id(origins, directions, multiple_hits=False)
    assert np.array_equal(index_ray, np.flatnonzero(expected_hit))
    assert np.array_equal(index_tri, first[expected_hit])

    locations, index_ray, index_tri = intersector.intersects_location(origins, directions, multiple_hits=False)
    assert np.array_equal(index_ray, np.flatnonzero(expected_hit))
    assert np.array_equal(index_tri, first[expected_hit])
    expected_points = np.array([[float(x) for x in reference[r][0][2]] for r in index_ray])
    assert np.array_equal(locations, expected_points)


def test_multiple_hits_and_containment_stay_crossings():
    mesh = box_mesh()
    origins, directions = touching_rays()
    intersector = RayMeshIntersector(mesh)
    index_tri, index_ray = intersector.intersects_id(origins, directions, multiple_hits=True)
    counts = np.bincount(index_ray, minlength=len(origins))
    # A ray from outside that touches the box (and never enters it) or passes through it crosses the
    # closed surface an even number of times: a grazing ray counts 0 or 2, never 1.
    assert np.all(counts % 2 == 0)
    # Rays through the middle of two opposite faces cross exactly twice.
    middle = np.all((origins == 0.5) | (directions != 0), axis=1) & (np.count_nonzero(directions, axis=1) == 1)
    assert middle.sum() == 6 and np.all(counts[middle] == 2)
    # Points on the surface follow the documented containment rule; points off it the true answer.
    inside = np.array([[0.5, 0.5, 0.5], [0.25, 0.75, 0.5]])
    outside = np.array([[1.5, 0.5, 0.5], [-(2.0**-30), 0.5, 0.5]])
    assert np.array_equal(intersector.contains_points(np.vstack([inside, outside])), [True, True, False, False])


def test_contacts_on_a_translated_float64_box():
    # Far from the origin: the tree's frame is centred on the mesh, the contacts are still the exact ones.
    offset = np.array([5.0e5, -3.0e5, 2.5e5])
    mesh = box_mesh(lo=tuple(offset), hi=tuple(offset + 1.0))
    origins, directions = touching_rays()
    origins = origins + offset
    reference = [exact_contacts(mesh, o, d) for o, d in zip(origins, directions)]
    intersector = RayMeshIntersector(mesh)
    assert np.array_equal(intersector.intersects_any(origins, directions), [len(h) > 0 for h in reference])
    assert_nearest_contacts(reference, intersector.intersects_first(origins, directions))
