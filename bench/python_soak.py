# SPDX-License-Identifier: MIT
"""Python soak: many threads call the extension at once for minutes; prints the calls made, the
answers that differ from a single-threaded reference, and the resident memory over time.

Every worker repeats, on random slices of one ray pool: Tracer.intersect / occluded, RayQueries
first / any / count / all / contains, building a small tree now and then, with its own thread limit
(1 or 2). Each answer is compared with the reference computed once, alone, before the workers start
(the C++ tests check the references themselves against the exact arbiter). Resident memory is
sampled every few seconds; over the second half of the run it must stay flat (no leak).

Usage: python3 bench/python_soak.py [--minutes 5] [--threads 8] [--scene builtin:NAME or a file]
(with the spacebvh package installed; exits 1 on any wrong answer, error, or growth of resident
memory beyond --rss-growth).
"""

import argparse
import random
import sys
import threading
import time

import numpy as np

import spacebvh


def resident_mib() -> float:
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=5.0)
    parser.add_argument("--threads", type=int, default=8, help="Python threads calling at once")
    parser.add_argument("--scene", default="builtin:" + spacebvh.builtin_scenes()[0])
    parser.add_argument("--rays", type=int, default=200_000, help="size of the ray pool")
    parser.add_argument("--batch", type=int, default=20_000, help="largest batch of one call")
    parser.add_argument("--calls", default="", help="comma-separated subset of the calls (default: all)")
    parser.add_argument("--rss-growth", type=float, default=0.05, help="allowed growth over the second half of the run")
    return parser.parse_args()


def mismatches(got, want) -> int:
    """Answers of `got` that differ from `want` (arrays, or tuples of arrays compared element by element;
    NaN equals NaN)."""
    if not isinstance(want, tuple):
        return int(np.count_nonzero(got != want))
    bad = np.zeros(len(want[0]), dtype=bool)
    for g, w in zip(got, want):
        bad |= ~((g == w) | (np.isnan(g) & np.isnan(w)) if g.dtype.kind == "f" else (g == w))
    return int(np.count_nonzero(bad))


def main() -> int:
    args = parse_args()

    scene = spacebvh.load_scene(args.scene)
    bvh = spacebvh.build(scene, "spatial")
    tracer = spacebvh.Tracer(bvh)
    queries = spacebvh.RayQueries(bvh)
    origins, directions = spacebvh.random_rays(scene, args.rays, seed=7)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in scene.bounds)
    points = np.random.default_rng(3).uniform(lo, hi, size=(args.rays, 3))

    reference = {
        "intersect": tracer.intersect(origins, directions, threads=1)[:2],
        "occluded": tracer.occluded(origins, directions, threads=1),
        "first": queries.first(origins, directions, threads=1)[:2],
        "any": queries.any(origins, directions, threads=1),
        "count": queries.count(origins, directions, threads=1),
        "contains": queries.contains(points, threads=1),
    }
    # A small mesh (the first triangles of the scene) that workers build trees of; each tree must
    # equal the one built alone (the same SAH and node count whatever the thread count).
    corners = scene.triangles()[:2000].reshape(-1, 3)
    small_scene = spacebvh.mesh(corners, np.arange(len(corners), dtype=np.int64).reshape(-1, 3))
    small_builders = ["binned", "cbvh", "spatial"]
    small_trees = {
        b: (t.sah, t.node_count) for b in small_builders for t in [spacebvh.build(small_scene, b, threads=1)]
    }

    def answer(name, part, threads):
        o, d = origins[part], directions[part]
        if name == "intersect":
            return tracer.intersect(o, d, threads=threads)[:2]
        if name == "occluded":
            return tracer.occluded(o, d, threads=threads)
        if name == "first":
            return queries.first(o, d, threads=threads)[:2]
        if name == "any":
            return queries.any(o, d, threads=threads)
        if name == "count":
            return queries.count(o, d, threads=threads)
        return queries.contains(points[part], threads=threads)

    def expected(name, part):
        value = reference[name]
        return tuple(v[part] for v in value) if isinstance(value, tuple) else value[part]

    kinds = [*reference, "all", "build"]
    if args.calls:
        unknown = set(args.calls.split(",")) - set(kinds)
        if unknown:
            raise SystemExit(f"--calls: unknown {sorted(unknown)}; known: {kinds}")
        kinds = args.calls.split(",")
    calls = [0] * args.threads
    wrong = [0] * args.threads
    errors: list = []
    stop = time.monotonic() + 60.0 * args.minutes

    def worker(index: int) -> None:
        rng = random.Random(index)
        try:
            while time.monotonic() < stop:
                name = rng.choice(kinds)
                start = rng.randrange(args.rays)
                part = slice(start, min(args.rays, start + rng.randint(1, args.batch)))
                threads = rng.choice([1, 2])
                if name == "build":
                    builder = rng.choice(small_builders)
                    tree = spacebvh.build(small_scene, builder, threads=threads)
                    wrong[index] += int((tree.sah, tree.node_count) != small_trees[builder])
                elif name == "all":
                    index_ray, _prim, _t, _u, _v, _p = queries.all(origins[part], directions[part], threads=threads)
                    counts = np.bincount(index_ray, minlength=part.stop - part.start)
                    wrong[index] += int(np.count_nonzero(counts != reference["count"][part]))
                else:
                    wrong[index] += mismatches(answer(name, part, threads), expected(name, part))
                calls[index] += 1
        except Exception as error:  # reported, and the soak fails
            errors.append(f"worker {index}: {type(error).__name__}: {error}")

    workers = [threading.Thread(target=worker, args=(i,)) for i in range(args.threads)]
    for w in workers:
        w.start()
    samples = []
    begin = time.monotonic()
    while any(w.is_alive() for w in workers):
        time.sleep(min(5.0, max(0.5, args.minutes * 60.0 / 50.0)))
        samples.append((time.monotonic() - begin, resident_mib()))
    for w in workers:
        w.join()

    # The allocator's arenas (one per thread) fill up during the first half; a leak keeps growing
    # through the second, so growth is measured from the middle of the run to its end.
    warm = samples[len(samples) // 2] if samples else (0.0, float("nan"))
    last = samples[-1] if samples else (0.0, float("nan"))
    growth = (last[1] - warm[1]) / warm[1] if warm[1] else 0.0
    print(f"scene {args.scene}: {scene.triangle_count} triangles, {args.threads} threads, {args.minutes} min")
    print(f"calls {sum(calls)}, wrong answers {sum(wrong)}, errors {len(errors)}")
    print(
        f"resident MiB: at {warm[0]:.0f} s {warm[1]:.1f}, end {last[1]:.1f}, max {max(s[1] for s in samples):.1f}, "
        f"growth over the second half {100.0 * growth:+.2f} %"
    )
    print("samples (s: MiB): " + ", ".join(f"{s:.0f}: {m:.0f}" for s, m in samples[:: max(1, len(samples) // 10)]))
    for message in errors[:10]:
        print(message)
    return 1 if sum(wrong) or errors or growth > args.rss_growth else 0


if __name__ == "__main__":
    sys.exit(main())
