# SPDX-License-Identifier: MIT
"""spacebvh's point queries against Open3D's RaycastingScene and libigl: the same points, one run.

Not a test: it times closest points, distance and signed distance on the bunny and crytek_sponza from
the shared scenes ($SPACEBVH_SCENES, default ../shared/scenes beside the checkout) and prints points per
second and the ratios. Then it counts each library's wrong answers (ours included) against the exact
reference of the Python tests (Fractions over every float32 triangle) on hostile sets: a lattice
through a subdivided box's faces, edges and vertices, the same rotated, and points exactly on a closed
box's surface (inside triangles, on edges, at vertices); and, where that reference is too slow,
points on the bunny's surface against ours. Needs `pip install ".[bench]"` (open3d-cpu 0.20.0,
libigl 2.6.3; Open3D also needs Debian's libusb-1.0-0 and libgomp1).

    python bench/distance_peers.py [--points 1000000] [--libigl-points 100000] [--threads 2]
        [--scenes bunny crytek_sponza living_room_3] [--hostile-only]

Points: uniform in the scene's bounding box grown by a tenth on each side (seeded). Tree and scene
builds are timed apart from the queries; each query is timed three times, the median printed. libigl
runs once per query on the first --libigl-points of them (its signed_distance rebuilds its tree on
every call and takes minutes for a million points), and ours is timed again on the same points for
its ratios.
"""

import argparse
import statistics
import time
from fractions import Fraction

import hostile_sets as sets
import numpy as np
from shared_scenes import SCENES
from test_distance import wrong_against_reference

import spacebvh


def median_seconds(function, *args, repeats=3):
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function(*args)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def indexed_mesh(scene):
    """Vertices (shared) and faces of a spacebvh scene's triangles, as libigl's signs need."""
    corners = np.asarray(scene.triangles(), dtype=np.float64).reshape(-1, 3)
    vertices, inverse = np.unique(corners, axis=0, return_inverse=True)
    return vertices, inverse.reshape(-1, 3).astype(np.int64)


def grid_box(n):
    """A closed box [0, 2n]^3 of n x n quads per face (outward), and a lattice of step 1/2 through it."""
    grid = np.arange(n + 1, dtype=np.float64) * 2.0
    u, v = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))
    vertices, faces = [], []
    cells = np.array([(i * (n + 1) + j) for i in range(n) for j in range(n)])
    for axis in range(3):
        for side in (0, 1):
            plane = np.zeros((len(u), 3))
            plane[:, axis] = 2.0 * n * side
            plane[:, (axis + 1) % 3], plane[:, (axis + 2) % 3] = u, v
            base = len(vertices) and sum(len(x) for x in vertices)
            vertices.append(plane)
            a, b, c, d = base + cells, base + cells + n + 1, base + cells + n + 2, base + cells + 1
            if side == 0:
                b, d = d, b
            faces.append(np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]))
    r = np.arange(-1.0, 2 * n + 1.25, 0.5)
    lattice = np.stack(np.meshgrid(r, r, r, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.concatenate(vertices), np.concatenate(faces), lattice


class Peers:
    """Each library's distance, signed distance and closest points on one mesh."""

    def __init__(self, vertices, faces, threads):
        import igl
        import open3d as o3d

        self.o3d, self.igl, self.threads = o3d, igl, threads
        self.V, self.F = vertices, faces
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)), o3d.core.Tensor(faces.astype(np.uint32)))

    def open3d(self, what, points):
        p = self.o3d.core.Tensor(points.astype(np.float32))
        if what == "closest":
            return self.scene.compute_closest_points(p, nthreads=self.threads)["points"].numpy()
        if what == "distance":
            return self.scene.compute_distance(p, nthreads=self.threads).numpy()
        return self.scene.compute_signed_distance(p, nthreads=self.threads).numpy()

    def libigl(self, what, points):
        if what == "signed":
            return self.igl.signed_distance(points, self.V, self.F)[0]
        d2, _, closest = self.igl.point_mesh_squared_distance(points, self.V, self.F)
        return closest if what == "closest" else np.sqrt(d2)


