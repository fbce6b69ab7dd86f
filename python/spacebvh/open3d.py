# SPDX-License-Identifier: MIT
"""Open3D's ``RaycastingScene`` as a drop-in, answered exactly by spacebvh.

``spacebvh.open3d.RaycastingScene`` has the methods, arguments, dictionary keys, dtypes and output
shapes of ``open3d.t.geometry.RaycastingScene`` (Open3D 0.20): ``add_triangles`` (vertex and index
arrays, or an ``open3d.t.geometry.TriangleMesh``) returning geometry ids, ``cast_rays``,
``test_occlusions``, ``count_intersections``, ``list_intersections``, ``compute_closest_points``,
``compute_distance``, ``compute_signed_distance``, ``compute_occupancy``, the static
``create_rays_pinhole`` (both forms) and ``INVALID_ID``. Rays are ``(..., 6)`` (origin, direction)
and points ``(..., 3)`` of any leading shape, float32 or float64. When open3d is installed the results
are Open3D tensors, else NumPy arrays; either is accepted as input.

Semantics (docs/queries.md):

- ``cast_rays`` and ``test_occlusions`` are **contacts**: triangles are closed, so a ray that touches
  an edge or a vertex hits (spacebvh's ``Tracer``, the exact arbiter of docs/rays.md);
- ``count_intersections`` and ``list_intersections`` are **crossings**: each crossing of a surface
  once, also where the ray passes exactly through an edge or a vertex (``RayQueries``);
- ``compute_occupancy`` and the sign of ``compute_signed_distance`` are the exact parity of those
  crossings along a fixed direction (``RayQueries.contains``): no jitter, no vote. ``nsamples`` is
  accepted (a positive odd number, as Open3D asks) and changes nothing;
- ``compute_closest_points`` and ``compute_distance`` come from ``spacebvh.DistanceQueries``.

The geometries added are traced as one mesh (ids mapped back per triangle); the tree is built at the
first query after an ``add_triangles``, as Open3D commits its scene.
"""

from __future__ import annotations

import math
from typing import Any, Optional

import numpy as np

from . import _core

__all__ = ["RaycastingScene", "INVALID_ID"]

INVALID_ID = 0xFFFFFFFF
# The scene's tree: binned SAH, then a few batches of reinsertion (docs/queries.md, "The Open3D
# drop-in"). Reinsertion repairs the top levels that binning places badly on meshes of uneven
# density (rooms, architecture), where it cuts the boxes an incoherent ray tests by about a quarter,
# at 1.35x to 2x the binned build time; the first batches take nearly all of its gain.
_BUILDER = "binned"
_OPTIMIZE = 4
_UNSET = object()
_open3d: Any = _UNSET


def _open3d_module() -> Optional[Any]:
    """open3d when it can be imported (then results are its tensors), else None."""
    global _open3d
    if _open3d is _UNSET:
        try:
            import open3d
        except ImportError:
            _open3d = None
        else:
            _open3d = open3d
    return _open3d


def _array(value: Any, name: str, dtype: Optional[Any] = None) -> np.ndarray:
    """A NumPy array of an Open3D tensor (on any device) or anything NumPy reads."""
    if hasattr(value, "numpy") and hasattr(value, "cpu") and not isinstance(value, np.ndarray):
        value = value.cpu().numpy()
    result = np.asarray(value)
    if result.dtype == object:
        raise TypeError(f"{name} must be an array or an Open3D tensor, not {type(value).__name__}")
    return result if dtype is None else result.astype(dtype, copy=False)


def _out(array: np.ndarray) -> Any:
    """An Open3D tensor when open3d is installed, else the array."""
    o3d = _open3d_module()
    if o3d is None:
        return array
    return o3d.core.Tensor.from_numpy(np.ascontiguousarray(array))


def _last_dim(value: Any, width: int, name: str) -> tuple[np.ndarray, tuple[int, ...]]:
    """Rows (k, width) of a float32/float64 array (..., width), and its leading shape."""
    array = _array(value, name)
    if array.dtype not in (np.float32, np.float64):
        raise TypeError(f"{name} must be float32 or float64, not {array.dtype}")
    if array.ndim < 1 or array.shape[-1] != width:
        raise ValueError(f"{name} must have shape (..., {width}), not {array.shape}")
    return array.reshape(-1, width), array.shape[:-1]


