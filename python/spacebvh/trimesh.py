# SPDX-License-Identifier: MIT
"""A drop-in ray intersector for trimesh, exact and multi-threaded.

``RayMeshIntersector(mesh)`` answers trimesh's five ray queries (``intersects_id``,
``intersects_location``, ``intersects_first``, ``intersects_any``, ``contains_points``) with the
same arguments, keywords, return tuples and dtypes as trimesh's Embree backend, from spacebvh's exact
queries (docs/queries.md). Each query has one of two documented semantics:

- **contacts** (``intersects_first``, ``intersects_any``, and ``intersects_id`` /
  ``intersects_location`` with ``multiple_hits=False``): triangles are closed, so a ray that only
  touches the mesh at an edge or a vertex, or runs in the plane of a face to its boundary, hits it,
  from every side. Answered by spacebvh's ``Tracer`` (the exact arbiter of docs/rays.md): the nearest
  contact, ties to the lower triangle id;
- **crossings** (``intersects_id`` / ``intersects_location`` with multiple hits, and
  ``contains_points``): a ray through a shared edge or vertex of a connected surface crosses it exactly
  once, decided by a fixed symbolic perturbation of the ray, not by an epsilon or a re-query loop;
  multiple hits are every crossing, sorted by ray and then by distance (at most ``max_hits``), and
  ``contains_points`` is an exact parity count, the same on every run and thread count.

float64 meshes keep their precision at large coordinates (they are traced in a frame centred on
their bounds), and hit locations are computed from the triangle in double precision.

``patch()`` routes trimesh's Embree backend to this intersector, so ``trimesh.Trimesh`` objects made
afterwards (with the default ``use_embree=True``) use it; meshes made with ``use_embree=False`` keep
trimesh's own pure-NumPy intersector. trimesh is an optional dependency: ``pip install spacebvh[trimesh]``.
"""

from __future__ import annotations

import sys
import types
from typing import Any, Optional

import numpy as np

from . import _core

__all__ = ["RayMeshIntersector", "patch", "unpatch"]


def _rows(array: Any, name: str) -> np.ndarray:
    result = np.asarray(array, dtype=np.float64)
    if result.ndim == 1 and result.shape == (3,):
        result = result.reshape(1, 3)
    if result.ndim != 2 or result.shape[1] != 3:
        raise ValueError(f"{name} must be (n, 3), not {result.shape}")
    return result


def _rays(ray_origins: Any, ray_directions: Any) -> tuple[np.ndarray, np.ndarray]:
    origins = _rows(ray_origins, "ray_origins")
    directions = _rows(ray_directions, "ray_directions")
    if origins.shape != directions.shape:
        raise ValueError("Ray origin and direction don't match!")
    return origins, directions


