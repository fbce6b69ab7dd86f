# SPDX-License-Identifier: MIT
"""spacebvh: BVHs built by space subdivision (Popov et al. 2009) and exact ray traversal.

Scenes come from files (``load_scene``) or NumPy meshes (``mesh``); ``build`` makes a tree with a
named builder or a ``Quality`` and the build settings as keywords (``build_settings()``); a
``Tracer`` answers batches of NumPy rays with the exact arbiter's closest or any hits, releasing the
GIL and using every core (``threads=`` limits that). float64 meshes keep their
precision at large coordinates: they are traced in a frame centred on their bounds and answer in the
caller's frame as float64. Errors in input or options raise ``spacebvh.Error`` (a RuntimeError and
a ValueError) naming the argument and the element; wrong dtypes raise TypeError.

Example::

    import numpy as np, spacebvh
    scene = spacebvh.mesh(vertices, faces)             # (n, 3) floats, (m, 3) integers
    tracer = spacebvh.Tracer(spacebvh.build(scene, "spatial"))
    t, primitive, u, v = tracer.intersect(origins, directions)
    points = scene.hit_points(primitive, u, v)
"""

from . import _core
from ._core import (
    Bvh,
    DistanceQueries,
    Error,
    GeometryMap,
    Quality,
    RayQueries,
    RenderScene,
    Scene,
    Tracer,
    Tracer64,
    build,
    build_settings,
    builders,
    builtin_scenes,
    containment_direction,
    diffuse_rays,
    kernels,
    load_bvh,
    load_scene,
    mesh,
    primary_rays,
    random_rays,
    read_hits,
    read_rays,
    write_hits,
    write_png,
    write_rays,
)
from .cli import executable as cli_executable

# Embree 3's own tracer, the yardstick: in builds with Embree (the source install), not in the
# self-contained wheel. `spacebvh.has_embree` says which.
has_embree: bool = hasattr(_core, "EmbreeTracer")
if has_embree:
    EmbreeTracer = _core.EmbreeTracer

__version__: str = _core.__version__

__all__ = [
    "has_embree",
    "Bvh",
    "Error",
    "GeometryMap",
    "Quality",
    "DistanceQueries",
    "RayQueries",
    "RenderScene",
    "Scene",
    "Tracer",
    "Tracer64",
    "__version__",
    "build",
    "build_settings",
    "builders",
    "builtin_scenes",
    "cli_executable",
    "containment_direction",
    "diffuse_rays",
    "kernels",
    "load_bvh",
    "load_scene",
    "mesh",
    "primary_rays",
    "random_rays",
    "read_hits",
    "read_rays",
    "write_hits",
    "write_png",
    "write_rays",
]
if has_embree:
    __all__.append("EmbreeTracer")
