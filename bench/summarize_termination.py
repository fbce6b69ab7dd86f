#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Rank correlations for bench/termination_gonogo.sh: does a predictor rank the trees the way the benchmark's
diffuse rays do?

Per scene and kernel, the trees' measured targets are the diffuse rays' child boxes per ray and time per ray
(1 / Mrays/s, fastest of the timed runs), closest hit and occlusion. The predictors are the tree's SAH and
EPO (`build`), and each sample's boxes per ray and cost (boxes + triangles, C_T = C_I = 1) in the same mode
as the target (closest-hit samples for closest-hit targets, any-hit samples for occlusion). Each cell is
Spearman / Kendall (tau-b); 1 means the predictor orders the trees exactly as the target does.
Usage: python3 bench/summarize_termination.py bench/out/termination
"""

import glob
import json
import os
import sys

KERNELS = ("bvh8", "binary")
MODES = ("occlusion", "closest")
SAMPLES = ("bounce", "area")


def ranks(values):
    """Ranks from 1, ties sharing their mean rank."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    result = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            result[order[k]] = (i + j) / 2.0 + 1.0
        i = j + 1
    return result


def spearman(x, y):
    """Pearson correlation of the ranks."""
    rx, ry = ranks(x), ranks(y)
    n = len(x)
    mx, my = sum(rx) / n, sum(ry) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    return sxy / (sxx * syy) ** 0.5 if sxx > 0 and syy > 0 else float("nan")


def kendall(x, y):
    """Kendall's tau-b (ties in either list count for neither side)."""
    concordant = discordant = ties_x = ties_y = 0
    for i in range(len(x)):
        for j in range(i + 1, len(x)):
            dx, dy = x[i] - x[j], y[i] - y[j]
            if dx == 0 and dy == 0:
                continue
            if dx == 0:
                ties_x += 1
            elif dy == 0:
                ties_y += 1
            elif (dx > 0) == (dy > 0):
                concordant += 1
            else:
                discordant += 1
    denominator = ((concordant + discordant + ties_x) * (concordant + discordant + ties_y)) ** 0.5
    return (concordant - discordant) / denominator if denominator > 0 else float("nan")


def load(path):
    with open(path) as f:
        return json.load(f)


def scene_data(directory):
    """{tree: {"build": build json, (kernel, set, mode): stats json, ("time", kernel, mode): ms per Mray}}"""
    trees = {}
    for path in sorted(glob.glob(os.path.join(directory, "build_*.json"))):
        tree = os.path.basename(path)[len("build_") : -len(".json")]
        entry = {"build": load(path)}
        complete = True
        for kernel in KERNELS:
            for mode in MODES:
                for ray_set in ("diffuse",) + SAMPLES:
                    stats = os.path.join(directory, f"stats_{tree}_{kernel}_{ray_set}_{mode}.json")
                    if not os.path.exists(stats):
                        complete = False
                        continue
                    entry[(kernel, ray_set, mode)] = load(stats)
                times = [
                    load(p) for p in glob.glob(os.path.join(directory, f"time_{tree}_{kernel}_diffuse_{mode}_*.json"))
                ]
                if times:
                    fastest = min(times, key=lambda t: t["trace_ms"])
                    entry[("time", kernel, mode)] = fastest["trace_ms"] * 1e6 / fastest["rays"]  # ms per million rays
        if complete:
            trees[tree] = entry
    return trees


def fmt_pair(x, y):
    return f"{spearman(x, y):.2f} / {kendall(x, y):.2f}"