class RayMeshIntersector:
    """Ray queries on a ``trimesh.Trimesh``, answered exactly by spacebvh.

    Parameters
    ----------
    geometry : trimesh.Trimesh
      The mesh. Its tree is built on the first query and rebuilt when the mesh changes.
    scale_to_box : bool
      Accepted for compatibility with trimesh's Embree backend; not needed (float64 meshes are
      traced in a local frame, and the answers are exact at any scale).
    builder : str
      The spacebvh builder of the tree (``spacebvh.builders()``).
    threads : int
      Threads of the batch queries (0 = every core).
    """

    def __init__(
        self, geometry: Any, scale_to_box: bool = True, builder: str = "binned", threads: int = 0, **kwargs: Any
    ):
        self.mesh = geometry
        self._scale_to_box = scale_to_box
        self._builder = builder
        self._threads = threads
        self._key: Optional[Any] = None
        self._cache: dict = {}

    # -- the tree, cached on the mesh's content --------------------------------------------------
    def _mesh_key(self) -> Any:
        try:
            return self.mesh.__hash__()
        except Exception:  # a mesh-like object without trimesh's content hash
            return (id(self.mesh.vertices), id(self.mesh.faces))

    def _current(self) -> dict:
        """The tree of the current mesh and the query objects made over it so far (rebuilt when the
        mesh changes; empty for a mesh without faces)."""
        key = self._mesh_key()
        if self._key != key:
            vertices = np.asarray(self.mesh.vertices, dtype=np.float64)
            faces = np.asarray(self.mesh.faces)
            self._cache = {}
            if len(faces) != 0:
                self._cache["bvh"] = _core.build(_core.mesh(vertices, faces), self._builder)
            self._key = key
        return self._cache

    def _made(self, name: str, make: Any) -> Optional[Any]:
        """The query object ``name`` of the current mesh, made by ``make(bvh, threads=...)`` on first use."""
        cache = self._current()
        if "bvh" in cache and name not in cache:
            cache[name] = make(cache["bvh"], threads=self._threads)
        return cache.get(name)

    @property
    def queries(self) -> Optional[Any]:
        """The ``spacebvh.RayQueries`` of the current mesh (crossings; None for a mesh without faces)."""
        return self._made("queries", _core.RayQueries)

    @property
    def tracer(self) -> Optional[Any]:
        """The ``spacebvh.Tracer`` of the current mesh (contacts; None for a mesh without faces)."""
        return self._made("tracer", _core.Tracer)

    # -- trimesh's interface ---------------------------------------------------------------------
    def intersects_id(
        self,
        ray_origins: Any,
        ray_directions: Any,
        multiple_hits: bool = True,
        max_hits: int = 100,
        return_locations: bool = False,
        **kwargs: Any,
    ):
        """Triangles hit by rays: ``(index_tri, index_ray)``, with ``locations`` third when
        ``return_locations``. With ``multiple_hits`` every crossing (at most ``max_hits`` per ray,
        the nearest), sorted by ray and then by distance; else the nearest contact of each ray
        (closed triangles: touching an edge or vertex counts)."""
        origins, directions = _rays(ray_origins, ray_directions)
        if "bvh" not in self._current() or len(origins) == 0:
            empty = np.zeros(0, dtype=np.int64)
            if return_locations:
                return empty, empty.copy(), np.zeros((0, 3), dtype=np.float64)
            return empty, empty.copy()
        if multiple_hits:
            index_ray, index_tri, _t, _u, _v, locations = self.queries.all(
                origins, directions, max_hits=max(int(max_hits), 0), points=return_locations, details=False
            )
        else:  # the hits only, locations in double from the triangle at the contact's barycentrics
            index_ray, index_tri, locations = self.tracer.hits(origins, directions, points=return_locations)
        if return_locations:
            return index_tri, index_ray, locations
        return index_tri, index_ray

    def intersects_location(self, ray_origins: Any, ray_directions: Any, multiple_hits: bool = True, **kwargs: Any):
        """Where rays hit: ``(locations (m, 3) float64, index_ray (m,) int64, index_tri (m,) int64)``;
        every crossing with ``multiple_hits``, else the nearest contact (as ``intersects_id``)."""
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins=ray_origins,
            ray_directions=ray_directions,
            multiple_hits=multiple_hits,
            return_locations=True,
            **kwargs,
        )
        return locations, index_ray, index_tri

    def intersects_first(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """The triangle of each ray's nearest contact (closed triangles; ties to the lower id):
        ``(n,)`` int64, -1 on a miss."""
        origins, directions = _rays(ray_origins, ray_directions)
        tracer = self.tracer
        if tracer is None or len(origins) == 0:
            return np.full(len(origins), -1, dtype=np.int64)
        return tracer.intersect(origins, directions)[1]

    def intersects_any(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """Whether each ray touches the mesh (closed triangles: an edge or a vertex counts): ``(n,)`` bool."""
        origins, directions = _rays(ray_origins, ray_directions)
        tracer = self.tracer
        if tracer is None or len(origins) == 0:
            return np.zeros(len(origins), dtype=bool)
        return tracer.occluded(origins, directions)

    def contains_points(self, points: Any) -> np.ndarray:
        """Whether each point is inside the mesh: ``(n,)`` bool, by an exact parity count along a fixed
        direction (the same answer every run). Points outside the mesh's bounding box are outside, as
        in trimesh. Meaningful for watertight meshes; see docs/queries.md for points on the surface."""
        points = _rows(points, "points")
        result = np.zeros(len(points), dtype=bool)
        queries = self.queries
        if queries is None or len(points) == 0:
            return result
        lo, hi = np.asarray(self.mesh.bounds, dtype=np.float64)
        # Column by column: NumPy reduces one strided column several times faster than axis 0 of an
        # (n, 3) array. The extremes settle the common case (every point in the box) without a mask.
        columns = [points[:, axis] for axis in range(3)]
        if all(column.min() >= lo[axis] and column.max() <= hi[axis] for axis, column in enumerate(columns)):
            return queries.contains(points)
        inside_box = np.ones(len(points), dtype=bool)
        for axis, column in enumerate(columns):
            inside_box &= (column >= lo[axis]) & (column <= hi[axis])
        if inside_box.any():
            result[inside_box] = queries.contains(points[inside_box])
        return result

    # -- copies and pickling, as trimesh's intersectors ------------------------------------------
    def __getstate__(self):
        state = self.__dict__.copy()
        state["_key"] = None
        state["_cache"] = {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)

    def __copy__(self, *args):
        return RayMeshIntersector(
            self.mesh, scale_to_box=self._scale_to_box, builder=self._builder, threads=self._threads
        )

    def __deepcopy__(self, *args):
        return self.__copy__()


_saved: Optional[tuple[Any, Any, Any]] = None


def patch() -> None:
    """Route trimesh's Embree backend to spacebvh: ``trimesh.Trimesh`` objects made afterwards with
    ``use_embree=True`` (the default) get a spacebvh ``RayMeshIntersector`` as ``mesh.ray``, and
    ``trimesh.ray.ray_pyembree.RayMeshIntersector`` is ours. Works with or without embreex installed.
    ``unpatch()`` undoes it."""
    global _saved
    import trimesh.ray as ray_module

    if _saved is None:
        _saved = (
            ray_module.has_embree,
            getattr(ray_module, "ray_pyembree", None),
            sys.modules.get("trimesh.ray.ray_pyembree"),
        )
    shim = types.ModuleType(
        "trimesh.ray.ray_pyembree", "spacebvh's exact intersector in place of trimesh's Embree backend"
    )
    shim.RayMeshIntersector = RayMeshIntersector  # type: ignore[attr-defined]
    ray_module.ray_pyembree = shim
    ray_module.has_embree = True
    sys.modules["trimesh.ray.ray_pyembree"] = shim


def unpatch() -> None:
    """Undo ``patch()``."""
    global _saved
    if _saved is None:
        return
    import trimesh.ray as ray_module

    has_embree, module, in_sys = _saved
    ray_module.has_embree = has_embree
    if module is not None:
        ray_module.ray_pyembree = module
    if in_sys is not None:
        sys.modules["trimesh.ray.ray_pyembree"] = in_sys
    else:
        sys.modules.pop("trimesh.ray.ray_pyembree", None)
    _saved = None
