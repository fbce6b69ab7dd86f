# SPDX-License-Identifier: MIT
"""Open3D's RaycastingScene against spacebvh.open3d.RaycastingScene: every query, and wrong answers.

Not a test. Part 1 times every query of the class on the bunny and crytek_sponza of the shared scenes
($SPACEBVH_SCENES, default ../shared/scenes beside the checkout) and on a generated mesh of 1,555,200
triangles (`organic-x16`: the built-in organic mesh split twice into four, the same on every run;
bench/shared_scenes.py), 1,000,000 rays or points (origins and
points uniform in the scene's box, directions uniform on the sphere), `nthreads` threads for both
(Open3D votes at its default nsamples=1), run in turn with medians, and prints the ratios (Open3D's
time over ours: above 1 is spacebvh faster). Part 2 counts each library's wrong answers on hostile sets
whose exact answers are known by construction:

- a rotated icosphere, rays from outside aimed at each vertex and edge midpoint through the centre:
  every ray crosses the closed surface exactly twice (count_intersections);
- a box subdivided into an n x n grid per face, rays along the axes through its interior grid
  vertices and edge lines: 2 crossings each, and the first contact at the face (cast_rays, t exact);
  rays running in the planes of faces and along the box's edges: a contact (cast_rays hits);
- points on a lattice through the box's grid: on the surface, a distance of 0; inside or outside,
  occupancy and the sign of the signed distance;
- rays whose origins lie exactly on a closed box's surface (triangle interiors, edges, vertices;
  directions off the surface and along it, tnear = 0), against the Python tests' Fraction references
  (bench/hostile_sets.py): the first contact's t and triangle, occlusion and crossing counts, by kind;
  and those origins as points on the surface (distance 0, the closest point the point itself).

    python bench/open3d_drop_in.py [--count 1000000] [--threads 2] [--repeat 3] [--scenes bunny crytek_sponza]

Each query's line also gives the time of the general spacebvh call the drop-in rests on ("core":
Tracer.intersect / occluded, RayQueries.count / all / contains, DistanceQueries on the same tree and
inputs), so that the drop-in's own cost (drop-in / core) and the gap of the core to Open3D show apart;
each scene's first line gives both libraries' build times (Open3D's add_triangles and commit at its
first query; ours at the first query of each kind: the tree, then the tracer's and the crossing
walk's layouts), which the query timings leave out.
--queries times only the queries named (all by default). --scenes takes any scene of the shared
collection by name (NAME/NAME.obj), e.g. `--scenes bunny crytek_sponza living_room_3` for a large one
(786,208 triangles).

Needs open3d-cpu (pip install ".[bench]").
"""

import argparse
import time

import hostile_sets as sets
import numpy as np
import open3d as o3d
from shared_scenes import LARGE, each_scene

import spacebvh
from spacebvh.open3d import RaycastingScene


def scenes_of(vertices, faces):
    ours, theirs = RaycastingScene(), o3d.t.geometry.RaycastingScene()
    ours.add_triangles(vertices, faces.astype(np.uint32))
    theirs.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces.astype(np.uint32)))
    return ours, theirs


def queries():
    """(label, call, core) of every query: call(scene, rays, points, threads) runs it on either class;
    core(ours, rays, points, threads) runs the general spacebvh call it rests on (Tracer, RayQueries,
    DistanceQueries on the same tree), so that the drop-in's own cost and the core's gap show apart."""

    def o(r):
        return r[:, :3]

    def d(r):
        return r[:, 3:]

    def tracer(s):
        return s._query("tracer")

    def crossings(s):
        return s._query("crossings")

    def distance(s):
        return s._query("distance")

    return [
        (
            "cast_rays",
            lambda s, r, p, n: s.cast_rays(r, nthreads=n),
            lambda s, r, p, n: tracer(s).intersect(o(r), d(r), threads=n),
        ),
        (
            "test_occlusions",
            lambda s, r, p, n: s.test_occlusions(r, nthreads=n),
            lambda s, r, p, n: tracer(s).occluded(o(r), d(r), threads=n),
        ),
        (
            "count_intersections",
            lambda s, r, p, n: s.count_intersections(r, nthreads=n),
            lambda s, r, p, n: crossings(s).count(o(r), d(r), threads=n),
        ),
        (
            "list_intersections",
            lambda s, r, p, n: s.list_intersections(r, nthreads=n),
            lambda s, r, p, n: crossings(s).all(o(r), d(r), points=False, details=False, threads=n),
        ),
        (
            "compute_occupancy",
            lambda s, r, p, n: s.compute_occupancy(p, nthreads=n),
            lambda s, r, p, n: crossings(s).contains(p, threads=n),
        ),
        (
            "compute_closest_points",
            lambda s, r, p, n: s.compute_closest_points(p, nthreads=n),
            lambda s, r, p, n: distance(s).closest_points(p, threads=n),
        ),
        (
            "compute_distance",
            lambda s, r, p, n: s.compute_distance(p, nthreads=n),
            lambda s, r, p, n: distance(s).distance(p, threads=n),
        ),
        (
            "compute_signed_distance",
            lambda s, r, p, n: s.compute_signed_distance(p, nthreads=n),
            lambda s, r, p, n: distance(s).signed_distance(p, sign="parity", threads=n),
        ),
    ]


