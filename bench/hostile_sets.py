# SPDX-License-Identifier: MIT
"""Hostile sets for the benchmark scripts, each with its exact answers: rays at the vertices and edge
midpoints of a rotated icosphere (2 crossings each); rays along the axes through a subdivided unit
box's grid lines, in its faces' planes and along its edges; and rays whose origins lie exactly on a
closed box (at triangle interiors, on edges and at vertices; directions off the surface and along it)
with the points they start from.

The exact answers of the rays from the surface come from the Fraction references of the Python tests
(python/tests/test_queries.py: crossings by the rule of docs/queries.md; test_trimesh_contacts.py:
contacts with closed triangles, t >= 0), over every triangle, on the float32 inputs: independent of
spacebvh's code.
"""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "python" / "tests"))
from test_queries import exact_triangles, grid_box, reference_hits  # noqa: E402
from test_trimesh_contacts import exact_contacts  # noqa: E402

# Spots on a face, in its plane's coordinates (u, v) within one 2 x 2 quad from (2i, 2j), by kind: the
# quads are split along (0, 0)-(2, 2), so (1.5, 0.5) is inside a triangle, (1, 0) on a grid line,
# (1, 1) on a diagonal and (0, 0) a vertex.
SPOTS = {"interior": [(1.5, 0.5), (0.5, 1.25)], "edge": [(1.0, 0.0), (1.0, 1.0)], "vertex": [(0.0, 0.0)]}


def directions_for(axis, outward):
    """(label, direction) pairs for a face with normal along `axis` (outward: +1 or -1): off the surface
    (the normals and obliques both ways) and along it (in the face's plane). Exact in float32."""
    u, v = (axis + 1) % 3, (axis + 2) % 3

    def vector(n, a, b):
        d = [0.0, 0.0, 0.0]
        d[axis], d[u], d[v] = n * outward, a, b
        return d

    return [
        ("off", vector(1, 0, 0)),
        ("off", vector(-1, 0, 0)),
        ("off", vector(1, 0.375, 0.25)),
        ("off", vector(-1, 0.25, -0.375)),
        ("along", vector(0, 1, 0)),
        ("along", vector(0, -0.5, 1)),
    ]


def surface_rays(n=3):
    """The box [0, 2n]^3 of test_queries.grid_box(n) and rays from spots on each face, one per spot
    (each quad's spots, the box's edges and corners included) and direction: (vertices, faces, origins,
    directions, kinds), kinds 'interior off', 'edge along', ... per ray."""
    vertices, faces = grid_box(n)
    size = 2.0 * n
    origins, directions, kinds = [], [], []
    for axis in range(3):
        u, v = (axis + 1) % 3, (axis + 2) % 3
        for side, outward in ((0.0, -1), (size, 1)):
            for kind, spots in SPOTS.items():
                for i in range(n + 1):
                    for j in range(n + 1):
                        for a, b in spots:
                            if 2 * i + a > size or 2 * j + b > size:
                                continue
                            origin = [0.0, 0.0, 0.0]
                            origin[axis], origin[u], origin[v] = side, 2 * i + a, 2 * j + b
                            for label, direction in directions_for(axis, outward):
                                origins.append(origin)
                                directions.append(direction)
                                kinds.append(f"{kind} {label}")
    return (
        vertices,
        faces,
        np.array(origins, dtype=np.float32),
        np.array(directions, dtype=np.float32),
        np.array(kinds),
    )


def exact_answers(vertices, faces, origins, directions):
    """Per ray over [0, inf): the first contact's t (inf where none), the set of triangles touched at
    that t, and the number of crossings."""
    mesh = SimpleNamespace(vertices=vertices.astype(np.float64), faces=faces)
    triangles = exact_triangles(vertices, faces)
    first, nearest, crossings = [], [], []
    for origin, direction in zip(origins, directions):
        contacts = exact_contacts(mesh, origin.astype(np.float64), direction.astype(np.float64))
        first.append(float(contacts[0][0]) if contacts else np.inf)
        nearest.append({index for t, index, _ in contacts if t == contacts[0][0]})
        crossings.append(len(reference_hits(triangles, origin, direction)))
    return np.array(first), nearest, np.array(crossings)


