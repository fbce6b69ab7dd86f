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

import numpy as np
import trimesh
from shared_scenes import SCENES, read_obj

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
    for name in args.scenes:
        path = SCENES / name / f"{name}.obj"
        if not path.exists():
            print(f"skipping {name}: no {path}")
            continue
        overhead_on(name, *read_obj(path), args)


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
            lambda: tracer.intersect(o, d),
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rays", type=int, default=1_000_000)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--scenes", nargs="+", default=["bunny", "crytek_sponza"])
    parser.add_argument("--builder", default="binned")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each query pair; medians are printed")
    parser.add_argument("--overhead-only", action="store_true", help="only the drop-in against the calls it wraps")
    args = parser.parse_args()
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
    rows = []
    for name in args.scenes:
        path = SCENES / name / f"{name}.obj"
        if not path.exists():
            print(f"skipping {name}: no {path}")
            continue
        vertices, faces = read_obj(path)
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
            for _ in range(args.repeat):
                t_theirs, cpu_theirs, a = timed_with_cpu(query, theirs)
                t_ours, cpu_ours, b = timed_with_cpu(query, ours)
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

    # The CPU ratio is the work ratio (trimesh+embreex runs on one thread, spacebvh on `threads`): on a
    # machine with idle cores for every thread, the wall ratio approaches it times the thread count; on
    # a machine loaded past its cores the threads share the same cores and the wall ratio falls to it.
    print("\nscene           query                 embree Mrays/s  spacebvh Mrays/s  ratio  cpu ratio")
    for name, label, theirs, ours, ratio, cpu_ratio in rows:
        print(f"{name:15s} {label:20s} {theirs:15.3f} {ours:17.3f} {ratio:6.1f}x {cpu_ratio:6.1f}x")


if __name__ == "__main__":
    main()