def ours(queries, what, points):
    if what == "closest":
        return queries.closest_points(points)["points"]
    if what == "distance":
        return queries.distance(points)
    return queries.signed_distance(points)


def time_scene(name, count, threads, libigl_count):
    path = SCENES / name / f"{name}.obj"
    if not path.exists():
        print(f"skipping {name}: no {path}")
        return
    scene = spacebvh.load_scene(str(path))
    start = time.perf_counter()
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "spatial"), threads=threads)
    print(f"{name}: {scene.triangles().shape[0]} triangles, our tree {time.perf_counter() - start:.2f} s")
    vertices, faces = indexed_mesh(scene)
    peers = Peers(vertices, faces, threads)
    lo, hi = (np.array(b) for b in scene.bounds)
    grow = (hi - lo) * 0.1
    points = np.random.default_rng(1).uniform(lo - grow, hi + grow, (count, 3))
    for what in ("closest", "distance", "signed"):
        ours_s, _ = median_seconds(ours, queries, what, points)
        o3d_s, _ = median_seconds(peers.open3d, what, points)
        print(f"  {what:9s} ours {count / ours_s / 1e6:6.2f} Mpt/s  Open3D x{o3d_s / ours_s:5.2f}", flush=True)
    libigl_rows(queries, peers, points[:libigl_count])


def libigl_rows(queries, peers, points):
    """libigl on the same points as ours, one run each (its signed_distance builds its AABB tree on
    every call, which is part of what a caller pays; at 1M points a call runs for minutes, hence the
    subset): our closest points, distance and signed distance against libigl's signed_distance (the
    bar: closest points >= 5x), and distance against its point_mesh_squared_distance."""
    n = len(points)
    igl_signed_s, _ = median_seconds(peers.libigl, "signed", points, repeats=1)
    igl_distance_s, _ = median_seconds(peers.libigl, "distance", points, repeats=1)
    line = f"  libigl, {n} points: signed_distance {igl_signed_s:7.2f} s ({n / igl_signed_s / 1e3:7.1f} kpt/s),"
    print(f"{line} point_mesh_squared_distance {igl_distance_s:7.2f} s ({n / igl_distance_s / 1e3:7.1f} kpt/s)")
    for what, theirs_s, theirs in (
        ("closest", igl_signed_s, "signed_distance"),
        ("signed", igl_signed_s, "signed_distance"),
        ("distance", igl_distance_s, "point_mesh_squared_distance"),
    ):
        ours_s, _ = median_seconds(ours, queries, what, points)
        bar = "  (bar >= 5x)" if what == "closest" else ""
        print(f"    ours {what:8s} vs libigl {theirs:27s} x{theirs_s / ours_s:7.2f}{bar}", flush=True)


def wrong_answers(name, vertices, faces, points, threads, inside):
    """Each library's wrong answers against the exact reference of the Python tests (test_distance.py:
    the squared distance to every float32 triangle in Fractions, the nearest with ties to the smaller
    id): a distance beyond 1e-6 of the mesh's size from the exact one, or a point off the surface on
    the wrong side (`inside`: by construction). Ours is checked by that reference's own rule (nearest
    triangle and the documented error bound)."""
    vertices = vertices.astype(np.float32).astype(np.float64)
    # float32 in: our triangles are then exactly the reference's (a float64 mesh is taken into a frame
    # about its centre before rounding, docs/float64.md).
    scene = spacebvh.mesh(vertices.astype(np.float32), faces)
    queries = spacebvh.DistanceQueries(spacebvh.build(scene, "spatial"), threads=threads)
    triangles = [tuple(tuple(Fraction(float(c)) for c in vertices[v]) for v in f) for f in faces]
    exact_d2 = []
    ours_wrong = len(wrong_against_reference(queries, triangles, points, exact_d2))
    exact = np.sqrt(np.array([float(d2) for d2 in exact_d2]))
    tolerance = 1e-6 * float(np.max(vertices.max(axis=0) - vertices.min(axis=0)))
    off = exact > tolerance
    ours_sign = int(np.sum(off & ((queries.signed_distance(points) < 0) != inside)))
    peers = Peers(vertices, faces, threads)
    line = f"  {name:28s} spacebvh {ours_wrong:5d} {ours_sign:5d}"
    for library in ("open3d", "libigl"):
        answer = getattr(peers, library)
        distance = int(np.sum(np.abs(answer("distance", points) - exact) > tolerance))
        sign = int(np.sum(off & ((answer("signed", points) < 0) != inside)))
        line += f"   {library} {distance:5d} {sign:5d}"
    print(f"{line}   of {len(points)} ({int(np.sum(~off))} on the surface)", flush=True)


