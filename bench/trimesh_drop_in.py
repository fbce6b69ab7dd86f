# SPDX-License-Identifier: MIT
"""trimesh with embreex against trimesh patched with spacebvh: the same rays, one run.

Not a test: it times intersects_first, intersects_any, intersects_location (multiple hits) and
contains_points on the bunny and crytek_sponza from the shared scenes ($SPACEBVH_SCENES, default
../shared/scenes beside the checkout) and prints rays per second and the ratios. Needs
`pip install trimesh embreex` and spacebvh in the same environment; without embreex (or with
`--overhead-only`) it prints only the drop-in's overhead: each drop-in query against the spacebvh
call it wraps (Tracer.intersect, Tracer.occluded, RayQueries.all, RayQueries.contains), side by side.

    python bench/trimesh_drop_in.py [--rays 1000000] [--threads 2] [--scenes bunny crytek_sponza]

The rays: origins uniform in the scene's bounding box, directions uniform on the sphere (seeded);
containment points uniform in the bounding box. Tree builds (ours) and scene builds (Embree) are
timed apart from the queries. Agreement is reported, not asserted: where they differ, trimesh+embreex
is the one that can be wrong (float32, re-query offsets, parity noise).
"""

import argparse
import time

import hostile_sets as sets
import numpy as np
import trimesh
from shared_scenes import each_scene

import spacebvh
import spacebvh.trimesh as drop_in


def rays_for(mesh, count, seed):
    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds
    origins = rng.uniform(lo, hi, (count, 3))
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    return origins, directions


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    result = function(*args, **kwargs)
    return time.perf_counter() - start, result


def timed_with_cpu(function, *args, **kwargs):
    """Wall seconds, CPU seconds of this process (every thread) and the result."""
    start, cpu_start = time.perf_counter(), time.process_time()
    result = function(*args, **kwargs)
    return time.perf_counter() - start, time.process_time() - cpu_start, result


def overhead(args):
    """Each drop-in query against the spacebvh call it makes, on the same rays, side by side."""
    print(f"drop-in overhead: {args.rays} rays, threads={args.threads}, medians of {max(args.repeat, 3)} runs")
    for name, vertices, faces in each_scene(args.scenes):
        overhead_on(name, vertices, faces, args)


def overhead_on(name, vertices, faces, args):
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    ray = drop_in.RayMeshIntersector(mesh, builder=args.builder, threads=args.threads)
    o, d = rays_for(mesh, args.rays, 1)
    points = rays_for(mesh, args.rays, 2)[0]
    tracer, queries = ray.tracer, ray.queries
    pairs = [
        ("intersects_first", lambda: ray.intersects_first(o, d), lambda: tracer.intersect(o, d)),
        ("intersects_any", lambda: ray.intersects_any(o, d), lambda: tracer.occluded(o, d)),
        (
            "intersects_location (single)",
            lambda: ray.intersects_location(o, d, multiple_hits=False),
            lambda: tracer.hits(o, d, points=True),
        ),
        (
            "intersects_location (multiple)",
            lambda: ray.intersects_location(o, d, multiple_hits=True),
            lambda: queries.all(o, d, max_hits=100, points=True, details=False),
        ),
        ("contains_points", lambda: ray.contains_points(points), lambda: queries.contains(points)),
    ]
    print(f"\n{name}: {len(faces)} triangles")
    for label, wrapped, core in pairs:
        # In turn, first one then the other first, so that both see the same load; medians printed.
        runs = []
        for run in range(max(args.repeat, 3)):
            runs.append(
                (timed(wrapped)[0], timed(core)[0])
                if run % 2 == 0
                else tuple(reversed((timed(core)[0], timed(wrapped)[0])))
            )
        runs = np.median(np.array(runs), axis=0)
        print(
            f"  {label:31s} drop-in {runs[0]:6.3f} s   core {runs[1]:6.3f} s   drop-in / core {runs[0] / runs[1]:5.2f}"
        )


def hit_counts(mesh, origins, directions):
    """Multiple hits per ray (intersects_location with multiple_hits=True)."""
    index_ray = mesh.ray.intersects_location(origins, directions, multiple_hits=True)[1]
    return np.bincount(index_ray, minlength=len(origins))


