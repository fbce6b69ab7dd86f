# SPDX-License-Identifier: MIT
"""Two builds of the Python package side by side on the exact queries (RayQueries and Tracer64).

  answers: every query (first, first_primitive, any, all, count, contains, Tracer64 intersect and
           occluded) on the same rays and points through both builds, each in its own process;
           exit status 1 unless every array is identical, bit for bit.
  speed:   RayQueries' batch queries timed through both builds, interleaved run by run (old, new,
           new, old, ...), one fresh process per run timing each query `repeat` times; prints the
           median over runs of the best wall and CPU seconds, and new / old.

A build is named by its Python interpreter, optionally with a folder to put first on PYTHONPATH:
PYTHON or PYTHON@DIR (a plain CMake build with -DSPACEBVH_BUILD_PYTHON=ON lays the package out in
build/python). Scenes are paths or builtin:NAME.

  python3 bench/queries_ab.py answers --old base/venv/bin/python --new build/venv/bin/python \\
      ../shared/scenes/bunny/bunny.obj --rays 200000
  python3 bench/queries_ab.py speed --old ... --new ... SCENE --rays 1000000 --runs 5 --threads 2
"""

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

QUERIES = ["first", "any", "count", "contains", "all"]


def rays_and_points(triangles, count, seed, mixed=True):
    """Random rays around the mesh over [0, inf); mixed: a tenth of them axis-aligned, a tenth starting
    past 0, a tenth ending short of inf (Python refuses a negative tmin, so RayQueries' binary layout
    is left to the C++ tests). And points in and around the mesh's box, a tenth of them mesh vertices."""
    import numpy as np

    rng = np.random.default_rng(seed)
    lo, hi = triangles.min(axis=(0, 1)).astype(np.float64), triangles.max(axis=(0, 1)).astype(np.float64)
    extent = hi - lo
    reach = float(np.linalg.norm(extent))
    origins = (lo - 0.2 * extent + 1.4 * extent * rng.random((count, 3))).astype(np.float32)
    directions = rng.normal(size=(count, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    directions = directions.astype(np.float32)
    kind = rng.integers(0, 10, count) if mixed else np.zeros(count, dtype=np.int64)
    axis = rng.integers(0, 3, count)
    aligned = kind == 7
    directions[aligned] = 0.0
    directions[aligned, axis[aligned]] = np.where(rng.random(int(aligned.sum())) < 0.5, -1.0, 1.0)
    tmin = np.zeros(count)
    tmax = np.full(count, np.inf)
    tmin[kind == 8] = 0.1 * reach
    tmax[kind == 8] = 0.5 * reach
    tmax[kind == 9] = 0.3 * reach
    points = (lo - 0.2 * extent + 1.4 * extent * rng.random((count, 3))).astype(np.float32)
    vertices = triangles.reshape(-1, 3)
    on_mesh = rng.random(count) < 0.1
    points[on_mesh] = vertices[rng.integers(0, len(vertices), int(on_mesh.sum()))]
    return origins, directions, tmin.astype(np.float32), tmax.astype(np.float32), points


def worker_answers(scene_source, builders, count, seed, threads, out):
    import numpy as np

    import spacebvh

    scene = spacebvh.load_scene(scene_source)
    triangles = scene.triangles()
    origins, directions, tmin, tmax, points = rays_and_points(triangles, count, seed)
    arrays = {}
    for builder in builders:
        queries = spacebvh.RayQueries(spacebvh.build(scene, builder), threads=threads)
        for name, value in zip(["t", "primitive", "u", "v", "points"], queries.first(origins, directions, tmin, tmax)):
            arrays[f"{builder}.first.{name}"] = value
        arrays[f"{builder}.first_primitive"] = queries.first_primitive(origins, directions, tmin, tmax)
        arrays[f"{builder}.any"] = queries.any(origins, directions, tmin, tmax)
        names = ["ray", "primitive", "t", "u", "v", "points"]
        for name, value in zip(names, queries.all(origins, directions, tmin, tmax)):
            arrays[f"{builder}.all.{name}"] = value
        arrays[f"{builder}.count"] = queries.count(origins, directions, tmin, tmax)
        arrays[f"{builder}.contains"] = queries.contains(points)
    vertices = triangles.reshape(-1, 3).astype(np.float64)
    faces = np.arange(len(vertices), dtype=np.int64).reshape(-1, 3)
    tracer = spacebvh.Tracer64(vertices, faces, builder=builders[0], threads=threads)
    o64, d64 = origins.astype(np.float64), directions.astype(np.float64)
    t64, tmax64 = tmin.astype(np.float64), tmax.astype(np.float64)
    for name, value in zip(["t", "primitive", "u", "v"], tracer.intersect(o64, d64, t64, tmax64)):
        arrays[f"float64.intersect.{name}"] = value
    arrays["float64.occluded"] = tracer.occluded(o64, d64, t64, tmax64)
    np.savez(out, **arrays)
    print(spacebvh.__file__, file=sys.stderr)


def worker_speed(scene_source, builder, count, seed, threads, queries_wanted, repeat):
    import spacebvh

    scene = spacebvh.load_scene(scene_source)
    origins, directions, _, _, points = rays_and_points(scene.triangles(), count, seed, mixed=False)
    queries = spacebvh.RayQueries(spacebvh.build(scene, builder), threads=threads)
    warm = slice(0, max(1, count // 100))
    calls = {
        "first": lambda part: queries.first(origins[part], directions[part]),
        "any": lambda part: queries.any(origins[part], directions[part]),
        "count": lambda part: queries.count(origins[part], directions[part]),
        "contains": lambda part: queries.contains(points[part]),
        "all": lambda part: queries.all(origins[part], directions[part]),
    }
    seconds = {}
    for name in queries_wanted:
        calls[name](warm)  # first touches of the layout
        # The best of `repeat` calls: other processes can only add time. Wall seconds, and the CPU
        # seconds of all the process's threads (less sensitive to other processes taking the cores).
        best = (math.inf, math.inf)
        for _ in range(repeat):
            wall, cpu = time.perf_counter(), time.process_time()
            calls[name](slice(None))
            best = (min(best[0], time.perf_counter() - wall), min(best[1], time.process_time() - cpu))
        seconds[name] = best
    print(json.dumps(seconds))


def run_side(side, arguments):
    python, _, path = side.partition("@")
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = os.path.abspath(path) + os.pathsep + env.get("PYTHONPATH", "")
    command = [python, os.path.abspath(__file__), "worker"] + arguments
    return subprocess.run(command, env=env, check=True, stdout=subprocess.PIPE, text=True).stdout


def compare_answers(args):
    import numpy as np

    failures = 0
    for scene in args.scenes:
        with tempfile.TemporaryDirectory() as folder:
            files = {}
            for label, side in (("old", args.old), ("new", args.new)):
                files[label] = os.path.join(folder, label + ".npz")
                run_side(
                    side,
                    ["answers", scene, args.builders, str(args.rays), str(args.seed), str(args.threads), files[label]],
                )
            old, new = np.load(files["old"]), np.load(files["new"])
            differ = sorted(set(old.files) ^ set(new.files))
            for key in sorted(set(old.files) & set(new.files)):
                a, b = old[key], new[key]
                # Bitwise: NaN points of misses compare equal, -0.0 and 0.0 do not.
                if a.dtype != b.dtype or a.shape != b.shape or a.tobytes() != b.tobytes():
                    differ.append(key)
            hits = int((old[args.builders.split(",")[0] + ".first.primitive"] >= 0).sum())
            total = sum(int(old[key].size) for key in old.files)
            status = "identical" if not differ else "DIFFERENT: " + ", ".join(differ)
            print(f"{scene}: {len(old.files)} arrays, {total} values, {hits} first hits of {args.rays} rays: {status}")
            failures += bool(differ)
    return 1 if failures else 0


def compare_speed(args):
    for scene in args.scenes:
        wanted = args.queries.split(",")
        times = {label: {q: ([], []) for q in wanted} for label in ("old", "new")}
        for run in range(args.runs):
            # Interleaved, alternating which goes first: drift of a shared machine slows both alike.
            order = ("old", "new") if run % 2 == 0 else ("new", "old")
            for label in order:
                side = args.old if label == "old" else args.new
                out = run_side(
                    side,
                    [
                        "speed",
                        scene,
                        args.builders.split(",")[0],
                        str(args.rays),
                        str(args.seed),
                        str(args.threads),
                        args.queries,
                        str(args.repeat),
                    ],
                )
                for query, (wall, cpu) in json.loads(out.strip().splitlines()[-1]).items():
                    times[label][query][0].append(wall)
                    times[label][query][1].append(cpu)
        print(
            f"{scene} ({args.rays} rays, {args.threads} threads, median over {args.runs} runs of the best of "
            f"{args.repeat}):"
        )
        print("| query | old wall s | new wall s | new / old | old CPU s | new CPU s | new / old |")
        print("|---|---|---|---|---|---|---|")
        for query in wanted:
            old = [statistics.median(samples) for samples in times["old"][query]]
            new = [statistics.median(samples) for samples in times["new"][query]]
            print(
                f"| {query} | {old[0]:.3f} | {new[0]:.3f} | {new[0] / old[0]:.3f} "
                f"| {old[1]:.3f} | {new[1]:.3f} | {new[1] / old[1]:.3f} |"
            )
        sys.stdout.flush()
    return 0


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "worker":
        kind, rest = sys.argv[2], sys.argv[3:]
        if kind == "answers":
            worker_answers(rest[0], rest[1].split(","), int(rest[2]), int(rest[3]), int(rest[4]), rest[5])
        else:
            worker_speed(rest[0], rest[1], int(rest[2]), int(rest[3]), int(rest[4]), rest[5].split(","), int(rest[6]))
        return 0
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("mode", choices=["answers", "speed"])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--old", required=True, help="PYTHON or PYTHON@DIR of the build compared against")
    parser.add_argument("--new", required=True, help="PYTHON or PYTHON@DIR of the build under test")
    parser.add_argument("--rays", type=int, default=200000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--runs", type=int, default=5, help="speed: processes per build, interleaved")
    parser.add_argument("--repeat", type=int, default=3, help="speed: timed calls per process (the best counts)")
    parser.add_argument("--builders", default="binned,spatial", help="trees of the answers (speed: the first)")
    parser.add_argument("--queries", default=",".join(QUERIES), help="speed: the queries timed")
    args = parser.parse_args()
    return compare_answers(args) if args.mode == "answers" else compare_speed(args)


if __name__ == "__main__":
    sys.exit(main())
