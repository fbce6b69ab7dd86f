# SPDX-License-Identifier: MIT
"""Ray and point queries over Dask arrays, on a Dask cluster.

``DaskQueries(scene, tree_file)`` answers batches held as Dask arrays: every chunk of rows becomes one
batch call on a worker (which releases the GIL and runs on the worker's cores), and the answers come
back as Dask arrays chunked like the input, computed when asked for (``.compute()``). Every worker
process loads the scene and the tree file once, at its first chunk, and keeps them for later chunks
and later calls. The answers are exactly those of one process: the queries are exact and do not
depend on how the rows are split.

    import dask.array as da, spacebvh, spacebvh.dask
    scene = spacebvh.load_scene("bunny.obj")
    spacebvh.build(scene, "spatial").save("bunny.sbvh")
    with spacebvh.dask.DaskQueries(scene, "bunny.sbvh") as queries:       # a LocalCluster
        origins = da.from_array(o, chunks=(250_000, 3))
        directions = da.from_array(d, chunks=(250_000, 3))
        t, primitive = queries.intersect(origins, directions)              # Dask arrays
        inside = queries.contains(points).compute()                        # a NumPy array

``scene`` is a ``spacebvh.Scene`` (sent to each worker once) or a scene file name or ``builtin:NAME``
that every worker can read; ``tree_file`` (``Bvh.save``) must be readable by every worker at the same
path. ``address`` names a running scheduler (``dask scheduler`` and ``dask worker ADDRESS`` on many
machines); ``client`` uses an existing ``distributed.Client``; with neither, a ``LocalCluster`` of
``n_workers`` processes is started and closed with the object. Needs ``pip install "spacebvh[reproduce]"``
(dask[distributed]).
"""

from __future__ import annotations

import os
from typing import Any, Optional, Union

import numpy as np

from . import _core

__all__ = ["DaskQueries"]

# Per worker process: the scene, tree and query objects of each (scene, tree file) it has served.
_loaded: dict[tuple, dict] = {}
_load_count = 0  # tree files loaded by this process (read by the tests)


def _served(scene: Any, tree_file: str, signature: tuple, threads: int) -> dict:
    """This process's objects for the scene and tree file, loaded at the first call."""
    global _load_count
    key = (signature, threads)
    if key not in _loaded:
        scene = _core.load_scene(scene) if isinstance(scene, str) else scene
        _loaded[key] = {"bvh": _core.load_bvh(tree_file, scene), "threads": threads}
        _load_count += 1
    return _loaded[key]


def _made(served: dict, kind: str) -> Any:
    if kind not in served:
        make = {"tracer": _core.Tracer, "crossings": _core.RayQueries}.get(kind) or _core.DistanceQueries
        served[kind] = make(served["bvh"], threads=served["threads"])
    return served[kind]


def _ray_block(origins, directions, scene, tree_file, signature, threads, query):
    served = _served(scene, tree_file, signature, threads)
    if query in ("intersect", "occluded"):
        tracer = _made(served, "tracer")
        if query == "occluded":
            return tracer.occluded(origins, directions)
        t, primitive, u, v = tracer.intersect(origins, directions)
        out = np.empty(len(t), dtype=[("t", t.dtype), ("primitive", np.int64), ("u", np.float32), ("v", np.float32)])
        out["t"], out["primitive"], out["u"], out["v"] = t, primitive, u, v
        return out
    queries = _made(served, "crossings")
    if query == "first":
        return queries.first_primitive(origins, directions)
    return queries.count(origins, directions)


def _point_block(points, scene, tree_file, signature, threads, query):
    served = _served(scene, tree_file, signature, threads)
    if query == "contains":
        return _made(served, "crossings").contains(points)
    distance = _made(served, "distance")
    if query == "signed_distance":
        return distance.signed_distance(points)
    return distance.distance(points)


