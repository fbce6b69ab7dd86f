# SPDX-License-Identifier: MIT
"""Type stubs of the extension module spacebvh._core (python/src/)."""

from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

# An (n, 3) array of real numbers (float32 or float64 read in place; other real dtypes converted).
_Rows = npt.ArrayLike
# One number per ray: a number shared by every ray, or an array of one per ray.
_PerRay = Union[float, npt.ArrayLike]
_Bounds = Tuple[Tuple[float, float, float], Tuple[float, float, float]]
_Hits = Tuple[npt.NDArray[np.floating[Any]], npt.NDArray[np.int64], npt.NDArray[np.float32], npt.NDArray[np.float32]]
_Rays = Tuple[npt.NDArray[np.floating[Any]], npt.NDArray[np.floating[Any]]]

class Error(RuntimeError, ValueError):
    """A library error: bad input (named with where it is), an unreadable file, or an option out of range."""

class Scene:
    """Triangles in file (or index) order; degenerate ones are kept and never hit."""

    @property
    def name(self) -> str: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def degenerate_count(self) -> int: ...
    @property
    def bounds(self) -> _Bounds: ...
    @property
    def origin(self) -> Tuple[float, float, float]: ...
    @property
    def dtype(self) -> np.dtype[Any]: ...
    def triangles(self) -> npt.NDArray[np.floating[Any]]:
        """The triangles as traced, (m, 3, 3) in the caller's frame and the scene's dtype."""
    def hit_points(self, primitive: npt.ArrayLike, u: npt.ArrayLike, v: npt.ArrayLike) -> npt.NDArray[np.floating[Any]]:
        """Points at barycentrics (u, v) of the triangles `primitive`, (k, 3); NaN rows for misses."""

# A build setting's value (build_settings()): a flag, a whole number or bytes, a number, search space names.
_SettingValue = Union[bool, int, float, str]