def timed(function, scene, rays, points, threads):
    start = time.perf_counter()
    function(scene, rays, points, threads)
    return time.perf_counter() - start


def speed(args):
    rows = []
    for name, vertices, faces in each_scene(args.scenes, np.float32):
        ours, theirs = scenes_of(vertices, faces)
        rng = np.random.default_rng(1)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        directions = rng.normal(size=(args.count, 3))
        rays = np.hstack([rng.uniform(lo, hi, (args.count, 3)), directions]).astype(np.float32)
        points = rng.uniform(lo, hi, (args.count, 3)).astype(np.float32)
        their_rays, their_points = o3d.core.Tensor(rays), o3d.core.Tensor(points)
        # Builds (at the first query of each kind: contacts, crossings, distances) apart from the timings.
        built = []
        for scene, r, p in ((ours, rays, points), (theirs, their_rays, their_points)):
            start = time.perf_counter()
            for _label, call, _core in queries():
                call(scene, r[:1], p[:1], args.threads)
            built.append(time.perf_counter() - start)
        print(
            f"\n{name}: {len(faces)} triangles, {args.count} rays/points, {args.threads} threads, "
            f"medians of {args.repeat}; builds (first query of each kind): open3d {built[1]:.3f} s, "
            f"spacebvh {built[0]:.3f} s"
        )
        for label, call, core in queries():
            if args.queries and label not in args.queries:
                continue
            calls = [(call, theirs, their_rays, their_points), (call, ours, rays, points), (core, ours, rays, points)]
            runs = []
            for run in range(args.repeat):  # the three in turn, each run starting with the next one
                order = [(run + k) % 3 for k in range(3)]
                times = {k: timed(*calls[k], args.threads) for k in order}
                runs.append([times[0], times[1], times[2]])
            t_theirs, t_ours, t_core = np.median(np.array(runs), axis=0)
            rows.append((name, label, t_theirs, t_ours, t_core))
            print(
                f"  {label:24s} open3d {t_theirs:7.3f} s   spacebvh {t_ours:7.3f} s (core {t_core:7.3f} s)   "
                f"ratio {t_theirs / t_ours:5.2f}x (core {t_theirs / t_core:5.2f}x, "
                f"drop-in / core {t_ours / t_core:4.2f})"
            )
    return rows


def wrong(label, ours, theirs, expected):
    """Prints how many of each library's answers differ from the exact ones."""
    mine, open3d = np.sum(np.asarray(ours) != expected), np.sum(np.asarray(theirs) != expected)
    print(f"  {label:58s} open3d {open3d:6d}   spacebvh {mine:6d}   of {np.size(ours)}")


def hostile(args):
    print("\nwrong answers on hostile sets (exact answers by construction)")
    vertices, faces, edges = sets.icosphere()
    ours, theirs = scenes_of(vertices, faces)
    targets = np.vstack([vertices, (vertices[edges[:, 0]] + vertices[edges[:, 1]]) / 2]).astype(np.float32)
    rays = np.hstack([3 * targets, -targets]).astype(np.float32)
    label = f"icosphere ({len(faces)} tris): count_intersections, rays at vertices/edges"
    wrong(label, ours.count_intersections(rays), theirs.count_intersections(o3d.core.Tensor(rays)).numpy(), 2)

    vertices, faces = sets.unit_grid_box(args.grid)
    ours, theirs = scenes_of(vertices, faces)
    rays, interior = sets.axis_rays(args.grid)
    their = o3d.core.Tensor(rays)
    counts = (ours.count_intersections(rays), theirs.count_intersections(their).numpy())
    wrong(
        f"grid box {args.grid}x{args.grid}: count_intersections, interior axis rays", *(c[interior] for c in counts), 2
    )
    hits = (np.asarray(ours.cast_rays(rays)["t_hit"]), theirs.cast_rays(their)["t_hit"].numpy())
    wrong("grid box: cast_rays t_hit not exactly 1, interior axis rays", *(h[interior] == 1 for h in hits), True)
    wrong(
        "grid box: cast_rays hit, rays in faces' planes and along edges", *(h[~interior] < np.inf for h in hits), True
    )
    occluded = (np.asarray(ours.test_occlusions(rays)), theirs.test_occlusions(their).numpy())
    wrong("grid box: test_occlusions, rays in faces' planes and along edges", *(o[~interior] for o in occluded), True)

    steps = np.arange(-2, 2 * args.grid + 3) / (2 * args.grid)
    points = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), axis=-1).reshape(-1, 3)
    on_surface = np.any((points == 0) | (points == 1), axis=1) & np.all((points >= 0) & (points <= 1), axis=1)
    surface = o3d.core.Tensor(points[on_surface].astype(np.float32))
    distance = (np.asarray(ours.compute_distance(surface.numpy())), theirs.compute_distance(surface).numpy())
    wrong(f"grid box: compute_distance == 0, {len(surface)} lattice points on the surface", *distance, 0.0)
    points = points[~np.any((points == 0) | (points == 1), axis=1)].astype(np.float32)  # never on the surface
    inside = np.all((points > 0) & (points < 1), axis=1)
    their = o3d.core.Tensor(points)
    occupancy = (np.asarray(ours.compute_occupancy(points)), theirs.compute_occupancy(their).numpy())
    wrong(f"grid box: compute_occupancy, {len(points)} lattice points", *(o == 1 for o in occupancy), inside)
    signed = (np.asarray(ours.compute_signed_distance(points)), theirs.compute_signed_distance(their).numpy())
    wrong("grid box: compute_signed_distance < 0, lattice points", *(s < 0 for s in signed), inside)