def wrong_first_t(t_hit, exact_t, size):
    """Where a first-contact distance is not the exact one: a hit where there is none, a miss where there
    is one, or t off by more than the shared spec's agreement tolerance (1e-4 relative plus 1e-6 of the
    scene's size, directions of unit length or shorter)."""
    t_hit = np.asarray(t_hit, dtype=np.float64)
    both = np.isfinite(t_hit) & np.isfinite(exact_t)
    off = np.abs(np.where(both, t_hit - exact_t, 0.0)) > 1e-4 * np.where(both, exact_t, 0.0) + 1e-6 * size
    return (np.isfinite(t_hit) != np.isfinite(exact_t)) | off


def wrong_first_triangle(ids, nearest):
    """Where a first-contact triangle is not among the exactly nearest ones (-1 or a miss where none)."""
    return np.array([(int(i) not in near) if near else int(i) >= 0 for i, near in zip(ids, nearest)])


def by_kind(kinds, wrong):
    """'kind wrong/count' for each kind of ray, in the order of SPOTS and directions_for."""
    labels = [f"{kind} {label}" for kind in SPOTS for label in ("off", "along")]
    return "  ".join(f"{label} {int(np.sum(wrong[kinds == label]))}/{int(np.sum(kinds == label))}" for label in labels)


def icosphere(subdivisions=3):
    """A unit icosphere (vertices, faces), rotated off the axes, and its edges."""
    g = (1 + 5**0.5) / 2
    v = [[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g]]
    v += [[g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2]]
    f += [[10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11]]
    f += [[6, 2, 10], [8, 6, 7], [9, 8, 1]]
    vertices = [np.array(p, dtype=float) / np.linalg.norm(p) for p in v]
    faces = f
    for _ in range(subdivisions):
        faces = subdivided(vertices, faces)
    angle = np.radians([17.0, 31.0, 47.0])
    rx = np.array([[1, 0, 0], [0, np.cos(angle[0]), -np.sin(angle[0])], [0, np.sin(angle[0]), np.cos(angle[0])]])
    rz = np.array([[np.cos(angle[2]), -np.sin(angle[2]), 0], [np.sin(angle[2]), np.cos(angle[2]), 0], [0, 0, 1]])
    vertices = (np.array(vertices) @ (rz @ rx).T).astype(np.float32)
    faces = np.array(faces, dtype=np.int64)
    edges = np.unique(np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    return vertices, faces, edges


def subdivided(vertices, faces):
    """Each triangle split in four, the new vertices (appended to ``vertices``) on the unit sphere."""
    middle, next_faces = {}, []

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in middle:
            p = vertices[a] + vertices[b]
            vertices.append(p / np.linalg.norm(p))
            middle[key] = len(vertices) - 1
        return middle[key]

    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        next_faces += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
    return next_faces


def unit_grid_box(n):
    """The unit box, each face an n x n grid of squares split into two triangles (float32)."""
    vertices, faces = [], []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for side in (0.0, 1.0):
            base = len(vertices)
            for i in range(n + 1):
                for j in range(n + 1):
                    p = [0.0, 0.0, 0.0]
                    p[axis], p[u], p[v] = side, i / n, j / n
                    vertices.append(p)
            for i in range(n):
                for j in range(n):
                    a, b = base + i * (n + 1) + j, base + (i + 1) * (n + 1) + j
                    quad = [a, b, b + 1, a + 1] if side == 1.0 else [a, a + 1, b + 1, b]
                    faces += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
    vertices = np.array(vertices, dtype=np.float32)
    unique, inverse = np.unique(vertices, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)[np.array(faces)].astype(np.int64)


def axis_rays(n):
    """Rays along each axis from both sides through the grid box: (rays, interior) where interior
    marks rays through interior grid lines (2 crossings, first contact at t = 1) and the rest run in the
    planes of faces or along the box's edges (a contact at t = 1 all the same)."""
    rays, interior = [], []
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        for sign in (1.0, -1.0):
            for i in range(n + 1):
                for j in range(n + 1):
                    ray = [0.0] * 6
                    ray[axis], ray[3 + axis] = (-1.0 if sign > 0 else 2.0), sign
                    ray[u], ray[v] = i / n, j / n
                    rays.append(ray)
                    interior.append(0 < i < n and 0 < j < n)
    return np.array(rays, dtype=np.float32), np.array(interior)