class Quality:
    """What most users pick: fast, balanced or high."""

    fast: Quality
    balanced: Quality
    high: Quality
    def __init__(self, value: int) -> None: ...
    def __int__(self) -> int: ...
    def __index__(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class Bvh:
    """A binary BVH and the scene it was built over."""

    @property
    def scene(self) -> Scene: ...
    @property
    def builder(self) -> str: ...
    @property
    def settings(self) -> Optional[dict[str, _SettingValue]]: ...
    @property
    def cost_model(self) -> str: ...
    @property
    def node_count(self) -> int: ...
    @property
    def reference_count(self) -> int: ...
    @property
    def sah(self) -> float: ...
    def stats(self, epo: bool = False) -> dict[str, Union[int, float]]:
        """Structure, memory and tree SAH (and EPO with epo=True) as a dict."""
    def save(self, path: str) -> None:
        """Writes the tree to a tree file (docs/tree-format.md)."""

class RayQueries:
    """Exact queries beyond the closest hit: every crossing, counts, first/any crossing, containment.
    A ray through a shared edge or vertex of a connected surface crosses it once (docs/queries.md)."""

    def __init__(self, bvh: Bvh, threads: int = 0) -> None: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def threads(self) -> int: ...
    def first(
        self, origins: _Rows, directions: _Rows, tmin: _PerRay = 0.0, tmax: _PerRay = ..., *, threads: Optional[int] = None
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The first crossing of each ray: (t, primitive (-1 on a miss), u, v, points (k, 3) in the caller's frame)."""
    def first_primitive(
        self, origins: _Rows, directions: _Rows, tmin: _PerRay = 0.0, tmax: _PerRay = ..., *, threads: Optional[int] = None
    ) -> npt.NDArray[np.int64]:
        """The triangle of each first crossing (-1 on a miss), as first()[1]."""
    def any(
        self, origins: _Rows, directions: _Rows, tmin: _PerRay = 0.0, tmax: _PerRay = ..., *, threads: Optional[int] = None
    ) -> npt.NDArray[np.bool_]:
        """Whether each ray crosses the mesh."""
    def all(
        self,
        origins: _Rows,
        directions: _Rows,
        tmin: _PerRay = 0.0,
        tmax: _PerRay = ...,
        *,
        max_hits: Optional[int] = None,
        points: bool = True,
        details: bool = True,
        threads: Optional[int] = None,
    ) -> Tuple[
        npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]
    ]:
        """Every crossing sorted by ray then t: (index_ray, primitive, t, u, v (empty when details=False), points (m, 3))."""
    def count(
        self, origins: _Rows, directions: _Rows, tmin: _PerRay = 0.0, tmax: _PerRay = ..., *, threads: Optional[int] = None
    ) -> npt.NDArray[np.int64]:
        """The number of crossings of each ray."""
    def contains(self, points: _Rows, *, threads: Optional[int] = None) -> npt.NDArray[np.bool_]:
        """Whether each point is inside, by exact parity along containment_direction."""

def containment_direction() -> Tuple[float, float, float]:
    """The fixed direction of the rays RayQueries.contains counts crossings along."""

class Tracer:
    """A traversal kernel over a tree; answers equal the exact arbiter of rays.md."""

    def __init__(self, bvh: Bvh, kernel: str = "auto", threads: int = 0) -> None: ...
    @property
    def kernel(self) -> str: ...
    @property
    def memory_bytes(self) -> int: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def threads(self) -> int: ...
    def intersect(
        self,
        origins: _Rows,
        directions: _Rows,
        tmin: _PerRay = 0.0,
        tmax: _PerRay = ...,
        *,
        threads: Optional[int] = None,
    ) -> _Hits:
        """Closest hits: arrays t (the scene's dtype, inf on a miss), primitive (-1 on a miss), u, v."""
    def occluded(
        self,
        origins: _Rows,
        directions: _Rows,
        tmin: _PerRay = 0.0,
        tmax: _PerRay = ...,
        *,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.bool_]:
        """Any hit within [tmin, tmax]: a bool array."""
    def render(
        self,
        width: int = 512,
        height: int = 512,
        camera: str = "",
        *,
        heatmap: bool = False,
        quantity: str = "work",
        percentile: float = 0.99,
        scale_max: float = 0.0,
        legend: bool = True,
    ) -> Any:
        """A (height, width, 3) uint8 image; with heatmap=True (image, dict of scale and totals)."""

class Tracer64:
    """A float64 mesh traced exactly with float64 rays (docs/float64.md)."""

    def __init__(self, vertices: _Rows, faces: npt.ArrayLike, builder: str = "binned", threads: int = 0) -> None: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def frame_origin(self) -> Tuple[float, float, float]: ...
    def intersect(
        self, origins: _Rows, directions: _Rows, tmin: Optional[_PerRay] = None, tmax: Optional[_PerRay] = None
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Closest hits: t (float64, inf on a miss), primitive (-1 on a miss), u, v (float64)."""
    def occluded(
        self, origins: _Rows, directions: _Rows, tmin: Optional[_PerRay] = None, tmax: Optional[_PerRay] = None
    ) -> npt.NDArray[np.bool_]:
        """Any hit within [tmin, tmax], decided exactly: a bool array."""

class EmbreeTracer:
    """Embree 3's own BVH and kernel over a scene, on the same numpy rays (not watertight)."""

    def __init__(self, scene: Scene, quality: str = "high", packets: bool = False, threads: int = 0) -> None: ...
    @property
    def kernel(self) -> str: ...
    @property
    def build_ms(self) -> float: ...
    @property
    def memory_bytes(self) -> int: ...
    @property
    def scene(self) -> Scene: ...
    def intersect(
        self,
        origins: _Rows,
        directions: _Rows,
        tmin: _PerRay = 0.0,
        tmax: _PerRay = ...,
        *,
        threads: Optional[int] = None,
    ) -> _Hits:
        """As Tracer.intersect."""
    def occluded(
        self,
        origins: _Rows,
        directions: _Rows,
        tmin: _PerRay = 0.0,
        tmax: _PerRay = ...,
        *,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.bool_]:
        """As Tracer.occluded."""

def load_bvh(path: str, scene: Scene) -> Bvh:
    """Reads a tree file built over this scene; spacebvh.Error names the file when it does not fit."""

def load_scene(
    source: str, *, rotate: str = "", scale: float = 1.0, translate: Sequence[float] = (0.0, 0.0, 0.0)
) -> Scene:
    """Loads .obj, .ply, .gltf, .glb or builtin:NAME, with the CLI's load-time transform."""

def mesh(vertices: _Rows, faces: npt.ArrayLike, name: str = "mesh") -> Scene:
    """A scene from vertices (n, 3) float32/float64 and faces (m, 3) integer vertex indices."""

def builtin_scenes() -> list[str]:
    """The names accepted by load_scene('builtin:NAME')."""

def builders() -> list[str]:
    """The builder names build() accepts."""

def kernels() -> list[str]:
    """The kernel names Tracer accepts on this CPU."""

def build(
    scene: Scene,
    builder: Optional[str] = None,
    *,
    quality: Union[Quality, str, None] = None,
    threads: int = 0,
    **settings: Optional[_SettingValue],
) -> Bvh:
    """Builds a BVH with a named builder (builders()) or a quality level, and build settings as keywords."""

def build_settings() -> list[dict[str, Any]]:
    """The keywords build() takes: name, type, default, range, help, flag, row_key, example."""

def random_rays(scene: Scene, count: int, seed: int = 1) -> _Rays:
    """The random rays of docs/rays.md: (origins, directions)."""

def primary_rays(scene: Scene, width: int = 1024, height: int = 1024, camera: str = "") -> _Rays:
    """The primary rays of docs/rays.md, row by row from the top: (origins, directions)."""

def diffuse_rays(
    scene: Scene,
    origins: _Rows,
    directions: _Rows,
    t: npt.ArrayLike,
    primitive: npt.ArrayLike,
    seed: int = 1,
    epsilon: float = 0.0,
) -> _Rays:
    """The diffuse rays of docs/rays.md: one bounce per primary ray that hits."""

def read_rays(
    path: str,
) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """A ray file: (origins, directions, tmin, tmax) float32 arrays."""

def write_rays(path: str, origins: _Rows, directions: _Rows, tmin: _PerRay = 0.0, tmax: _PerRay = ...) -> None:
    """Writes a ray file of docs/rays.md."""

def read_hits(path: str) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.int64]]:
    """A hit file: (t, primitive) arrays, primitive -1 for a miss."""

def write_hits(path: str, t: npt.ArrayLike, primitive: npt.ArrayLike) -> None:
    """Writes a hit file from t and primitive arrays (-1 = a miss)."""

def write_png(path: str, pixels: npt.ArrayLike) -> None:
    """Writes a (height, width, 3) uint8 array as a PNG file."""