def from_the_surface(args):
    """Rays from exact points of a closed box's surface, and those points, against the Fraction reference."""
    vertices, faces, origins, directions, kinds = sets.surface_rays(args.surface_grid)
    exact_t, nearest, crossings = sets.exact_answers(vertices, faces, origins, directions)
    size = float(np.max(vertices) - np.min(vertices))
    print(
        f"\nrays from the surface of a closed box ({len(faces)} tris, {len(origins)} rays, tnear = 0), wrong against "
        "the exact reference (Fractions, every triangle), by origin and direction:"
    )
    ours, theirs = scenes_of(vertices, faces)
    rays = np.hstack([origins, directions])

    def as_numpy(x):  # spacebvh.open3d answers in Open3D tensors when open3d is installed, as here
        return x.numpy() if hasattr(x, "numpy") else np.asarray(x)

    for library, scene, r in (("open3d", theirs, o3d.core.Tensor(rays)), ("spacebvh", ours, rays)):
        cast = scene.cast_rays(r)
        t = as_numpy(cast["t_hit"])
        ids = np.where(np.isfinite(t), as_numpy(cast["primitive_ids"]).astype(np.int64), -1)
        checks = [
            ("cast_rays t_hit (contact)", sets.wrong_first_t(t, exact_t, size)),
            ("cast_rays primitive_ids", sets.wrong_first_triangle(ids, nearest)),
            ("test_occlusions", as_numpy(scene.test_occlusions(r)) != np.isfinite(exact_t)),
            ("count_intersections", as_numpy(scene.count_intersections(r)) != crossings),
        ]
        for label, bad in checks:
            print(f"  {library:8s} {label:26s} {int(np.sum(bad)):5d}   {sets.by_kind(kinds, bad)}")
    points = np.unique(origins, axis=0)
    their = o3d.core.Tensor(points)
    distance = (as_numpy(ours.compute_distance(points)), theirs.compute_distance(their).numpy())
    wrong(f"closed box: compute_distance == 0, {len(points)} ray origins on the surface", *distance, 0.0)
    closest = (
        as_numpy(ours.compute_closest_points(points)["points"]),
        theirs.compute_closest_points(their)["points"].numpy(),
    )
    wrong(
        "closed box: compute_closest_points is the point itself", *(np.all(c == points, axis=1) for c in closest), True
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1_000_000, help="rays and points per query")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3, help="runs of each query pair; medians are printed")
    parser.add_argument("--scenes", nargs="+", default=["bunny", "crytek_sponza", LARGE])
    parser.add_argument("--queries", nargs="+", choices=[q[0] for q in queries()], help="time only these (default all)")
    parser.add_argument("--grid", type=int, default=8, help="squares per box edge in the hostile sets")
    parser.add_argument("--surface-grid", type=int, default=3, help="quads per box edge for the rays from the surface")
    parser.add_argument("--hostile-only", action="store_true", help="only the wrong answers, no timings")
    args = parser.parse_args()
    print(
        f"open3d {o3d.__version__}, spacebvh {spacebvh.__version__} (kernels: {', '.join(spacebvh.kernels()[:3])}...)"
    )
    rows = [] if args.hostile_only else speed(args)
    hostile(args)
    from_the_surface(args)
    if not rows:
        return
    print(
        "\nscene           query                     open3d s  spacebvh s  core s  open3d / spacebvh  open3d / core"
        "  drop-in / core"
    )
    for name, label, theirs, ours, core in rows:
        print(
            f"{name:15s} {label:24s} {theirs:9.3f} {ours:11.3f} {core:7.3f} {theirs / ours:17.2f}x"
            f" {theirs / core:13.2f}x {ours / core:15.2f}"
        )


if __name__ == "__main__":
    main()
