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


def each_scene(names, dtype=np.float64):
    """(name, vertices, faces) of each named scene of the collection, in turn; a scene that is not there
    is skipped with a line that says so, so that a run on a partial collection measures what it has."""
    for name in names:
        path = SCENES / name / f"{name}.obj"
        if not path.exists():
            print(f"skipping {name}: no {path}")
            continue
        yield (name, *read_obj(path, dtype))
