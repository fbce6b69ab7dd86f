# SPDX-License-Identifier: MIT
"""Open3D's RaycastingScene against spacebvh.open3d.RaycastingScene: every query, and wrong answers.

Not a test. Part 1 times every query of the class on the bunny and crytek_sponza of the shared scenes
($SPACEBVH_SCENES, default ../shared/scenes beside the checkout), 1,000,000 rays or points (origins and
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
  occupancy and the sign of the signed distance.

    python bench/open3d_drop_in.py [--count 1000000] [--threads 2] [--repeat 3] [--scenes bunny crytek_sponza]

Needs open3d-cpu (pip install "spacebvh[open3d]").
"""

import argparse
import time

import numpy as np
import open3d as o3d
from shared_scenes import SCENES, read_obj

import spacebvh
from spacebvh.open3d import RaycastingScene


def scenes_of(vertices, faces):
    ours, theirs = RaycastingScene(), o3d.t.geometry.RaycastingScene()
    ours.add_triangles(vertices, faces.astype(np.uint32))
    theirs.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(faces.astype(np.uint32)))
    return ours, theirs


def queries():
    """(label, call) of every query: call(scene, rays, points, threads)."""
    return [
        ("cast_rays", lambda s, r, p, n: s.cast_rays(r, nthreads=n)),
        ("test_occlusions", lambda s, r, p, n: s.test_occlusions(r, nthreads=n)),
        ("count_intersections", lambda s, r, p, n: s.count_intersections(r, nthreads=n)),
        ("list_intersections", lambda s, r, p, n: s.list_intersections(r, nthreads=n)),
        ("compute_occupancy", lambda s, r, p, n: s.compute_occupancy(p, nthreads=n)),
        ("compute_closest_points", lambda s, r, p, n: s.compute_closest_points(p, nthreads=n)),
        ("compute_distance", lambda s, r, p, n: s.compute_distance(p, nthreads=n)),
        ("compute_signed_distance", lambda s, r, p, n: s.compute_signed_distance(p, nthreads=n)),
    ]


def speed(args):
    rows = []
    for name in args.scenes:
        path = SCENES / name / f"{name}.obj"
        if not path.exists():
            print(f"skipping {name}: no {path}")
            continue
        vertices, faces = read_obj(path, np.float32)
        ours, theirs = scenes_of(vertices, faces)
        rng = np.random.default_rng(1)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        directions = rng.normal(size=(args.count, 3))
        rays = np.hstack([rng.uniform(lo, hi, (args.count, 3)), directions]).astype(np.float32)
        points = rng.uniform(lo, hi, (args.count, 3)).astype(np.float32)
        their_rays, their_points = o3d.core.Tensor(rays), o3d.core.Tensor(points)
        # Builds (at the first query of each kind: contacts, crossings, distances) apart from the timings.
        for scene, r, p in ((ours, rays, points), (theirs, their_rays, their_points)):
            for _label, call in queries():
                call(scene, r[:1], p[:1], args.threads)
        print(f"\n{name}: {len(faces)} triangles, {args.count} rays/points, {args.threads} threads")
        for label, call in queries():
            runs = []
            for run in range(args.repeat):
                order = [(theirs, their_rays, their_points), (ours, rays, points)]
                times = {}
                for scene, r, p in order if run % 2 == 0 else order[::-1]:
                    start = time.perf_counter()
                    call(scene, r, p, args.threads)
                    times[scene is ours] = time.perf_counter() - start
                runs.append((times[False], times[True]))
            t_theirs, t_ours = np.median(np.array(runs), axis=0)
            rows.append((name, label, t_theirs, t_ours))
            print(
                f"  {label:24s} open3d {t_theirs:7.3f} s   spacebvh {t_ours:7.3f} s   ratio {t_theirs / t_ours:5.2f}x"
            )
    return rows


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


def grid_box(n):
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


def wrong(label, ours, theirs, expected):
    """Prints how many of each library's answers differ from the exact ones."""
    mine, open3d = np.sum(np.asarray(ours) != expected), np.sum(np.asarray(theirs) != expected)
    print(f"  {label:58s} open3d {open3d:6d}   spacebvh {mine:6d}   of {np.size(ours)}")


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


def hostile(args):
    print("\nwrong answers on hostile sets (exact answers by construction)")
    vertices, faces, edges = icosphere()
    ours, theirs = scenes_of(vertices, faces)
    targets = np.vstack([vertices, (vertices[edges[:, 0]] + vertices[edges[:, 1]]) / 2]).astype(np.float32)
    rays = np.hstack([3 * targets, -targets]).astype(np.float32)
    label = f"icosphere ({len(faces)} tris): count_intersections, rays at vertices/edges"
    wrong(label, ours.count_intersections(rays), theirs.count_intersections(o3d.core.Tensor(rays)).numpy(), 2)

    vertices, faces = grid_box(args.grid)
    ours, theirs = scenes_of(vertices, faces)
    rays, interior = axis_rays(args.grid)
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=1_000_000, help="rays and points per query")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3, help="runs of each query pair; medians are printed")
    parser.add_argument("--scenes", nargs="+", default=["bunny", "crytek_sponza"])
    parser.add_argument("--grid", type=int, default=8, help="squares per box edge in the hostile sets")
    args = parser.parse_args()
    print(
        f"open3d {o3d.__version__}, spacebvh {spacebvh.__version__} (kernels: {', '.join(spacebvh.kernels()[:3])}...)"
    )
    rows = speed(args)
    hostile(args)
    print("\nscene           query                     open3d s  spacebvh s  open3d / spacebvh")
    for name, label, theirs, ours in rows:
        print(f"{name:15s} {label:24s} {theirs:9.3f} {ours:11.3f} {theirs / ours:10.2f}x")


if __name__ == "__main__":
    main()