def hostile(args, meshes):
    """Each library's wrong answers on the hostile sets, against answers exact by construction or by the
    Fraction reference. meshes(vertices, faces) gives (label, trimesh.Trimesh) pairs."""
    print("\nwrong answers on hostile sets (exact by construction, or by the Fraction reference)")

    def report(label, expected, answer, pairs):
        answers = [(name, np.asarray(answer(mesh))) for name, mesh in pairs]
        counts = "   ".join(f"{name} {int(np.sum(a != expected)):5d}" for name, a in answers)
        print(f"  {label:66s} {counts}   of {len(answers[0][1])}")

    vertices, faces, edges = sets.icosphere()
    pairs = meshes(vertices, faces)
    targets = np.vstack([vertices, (vertices[edges[:, 0]] + vertices[edges[:, 1]]) / 2]).astype(np.float64)
    o, d = 3 * targets, -targets
    report(
        f"icosphere ({len(faces)} tris): multiple hits, rays at vertices/edges = 2",
        2,
        lambda m: hit_counts(m, o, d),
        pairs,
    )

    vertices, faces = sets.unit_grid_box(args.grid)
    pairs = meshes(vertices, faces)
    rays, interior = sets.axis_rays(args.grid)
    o, d = rays[:, :3].astype(np.float64), rays[:, 3:].astype(np.float64)
    report(
        f"grid box {args.grid}x{args.grid}: multiple hits, interior axis rays = 2",
        2,
        lambda m: hit_counts(m, o[interior], d[interior]),
        pairs,
    )
    report(
        "grid box: intersects_any, rays in faces' planes and along edges",
        True,
        lambda m: m.ray.intersects_any(o[~interior], d[~interior]),
        pairs,
    )
    report(
        "grid box: intersects_first hits, rays in faces' planes and along edges",
        True,
        lambda m: m.ray.intersects_first(o[~interior], d[~interior]) >= 0,
        pairs,
    )
    steps = np.arange(-2, 2 * args.grid + 3) / (2 * args.grid)
    points = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), axis=-1).reshape(-1, 3)
    points = points[~np.any((points == 0) | (points == 1), axis=1)]  # never on the surface
    inside = np.all((points > 0) & (points < 1), axis=1)
    report(
        f"grid box: contains_points, {len(points)} lattice points off the surface",
        inside,
        lambda m: m.contains(points),
        pairs,
    )

    vertices, faces, origins, directions, kinds = sets.surface_rays(args.surface_grid)
    exact_t, nearest, crossings = sets.exact_answers(vertices, faces, origins, directions)
    o, d = origins.astype(np.float64), directions.astype(np.float64)
    print(f"  rays from the surface of a closed box ({len(faces)} tris, {len(o)} rays), by origin and direction:")
    for name, mesh in meshes(vertices, faces):
        checks = [
            ("intersects_first", sets.wrong_first_triangle(mesh.ray.intersects_first(o, d), nearest)),
            ("intersects_any", np.asarray(mesh.ray.intersects_any(o, d)) != np.isfinite(exact_t)),
            ("multiple hits (crossings)", hit_counts(mesh, o, d) != crossings),
        ]
        for label, wrong in checks:
            print(f"    {name:16s} {label:26s} {int(np.sum(wrong)):5d}   {sets.by_kind(kinds, wrong)}")


# The bars of the drop-in against trimesh+embreex (spacebvh on 2 threads, trimesh+embreex on its one).
BARS = {"intersects_first": 1.8, "intersects_any": 1.8, "intersects_location": 4.0, "contains_points": 10.0}