def main(root):
    scenes = sorted(d for d in os.listdir(root) if os.path.isdir(os.path.join(root, d)))
    order = ["bunny", "sibenik", "coffee_maker", "crytek_sponza", "living_room_3"]
    scenes.sort(key=lambda s: order.index(s) if s in order else len(order))
    data = {scene: scene_data(os.path.join(root, scene)) for scene in scenes}
    data = {scene: trees for scene, trees in data.items() if len(trees) >= 3}

    print("## Trees: quality and what each ray set costs them (child boxes per ray; BVH8 kernel, binary in brackets)")
    print()
    print(
        "| scene | tree | build ms | SAH | EPO | diffuse occl. boxes | diffuse closest boxes | bounce occl. boxes |"
        " bounce closest boxes | area occl. boxes | area closest boxes | diffuse occl. Mrays/s |"
        " diffuse closest Mrays/s |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scene, trees in data.items():
        for tree, entry in trees.items():
            build = entry["build"]
            cells = []
            for ray_set in ("diffuse",) + SAMPLES:
                for mode in MODES:
                    cells.append(
                        "{:.2f} ({:.2f})".format(
                            entry[("bvh8", ray_set, mode)]["nodes_per_ray"],
                            entry[("binary", ray_set, mode)]["nodes_per_ray"],
                        )
                    )
            for mode in MODES:
                speeds = [
                    "%.1f" % (1000.0 / entry[("time", kernel, mode)]) if ("time", kernel, mode) in entry else "-"
                    for kernel in KERNELS
                ]
                cells.append("{} ({})".format(*tuple(speeds)))
            print(
                "| {} | {} | {:.0f} | {:.2f} | {:.3f} | {} |".format(
                    scene, tree, build["build_ms"], build["sah"], build.get("epo", float("nan")), " | ".join(cells)
                )
            )
    print()

    predictors = [
        ("SAH", lambda e, k, m: e["build"]["sah"]),
        ("EPO", lambda e, k, m: e["build"].get("epo", float("nan"))),
    ]
    for sample in SAMPLES:
        predictors.append((f"{sample} boxes", lambda e, k, m, s=sample: e[(k, s, m)]["nodes_per_ray"]))
        predictors.append(
            (
                f"{sample} boxes+tris",
                lambda e, k, m, s=sample: e[(k, s, m)]["nodes_per_ray"] + e[(k, s, m)]["triangles_per_ray"],
            )
        )
    targets = [
        ("boxes", lambda e, k, m: e[(k, "diffuse", m)]["nodes_per_ray"]),
        ("time", lambda e, k, m: e.get(("time", k, m), float("nan"))),
    ]

    print("## Rank correlation with the diffuse rays (Spearman / Kendall tau-b, over the trees of each scene)")
    print()
    print("| scene | trees | kernel | mode | target | " + " | ".join(name for name, _ in predictors) + " |")
    print("|---|---:|---|---|---|" + "---:|" * len(predictors))
    summary = {}
    for scene, trees in data.items():
        entries = list(trees.values())
        for kernel in KERNELS:
            for mode in MODES:
                for target_name, target in targets:
                    y = [target(e, kernel, mode) for e in entries]
                    if any(v != v for v in y):
                        continue
                    cells = []
                    for name, predictor in predictors:
                        x = [predictor(e, kernel, mode) for e in entries]
                        cells.append(fmt_pair(x, y))
                        summary.setdefault((kernel, mode, target_name, name), []).append(spearman(x, y))
                    print(f"| {scene} | {len(entries)} | {kernel} | {mode} | {target_name} | {' | '.join(cells)} |")
    print()
    print("## Mean Spearman over the scenes")
    print()
    print("| kernel | mode | target | " + " | ".join(name for name, _ in predictors) + " |")
    print("|---|---|---|" + "---:|" * len(predictors))
    for kernel in KERNELS:
        for mode in MODES:
            for target_name, _ in targets:
                cells = []
                for name, _ in predictors:
                    values = [v for v in summary.get((kernel, mode, target_name, name), []) if v == v]
                    cells.append(f"{sum(values) / len(values):.2f} ({len(values)})" if values else "-")
                print("| {} | {} | {} | {} |".format(kernel, mode, target_name, " | ".join(cells)))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "bench/out/termination")
