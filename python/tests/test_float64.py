# SPDX-License-Identifier: MIT
"""Tests of spacebvh.Tracer64 (float64 meshes traced exactly) against an independent exact reference
in rational arithmetic (fractions.Fraction): rays exactly through vertices and edge midpoints of closed
boxes at 10^7 offsets and at 10^-6 scale, and the large-coordinate case of the trimesh drop-in."""

import itertools
import unittest
from fractions import Fraction

import numpy as np

import spacebvh


def closed_box(centre, step, cells):
    """A closed box surface, each face a cells x cells grid of squares split in two triangles;
    every coordinate exact in float64 (step a power of two)."""
    vertices, faces, index = [], [], {}

    def vertex(point):
        key = tuple(point)
        if key not in index:
            index[key] = len(vertices)
            vertices.append([centre[a] + point[a] * step for a in range(3)])
        return index[key]

    half = cells / 2
    for axis, side in itertools.product(range(3), (-half, half)):
        for i, j in itertools.product(range(cells), repeat=2):

            def corner(di, dj):
                p = [0.0, 0.0, 0.0]
                p[axis] = side
                p[(axis + 1) % 3] = -half + i + di
                p[(axis + 2) % 3] = -half + j + dj
                return vertex(p)

            faces.append([corner(0, 0), corner(1, 0), corner(1, 1)])
            faces.append([corner(0, 0), corner(1, 1), corner(0, 1)])
    return np.array(vertices, dtype=np.float64), np.array(faces, dtype=np.int64)


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def exact_closest_t(vertices, faces, origin, direction):
    """The smallest t >= 0 at which the ray meets a closed triangle, in rationals (None: a miss)."""
    o = [Fraction(x) for x in origin]
    d = [Fraction(x) for x in direction]
    best = None
    for face in faces:
        v0, v1, v2 = ([Fraction(x) for x in vertices[k]] for k in face)
        n = cross([b - a for a, b in zip(v0, v1)], [b - a for a, b in zip(v0, v2)])
        den = dot(n, d)
        if den == 0:
            continue
        t = dot(n, [a - b for a, b in zip(v0, o)]) / den
        if t < 0:
            continue
        p = [a + t * b for a, b in zip(o, d)]
        corners = (v0, v1, v2)
        inside = all(
            dot(
                cross(
                    [a - b for a, b in zip(corners[(k + 1) % 3], p)], [a - b for a, b in zip(corners[(k + 2) % 3], p)]
                ),
                n,
            )
            >= 0
            for k in range(3)
        )
        if inside and (best is None or t < best):
            best = t
    return best


class Tracer64Test(unittest.TestCase):
    def test_rays_through_vertices_and_edges_equal_the_rational_reference(self):
        for centre, step in (((1e7, -1e7, 1e7), 2.0**-20), ((0.5, 0.25, -0.75), 2.0**-22)):
            vertices, faces = closed_box(centre, step, 2)
            tracer = spacebvh.Tracer64(vertices, faces, builder="sbvh")
            outside = np.array(centre) + np.array([5.0, 2.5, -4.0]) * step
            targets = list(vertices) + [(vertices[a] + vertices[b]) / 2 for a, b in faces[:, :2]]
            for eye in (np.array(centre), outside):
                directions = np.array([target - eye for target in targets])
                origins = np.repeat(eye[None, :], len(directions), axis=0)
                t, primitive, _, _ = tracer.intersect(origins, directions)
                hit = tracer.occluded(origins, directions)
                for i, direction in enumerate(directions):
                    truth = exact_closest_t(vertices, faces, eye, direction)
                    self.assertEqual(primitive[i] >= 0, truth is not None, f"ray {i} from {eye}")
                    self.assertEqual(bool(hit[i]), truth is not None)
                    if truth is not None:
                        self.assertAlmostEqual(t[i], float(truth), delta=1e-12 * float(truth))
                if eye is not outside:
                    self.assertTrue(np.all(primitive >= 0), "a ray from inside the closed box escaped")

    def test_ray_just_off_a_far_surface_cast_away_does_not_hit(self):
        z = 5e5
        vertices = np.array([[-1e3, -1e3, z], [1e3, -1e3, z], [1e3, 1e3, z], [-1e3, 1e3, z]])
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        tracer = spacebvh.Tracer64(vertices, faces)
        t, primitive, _, _ = tracer.intersect([[0.3, 0.2, z + 0.01], [0.3, 0.2, z + 0.01]], [[0, 0, 1], [0, 0, -1]])
        self.assertEqual(primitive[0], -1)
        self.assertEqual(t[0], np.inf)
        self.assertEqual(primitive[1], 0)
        self.assertAlmostEqual(t[1], 0.01, delta=1e-9)
        self.assertFalse(tracer.occluded([0.3, 0.2, z - 0.01], [0.1, 0.0, -1.0])[0])
        # The exact distance is (z + 0.01) - z of the doubles, itself a double: tmax decides exactly.
        gap = (z + 0.01) - z
        self.assertTrue(tracer.occluded([0.3, 0.2, z + 0.01], [0.0, 0.0, -1.0], tmax=gap)[0])
        self.assertFalse(tracer.occluded([0.3, 0.2, z + 0.01], [0.0, 0.0, -1.0], tmax=np.nextafter(gap, 0.0))[0])

    def test_bad_input_is_a_clear_error(self):
        vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
        tracer = spacebvh.Tracer64(vertices, [[0, 1, 2]])
        with self.assertRaisesRegex(spacebvh.Error, "ray 1: direction is zero"):
            tracer.intersect([[0, 0, 1], [0, 0, 1]], [[0, 0, -1], [0, 0, 0]])
        with self.assertRaisesRegex(spacebvh.Error, "shape"):
            tracer.intersect([[0, 0]], [[0, 0, 1]])
        with self.assertRaisesRegex(spacebvh.Error, "triangle 0 uses vertex 7"):
            spacebvh.Tracer64(vertices, [[0, 1, 7]])


if __name__ == "__main__":
    unittest.main()
