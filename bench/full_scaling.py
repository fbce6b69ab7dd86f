#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Build time of a builder versus N on growing subsets of a scene, with the fitted exponent.

Subsets keep every k-th triangle of the OBJ (so each has the whole scene's spatial spread), for
k = 1, 2, 4, ... until N falls below --min-triangles. Each subset is built with `spacebvh build
--no-epo --json` (the median of --runs builds) and the exponent is the least-squares slope of
log(build ms) against log(N).

  python3 bench/full_scaling.py ../shared/scenes/crytek_sponza/crytek_sponza.obj --builder full --threads 2
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile


def read_obj(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vertices.append(line)
            elif line.startswith("f "):
                faces.append([int(token.split("/")[0]) for token in line.split()[1:]])
    return vertices, faces


def write_subset(path, vertices, faces, stride):
    with open(path, "w") as out:
        out.writelines(vertices)
        for face in faces[::stride]:
            out.write("f " + " ".join(str(i) for i in face) + "\n")
    return len(faces[::stride])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("scene")
    parser.add_argument("--builder", default="full")
    parser.add_argument("--threads", default="2")
    parser.add_argument("--min-triangles", type=int, default=8000)
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--spacebvh", default=os.path.join(os.path.dirname(__file__), "..", "build", "spacebvh"))
    parser.add_argument("extra", nargs="*", help="more options for spacebvh build (after --)")
    args = parser.parse_args()
    vertices, faces = read_obj(args.scene)
    points = []
    with tempfile.TemporaryDirectory() as directory:
        stride = 1
        while len(faces) // stride >= args.min_triangles:
            subset = os.path.join(directory, f"subset_{stride}.obj")
            count = write_subset(subset, vertices, faces, stride)
            times = []
            for _ in range(args.runs):
                report = os.path.join(directory, "report.json")
                subprocess.run(
                    [
                        args.spacebvh,
                        "build",
                        subset,
                        "--builder",
                        args.builder,
                        "--threads",
                        args.threads,
                        "--no-epo",
                        "--quiet",
                        "--json",
                        report,
                    ]
                    + args.extra,
                    check=True,
                    stdout=subprocess.DEVNULL,
                )
                with open(report) as f:
                    times.append(json.load(f)["build_ms"])
            times.sort()
            points.append((count, times[len(times) // 2]))
            print(f"{count:>9} triangles  {points[-1][1]:>10.1f} ms", flush=True)
            stride *= 2
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(t) for _, t in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    slope = sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)
    print(
        f"fitted exponent (build ms ~ N^e) over N = {points[-1][0]}..{points[0][0]} "
        f"({points[0][0] / points[-1][0]:.0f}x): e = {slope:.2f}"
    )


if __name__ == "__main__":
    sys.exit(main())