def against_embree(args):
    """trimesh+embreex against the drop-in on the shared scenes, query by query: rows of (scene, query,
    embree Mrays/s, spacebvh Mrays/s, wall ratio, CPU ratio)."""
    rows = []
    for name, vertices, faces in each_scene(args.scenes):
        theirs = trimesh.Trimesh(vertices, faces, process=False)  # Embree backend
        ours = trimesh.Trimesh(vertices, faces, process=False)
        ours.ray = drop_in.RayMeshIntersector(ours, builder=args.builder, threads=args.threads)
        assert type(theirs.ray).__module__ == "trimesh.ray.ray_pyembree", type(theirs.ray)
        origins, directions = rays_for(theirs, args.rays, 1)
        points = rays_for(theirs, args.rays, 2)[0]

        # Builds, apart from the queries.
        build_theirs, _ = timed(theirs.ray.intersects_first, origins[:1], directions[:1])
        build_ours, _ = timed(ours.ray.intersects_first, origins[:1], directions[:1])
        print(
            f"\n{name}: {len(faces)} triangles; first-query build: embree {build_theirs:.2f} s, "
            f"spacebvh {build_ours:.2f} s"
        )

        queries = [
            ("intersects_first", lambda m, o=origins, d=directions: m.ray.intersects_first(o, d)),
            ("intersects_any", lambda m, o=origins, d=directions: m.ray.intersects_any(o, d)),
            (
                "intersects_location",
                lambda m, o=origins, d=directions: m.ray.intersects_location(o, d, multiple_hits=True),
            ),
            ("contains_points", lambda m, p=points: m.ray.contains_points(p)),
        ]
        for label, query in queries:
            # Side by side, `repeat` times; each figure below is the median over the runs.
            runs = []
            for run in range(args.repeat):
                # In turn, first one then the other first, so that both see the same load.
                if run % 2 == 0:
                    t_theirs, cpu_theirs, a = timed_with_cpu(query, theirs)
                    t_ours, cpu_ours, b = timed_with_cpu(query, ours)
                else:
                    t_ours, cpu_ours, b = timed_with_cpu(query, ours)
                    t_theirs, cpu_theirs, a = timed_with_cpu(query, theirs)
                runs.append((t_theirs, t_ours, t_theirs / t_ours, cpu_theirs / cpu_ours))
            t_theirs, t_ours, ratio, cpu_ratio = np.median(np.array(runs), axis=0)
            if label == "intersects_location":
                agree = np.mean(np.bincount(a[1], minlength=args.rays) == np.bincount(b[1], minlength=args.rays))
                hits = f", hits {len(a[1])} vs {len(b[1])}"
            else:
                agree = np.mean(np.asarray(a) == np.asarray(b))
                hits = ""
            rows.append((name, label, args.rays / t_theirs / 1e6, args.rays / t_ours / 1e6, ratio, cpu_ratio))
            print(
                f"  {label:20s} embree {args.rays / t_theirs / 1e6:7.3f} Mrays/s ({t_theirs:6.2f} s)   "
                f"spacebvh {args.rays / t_ours / 1e6:7.3f} Mrays/s ({t_ours:6.2f} s)   "
                f"ratio {ratio:6.1f}x (cpu {cpu_ratio:5.1f}x)   same answer {100 * agree:.2f} %{hits}",
                flush=True,
            )

    return rows


def meshes_for(args):
    """(label, mesh) of trimesh+embreex and of the drop-in, for the hostile sets."""

    def meshes(vertices, faces):
        theirs = trimesh.Trimesh(vertices.astype(np.float64), faces, process=False)
        ours = trimesh.Trimesh(vertices.astype(np.float64), faces, process=False)
        ours.ray = drop_in.RayMeshIntersector(ours, builder=args.builder, threads=args.threads)
        return [("trimesh+embreex", theirs), ("spacebvh", ours)]

    return meshes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=1_000_000)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--scenes", nargs="+", default=["bunny", "crytek_sponza"])
    parser.add_argument("--builder", default="binned")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each query pair; medians are printed")
    parser.add_argument("--overhead-only", action="store_true", help="only the drop-in against the calls it wraps")
    parser.add_argument("--no-overhead", action="store_true", help="skip the drop-in against the calls it wraps")
    parser.add_argument("--hostile-only", action="store_true", help="only the wrong answers on the hostile sets")
    parser.add_argument("--grid", type=int, default=8, help="squares per box edge in the hostile sets")
    parser.add_argument("--surface-grid", type=int, default=3, help="quads per box edge for the rays from the surface")
    args = parser.parse_args()
    if not (args.no_overhead or args.hostile_only):
        overhead(args)
    if args.overhead_only:
        return
    try:
        import embreex
        import trimesh.ray.ray_pyembree as embree_backend  # noqa: F401
    except ImportError:
        print("\nno embreex: trimesh's Embree backend is not compared (pip install embreex)")
        return

    print(
        f"trimesh {trimesh.__version__}, embreex {embreex.__version__}, spacebvh {spacebvh.__version__}; "
        f"{args.rays} rays, spacebvh threads={args.threads}, builder {args.builder}, medians of {args.repeat} runs"
    )
    rows = [] if args.hostile_only else against_embree(args)
    hostile(args, meshes_for(args))
    if not rows:
        return
    # The CPU ratio is the work ratio (trimesh+embreex runs on one thread, spacebvh on `threads`): on a
    # machine with idle cores for every thread, the wall ratio approaches it times the thread count; on
    # a machine loaded past its cores the threads share the same cores and the wall ratio falls to it.
    print("\nscene           query                 embree Mrays/s  spacebvh Mrays/s  ratio  cpu ratio  bar")
    for name, label, theirs, ours, ratio, cpu_ratio in rows:
        bar = BARS[label]
        print(
            f"{name:15s} {label:20s} {theirs:15.3f} {ours:17.3f} {ratio:6.1f}x {cpu_ratio:6.1f}x   "
            f">= {bar:4.1f}x {'met' if ratio >= bar else 'MISSED'}"
        )


if __name__ == "__main__":
    main()