def against_ours(name, vertices, faces, points, threads):
    """Where the Fraction reference is too slow (large meshes): each library's distances that differ
    from ours (exact nearest triangle, checked above and in the tests) beyond 1e-6 of the mesh's size."""
    queries = spacebvh.DistanceQueries(spacebvh.build(spacebvh.mesh(vertices, faces), "spatial"), threads=threads)
    ours = queries.distance(points)
    tolerance = 1e-6 * float(np.max(vertices.max(axis=0) - vertices.min(axis=0)))
    peers = Peers(vertices, faces, threads)
    counts = "   ".join(
        f"{library} {int(np.sum(np.abs(getattr(peers, library)('distance', points) - ours) > tolerance)):5d}"
        for library in ("open3d", "libigl")
    )
    print(f"  {name:28s} distance differs from ours: {counts}   of {len(points)}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1_000_000)
    parser.add_argument("--threads", type=int, default=2)
    # living_room_3 (786,208 triangles): the largest mesh of the shared collection, which has none of
    # 1-2M triangles.
    parser.add_argument("--scenes", nargs="+", default=["bunny", "crytek_sponza", "living_room_3"])
    parser.add_argument(
        "--libigl-points", type=int, default=100_000, help="points libigl and ours are timed on (the first of --points)"
    )
    parser.add_argument("--lattice-step", type=int, default=3, help="every n-th lattice point (the reference is slow)")
    parser.add_argument("--hostile-only", action="store_true", help="only the wrong answers, no timings")
    args = parser.parse_args()
    for name in [] if args.hostile_only else args.scenes:
        time_scene(name, args.points, args.threads, min(args.libigl_points, args.points))
    print(
        "wrong answers against the exact reference (Fractions, every triangle): distance, sign of points off the "
        "surface; libraries in turn"
    )
    vertices, faces, lattice = grid_box(3)
    lattice = lattice[:: args.lattice_step]
    inside = np.all((lattice > 0) & (lattice < 6), axis=1)
    wrong_answers("box lattice", vertices, faces, lattice, args.threads, inside)
    rotation = np.linalg.qr(np.random.default_rng(2).normal(size=(3, 3)))[0]
    wrong_answers("rotated box lattice", vertices @ rotation.T, faces, lattice @ rotation.T, args.threads, inside)
    # Points exactly on a closed box's surface: inside triangles, on edges (grid lines, diagonals) and
    # at vertices, the box's edges and corners included (the origins of bench/hostile_sets.py's rays).
    vertices, faces, origins = sets.surface_rays(3)[:3]
    points = np.unique(origins.astype(np.float64), axis=0)
    wrong_answers("box surface points", vertices, faces, points, args.threads, np.zeros(len(points), dtype=bool))
    if (SCENES / "bunny" / "bunny.obj").exists():
        scene = spacebvh.load_scene(str(SCENES / "bunny" / "bunny.obj"))
        v, f = indexed_mesh(scene)
        rng = np.random.default_rng(4)
        tri = v[f[rng.integers(0, len(f), 20000)]]
        u = rng.uniform(0, 1, (20000, 1))
        w = rng.uniform(0, 1, (20000, 1)) * (1 - u)
        on_surface = tri[:, 0] + u * (tri[:, 1] - tri[:, 0]) + w * (tri[:, 2] - tri[:, 0])
        against_ours("bunny surface points", v, f, on_surface, args.threads)


if __name__ == "__main__":
    main()