class DaskQueries:
    """Queries over ``tree_file`` (built over ``scene``) on a Dask cluster (module docstring).

    ``threads``: threads per worker process of each batch call (0 = every core of its machine)."""

    def __init__(
        self,
        scene: Union[str, Any],
        tree_file: Union[str, os.PathLike],
        *,
        client: Optional[Any] = None,
        address: Optional[str] = None,
        n_workers: int = 2,
        threads: int = 0,
    ):
        import dask
        from distributed import Client, LocalCluster

        tree_file = os.path.abspath(os.fspath(tree_file))
        if not os.path.isfile(tree_file):
            raise FileNotFoundError(f"tree_file: no file {tree_file}")
        if int(threads) < 0:
            raise ValueError(f"threads must be >= 0 (0 = every core), not {threads}")
        if isinstance(scene, str) and not scene.startswith("builtin:"):
            scene = os.path.abspath(scene)
        # The scene travels once per worker, as one graph key every chunk depends on.
        self._scene = scene if isinstance(scene, str) else dask.delayed(scene, pure=True)
        stat = os.stat(tree_file)
        scene_token = scene if isinstance(scene, str) else dask.base.tokenize(scene.triangles())
        self._signature = (scene_token, tree_file, stat.st_size, stat.st_mtime_ns)
        self._tree_file, self._threads = tree_file, int(threads)
        # t comes back in the scene's dtype: float64 only for float64 meshes (files load as float32).
        self._t_dtype = np.float32 if isinstance(scene, str) else scene.dtype
        self._cluster = None
        if client is not None:
            self.client = client
        elif address is not None:
            self.client = Client(address)
        else:
            self._cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True)
            self.client = Client(self._cluster)
        self._owns_client = client is None

    def close(self) -> None:
        """Closes the client and the LocalCluster this object started (not a client it was given)."""
        if self._owns_client:
            self.client.close()
        if self._cluster is not None:
            self._cluster.close()

    def __enter__(self) -> DaskQueries:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    # -- rays --------------------------------------------------------------------------------------
    def _rays(self, origins: Any, directions: Any, query: str, dtype: Any) -> Any:
        import dask.array as da

        origins, directions = da.asarray(origins), da.asarray(directions)
        for name, array in (("origins", origins), ("directions", directions)):
            if array.ndim != 2 or array.shape[1] != 3:
                raise ValueError(f"{name} must be a (n, 3) array, not {array.shape}")
        if origins.shape[0] != directions.shape[0]:
            raise ValueError(f"origins and directions differ in length ({origins.shape[0]}, {directions.shape[0]})")
        origins = origins.rechunk({1: 3})
        directions = directions.rechunk({0: origins.chunks[0], 1: 3})
        args = (self._scene, self._tree_file, self._signature, self._threads, query)
        return da.map_blocks(_ray_block, origins, directions, *args, drop_axis=1, dtype=dtype)

    def intersect(self, origins: Any, directions: Any) -> tuple[Any, Any, Any, Any]:
        """Closest hits (contacts, as ``Tracer.intersect``): Dask arrays ``t, primitive, u, v``."""
        fields = np.dtype([("t", self._t_dtype), ("primitive", np.int64), ("u", np.float32), ("v", np.float32)])
        hits = self._rays(origins, directions, "intersect", fields)
        return hits["t"], hits["primitive"], hits["u"], hits["v"]

    def occluded(self, origins: Any, directions: Any) -> Any:
        """Whether each ray hits anything (``Tracer.occluded``): a bool Dask array."""
        return self._rays(origins, directions, "occluded", bool)

    def first_primitive(self, origins: Any, directions: Any) -> Any:
        """The triangle of each first crossing (``RayQueries.first_primitive``): an int64 Dask array."""
        return self._rays(origins, directions, "first", np.int64)

    def count(self, origins: Any, directions: Any) -> Any:
        """The number of crossings of each ray (``RayQueries.count``): an int64 Dask array."""
        return self._rays(origins, directions, "count", np.int64)

    # -- points ------------------------------------------------------------------------------------
    def _points(self, points: Any, query: str, dtype: Any) -> Any:
        import dask.array as da

        points = da.asarray(points)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"points must be a (n, 3) array, not {points.shape}")
        args = (self._scene, self._tree_file, self._signature, self._threads, query)
        return da.map_blocks(_point_block, points.rechunk({1: 3}), *args, drop_axis=1, dtype=dtype)

    def contains(self, points: Any) -> Any:
        """Whether each point is inside (``RayQueries.contains``, exact parity): a bool Dask array."""
        return self._points(points, "contains", bool)

    def distance(self, points: Any) -> Any:
        """The distance of each point to the mesh (``DistanceQueries.distance``): a float64 Dask array."""
        return self._points(points, "distance", np.float64)

    def signed_distance(self, points: Any) -> Any:
        """The signed distance, negative inside (``DistanceQueries.signed_distance``): float64."""
        return self._points(points, "signed_distance", np.float64)
