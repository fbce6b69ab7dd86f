# SPDX-License-Identifier: MIT
"""The shared scene collection for the Python benchmark scripts: where it is, and its OBJ files read
into NumPy arrays."""

import os
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = Path(os.environ.get("SPACEBVH_SCENES") or ROOT.parent / "shared" / "scenes")


def read_obj(path, dtype=np.float64):
    """Vertices and triangles of a plain OBJ (`v` records; `f` with the first index of each corner), as
    the scene collection's MANIFEST.md describes them; trimesh's loader needs Pillow for their materials."""
    vertices, faces = [], []
    with open(path) as lines:
        for line in lines:
            if line.startswith("v "):
                vertices.append(line.split()[1:4])
            elif line.startswith("f "):
                faces.append([int(corner.split("/")[0]) for corner in line.split()[1:4]])
    faces = np.array(faces, dtype=np.int64)
    return np.array(vertices, dtype=dtype), np.where(faces > 0, faces - 1, faces + len(vertices))


# A generated mesh of 1-2M triangles, which the shared collection lacks (its largest, living_room_3,
# has 786,208): the built-in organic mesh (a closed, displaced cube-sphere) split twice into four.
LARGE = "organic-x16"


def indexed(triangles):
    """Vertices and faces of a triangle soup (n, 3, 3), equal corners made one vertex."""
    vertices, inverse = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    return vertices, inverse.reshape(-1, 3).astype(np.int64)


def subdivided(vertices, faces, levels):
    """The mesh with each triangle split `levels` times into four at its edges' midpoints: the same
    surface, 4^levels times the triangles; a closed mesh stays closed (neighbours share each midpoint)."""
    vertices = np.asarray(vertices, dtype=np.float64)
    for _ in range(levels):
        corners = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)  # edges ab, bc, ca of each triangle
        edges, inverse = np.unique(np.sort(corners, axis=1), axis=0, return_inverse=True)
        ab, bc, ca = (len(vertices) + inverse.reshape(-1, 3)).T
        a, b, c = faces.T
        faces = np.stack([np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))], axis=1)
        faces = faces.reshape(-1, 3)
        vertices = np.vstack([vertices, (vertices[edges[:, 0]] + vertices[edges[:, 1]]) / 2])
    return vertices, faces


def large_mesh(dtype=np.float64):
    """LARGE's vertices and faces: the same for every run (the built-in scene is generated, not read)."""
    import spacebvh

    vertices, faces = indexed(np.asarray(spacebvh.load_scene("builtin:organic").triangles(), dtype=np.float64))
    vertices, faces = subdivided(vertices, faces, 2)
    return vertices.astype(dtype), faces


def each_scene(names, dtype=np.float64):
    """(name, vertices, faces) of each named scene of the collection (or LARGE, generated), in turn; a
    scene that is not there is skipped with a line that says so, so that a run on a partial collection
    measures what it has."""
    for name in names:
        if name == LARGE:
            yield (name, *large_mesh(dtype))
            continue
        path = SCENES / name / f"{name}.obj"
        if not path.exists():
            print(f"skipping {name}: no {path}")
            continue
        yield (name, *read_obj(path, dtype))