def _threads(nthreads: int) -> int:
    if int(nthreads) < 0:
        raise ValueError(f"nthreads must be >= 0 (0 = every core), not {nthreads}")
    return int(nthreads)


def _check_nsamples(nsamples: int) -> None:
    if int(nsamples) < 1 or int(nsamples) % 2 == 0:
        raise ValueError(f"nsamples must be a positive odd number, not {nsamples} (answers are exact with 1)")


class RaycastingScene:
    """Open3D's ``RaycastingScene`` over spacebvh's exact queries (module docstring)."""

    INVALID_ID = INVALID_ID

    def __init__(self, nthreads: int = 0, device: Any = None):
        if device is not None and not str(device).upper().startswith("CPU"):
            raise ValueError(f"device must be a CPU device, not {device}")
        self._build_threads = _threads(nthreads)
        self._geometries: list[tuple[np.ndarray, np.ndarray]] = []
        self._cache: Optional[dict] = None

    # -- geometries ------------------------------------------------------------------------------
    def add_triangles(self, vertex_positions: Any, triangle_indices: Any = None) -> int:
        """Adds a mesh: ``vertex_positions`` (n, 3) float32/float64 and ``triangle_indices`` (m, 3)
        integers, or an ``open3d.t.geometry.TriangleMesh`` alone. Returns its geometry id (0, 1, ...)."""
        if triangle_indices is None:
            mesh = vertex_positions
            if not (hasattr(mesh, "vertex") and hasattr(mesh, "triangle")):
                raise TypeError("add_triangles takes (vertex_positions, triangle_indices) or a TriangleMesh")
            vertex_positions, triangle_indices = mesh.vertex.positions, mesh.triangle.indices
        geometry = len(self._geometries)
        vertices = _array(vertex_positions, f"vertex_positions of geometry {geometry}")
        faces = _array(triangle_indices, f"triangle_indices of geometry {geometry}")
        if vertices.dtype not in (np.float32, np.float64) or vertices.ndim != 2 or vertices.shape[1] != 3:
            raise ValueError(f"vertex_positions of geometry {geometry} must be (n, 3) float32 or float64")
        if faces.dtype.kind not in "iu" or faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"triangle_indices of geometry {geometry} must be (m, 3) integers, not {faces.dtype}")
        bad = np.flatnonzero(~np.isfinite(vertices).all(axis=1))
        if len(bad):
            raise ValueError(f"vertex {bad[0]} of geometry {geometry} is not finite: {vertices[bad[0]]}")
        faces = faces.astype(np.int64)
        bad = np.flatnonzero(((faces < 0) | (faces >= len(vertices))).any(axis=1))
        if len(bad):
            raise ValueError(
                f"triangle {bad[0]} of geometry {geometry} has a vertex index out of range "
                f"(0..{len(vertices) - 1}): {faces[bad[0]]}"
            )
        self._geometries.append((vertices.copy(), faces))
        self._cache = None
        return geometry

    def _scene(self) -> dict:
        """The combined mesh's tree, its id map and triangle normals (made at the first query after a
        change), and the query objects made over it so far."""
        if self._cache is not None:
            return self._cache
        cache: dict = {}
        counts = [len(faces) for _, faces in self._geometries]
        total = sum(counts)
        if total:
            dtype = np.float64 if any(v.dtype == np.float64 for v, _ in self._geometries) else np.float32
            vertices = np.concatenate([v.astype(dtype) for v, _ in self._geometries])
            starts = np.cumsum([0] + [len(v) for v, _ in self._geometries])[:-1]
            faces = np.concatenate([f + s for (_, f), s in zip(self._geometries, starts)])
            cache["bvh"] = _core.build(
                _core.mesh(vertices, faces), _BUILDER, threads=self._build_threads, optimize=_OPTIMIZE
            )
            corners = vertices.astype(np.float64)[faces]
            normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            length = np.linalg.norm(normals, axis=1, keepdims=True)
            unit = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
            # Per combined triangle its geometry and primitive ids and unit normal: the ray queries
            # write Open3D's arrays through it in C++, the point queries through _ids and _normals.
            cache["map"] = _core.GeometryMap(counts, unit.astype(np.float32))
            # The same with one more row for "no triangle" (index -1): INVALID_ID and a zero normal,
            # so that one gather maps hits and misses alike.
            invalid = np.array([INVALID_ID], dtype=np.uint32)
            cache["geometry"] = np.concatenate([np.repeat(np.arange(len(counts), dtype=np.uint32), counts), invalid])
            cache["primitive"] = np.concatenate([np.arange(c, dtype=np.uint32) for c in counts] + [invalid])
            cache["normals"] = np.vstack([unit, np.zeros((1, 3))]).astype(np.float32)
        self._cache = cache
        return cache

    def _query(self, kind: str) -> Optional[Any]:
        """The tracer (contacts), ray queries (crossings) or distance queries of the scene, made at
        first use; None when it has no triangles."""
        cache = self._scene()
        if "bvh" not in cache:
            return None
        if kind not in cache:
            make = {"tracer": _core.Tracer, "crossings": _core.RayQueries, "distance": _core.DistanceQueries}[kind]
            cache[kind] = make(cache["bvh"])
        return cache[kind]

    def _ids(self, triangle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Geometry and primitive ids (uint32) of combined triangle numbers (-1: INVALID_ID)."""
        cache = self._scene()
        if "geometry" not in cache:
            invalid = np.full(triangle.shape, INVALID_ID, dtype=np.uint32)
            return invalid, invalid.copy()
        return cache["geometry"][triangle], cache["primitive"][triangle]

    def _normals(self, triangle: np.ndarray) -> np.ndarray:
        """Unit normals (float32) of combined triangle numbers (-1: zero)."""
        cache = self._scene()
        if "normals" not in cache:
            return np.zeros(triangle.shape + (3,), dtype=np.float32)
        return cache["normals"][triangle]

    # -- rays ------------------------------------------------------------------------------------
    # The ray queries and compute_occupancy hand Open3D's rows to spacebvh.GeometryMap, which reads
    # them in place and writes every output array in one pass without the GIL.
    def cast_rays(self, rays: Any, nthreads: int = 0) -> dict:
        """The nearest contact of each ray (closed triangles): ``t_hit`` (inf on a miss),
        ``geometry_ids``, ``primitive_ids`` (INVALID_ID on a miss), ``primitive_uvs``, ``primitive_normals``."""
        rows, shape = _last_dim(rays, 6, "rays")
        threads = _threads(nthreads)
        tracer = self._query("tracer")
        if tracer is None or not len(rows):
            count = len(rows)
            invalid = np.full(count, INVALID_ID, dtype=np.uint32)
            answer = {
                "t_hit": np.full(count, np.inf, dtype=np.float32),
                "geometry_ids": invalid,
                "primitive_ids": invalid.copy(),
                "primitive_uvs": np.zeros((count, 2), dtype=np.float32),
                "primitive_normals": np.zeros((count, 3), dtype=np.float32),
            }
        else:
            answer = self._scene()["map"].cast_rays(tracer, rows, threads=threads)
        return {key: _out(value.reshape(shape + value.shape[1:])) for key, value in answer.items()}

    def test_occlusions(self, rays: Any, tnear: float = 0.0, tfar: float = math.inf, nthreads: int = 0) -> Any:
        """Whether each ray touches the scene for t in [tnear, tfar] (closed triangles): bool (...)."""
        rows, shape = _last_dim(rays, 6, "rays")
        threads = _threads(nthreads)
        tracer = self._query("tracer")
        if tracer is None or not len(rows):
            return _out(np.zeros(shape, dtype=bool))
        answers = self._scene()["map"].test_occlusions(tracer, rows, float(tnear), float(tfar), threads=threads)
        return _out(answers.reshape(shape))

    def count_intersections(self, rays: Any, nthreads: int = 0) -> Any:
        """The number of crossings of each ray (t >= 0): int32 (...)."""
        rows, shape = _last_dim(rays, 6, "rays")
        threads = _threads(nthreads)
        queries = self._query("crossings")
        if queries is None or not len(rows):
            return _out(np.zeros(shape, dtype=np.int32))
        return _out(self._scene()["map"].count_intersections(queries, rows, threads=threads).reshape(shape))

    def list_intersections(self, rays: Any, nthreads: int = 0) -> dict:
        """Every crossing (t >= 0), by ray and then by t: ``ray_splits`` (rays + 1: where each ray's
        crossings start), ``ray_ids``, ``geometry_ids``, ``primitive_ids``, ``primitive_uvs``, ``t_hit``."""
        rows, _shape = _last_dim(rays, 6, "rays")
        threads = _threads(nthreads)
        queries = self._query("crossings")
        if queries is None or not len(rows):
            none = np.zeros(0, dtype=np.uint32)
            answer = {
                "ray_splits": np.zeros(len(rows) + 1, dtype=np.uint32),
                "ray_ids": none,
                "geometry_ids": none,
                "primitive_ids": none,
                "primitive_uvs": np.zeros((0, 2), dtype=np.float32),
                "t_hit": np.zeros(0, dtype=np.float32),
            }
        else:
            answer = self._scene()["map"].list_intersections(queries, rows, threads=threads)
        return {key: _out(value) for key, value in answer.items()}

    # -- points ----------------------------------------------------------------------------------
    def _points(self, query_points: Any, kind: str) -> tuple[np.ndarray, tuple[int, ...], Any]:
        rows, shape = _last_dim(query_points, 3, "query_points")
        # One sum settles the common case (a NaN or inf makes it NaN or inf; float32 values cannot
        # overflow a float64 sum); the row is looked for only when it is not finite.
        if not np.isfinite(rows.sum(dtype=np.float64)):
            bad = np.flatnonzero(~np.isfinite(rows).all(axis=1))
            if len(bad):
                raise ValueError(f"query_points: point {bad[0]} is not finite: {rows[bad[0]]}")
        queries = self._query(kind)
        if queries is None:
            raise ValueError(f"the scene has no triangles: add_triangles() first ({len(self._geometries)} added)")
        return rows, shape, queries

    def compute_closest_points(self, query_points: Any, nthreads: int = 0) -> dict:
        """The nearest point of the scene to each point: ``points``, ``geometry_ids``, ``primitive_ids``,
        ``primitive_uvs`` (barycentrics of the 2nd and 3rd corners), ``primitive_normals``."""
        rows, shape, queries = self._points(query_points, "distance")
        answer = queries.closest_points(rows, threads=_threads(nthreads))
        triangle = answer["triangle_ids"].astype(np.int64)
        triangle[answer["triangle_ids"] == INVALID_ID] = -1
        geometry, primitive = self._ids(triangle)
        return {
            "points": _out(answer["points"].astype(np.float32).reshape(shape + (3,))),
            "geometry_ids": _out(geometry.reshape(shape)),
            "primitive_ids": _out(primitive.reshape(shape)),
            "primitive_uvs": _out(answer["barycentrics"].astype(np.float32).reshape(shape + (2,))),
            "primitive_normals": _out(self._normals(triangle).reshape(shape + (3,))),
        }

    def compute_distance(self, query_points: Any, nthreads: int = 0) -> Any:
        """The distance of each point to the scene: float32 (...)."""
        rows, shape, queries = self._points(query_points, "distance")
        return _out(queries.distance(rows, threads=_threads(nthreads)).astype(np.float32).reshape(shape))

    def compute_signed_distance(self, query_points: Any, nthreads: int = 0, nsamples: int = 1) -> Any:
        """The distance of each point to the scene, negative inside (the exact parity of crossings):
        float32 (...). ``nsamples`` is accepted and changes nothing."""
        _check_nsamples(nsamples)
        rows, shape, queries = self._points(query_points, "distance")
        return _out(
            queries.signed_distance(rows, sign="parity", threads=_threads(nthreads)).astype(np.float32).reshape(shape)
        )

    def compute_occupancy(self, query_points: Any, nthreads: int = 0, nsamples: int = 1) -> Any:
        """1.0 where a point is inside (the exact parity of crossings), else 0.0: float32 (...).
        ``nsamples`` is accepted and changes nothing."""
        _check_nsamples(nsamples)
        rows, shape, queries = self._points(query_points, "crossings")
        return _out(self._scene()["map"].compute_occupancy(queries, rows, threads=_threads(nthreads)).reshape(shape))

    # -- cameras ---------------------------------------------------------------------------------
    @staticmethod
    def create_rays_pinhole(*args: Any, **kwargs: Any) -> Any:
        """Rays (height_px, width_px, 6) float32 through pixel centres: ``(intrinsic_matrix,
        extrinsic_matrix, width_px, height_px)`` or ``(fov_deg, center, eye, up, width_px, height_px)``
        (horizontal field of view), as Open3D's."""
        from ._pinhole import rays_pinhole

        return _out(rays_pinhole(*args, **kwargs))
