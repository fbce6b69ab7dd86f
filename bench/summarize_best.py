#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Ratio tables from `spacebvh compare --json` files: our fastest row against Embree HIGH.

Default (bench/best_shared_scenes.sh): per scene and ray kind, our fastest row (any builder, any
kernel) / Embree HIGH rtcIntersect1 or rtcOccluded1, next to the goal max(1.0, tinybvh / Embree at 2
threads from ../shared/research/peers-measured.md); and our best packet row / Embree HIGH
rtcIntersect16 on primary rays (goal 1.0).

--embree-kernels (bench/embree_ratio_shared_scenes.sh): each ray kind against Embree HIGH's own
kernel for it, goal 1.0 everywhere: random and diffuse rays against rtcIntersect1/rtcOccluded1,
primary rays against rtcIntersect16/rtcOccluded16; with the wrong answers of each scene's rows.

Each ratio comes from one compare run per scene (rows side by side); given several runs
(directories), each cell is the median of its per-run ratios.
Usage: summarize_best.py [--embree-kernels] [--prefix P] FILE.json... | DIR...   (P: file prefix, default best)
"""

import argparse
import glob
import json
import os

# tinybvh / Embree HIGH, 2 threads (../shared/research/peers-measured.md): random, random occl.,
# primary, primary occl., diffuse, diffuse occl. Scenes it does not list have goal 1.0.
PEER_RATIOS = {
    "crytek_sponza": (0.97, 0.89, 0.96, 1.02, 0.78, 0.60),
    "crytek_sponza_rotated": (0.90, 0.70, 0.92, 0.71, 0.84, 0.50),
    "living_room_3": (1.10, 0.94, 1.41, 1.74, 1.03, 0.85),
    "coffee_maker": (1.21, 1.13, 1.58, 1.73, 1.18, 1.13),
}
COLUMNS = [(kind, field) for kind in ("random", "primary", "diffuse") for field in ("closest_mrays", "occlusion_mrays")]
SCENE_ORDER = ["bunny", "sibenik", "coffee_maker", "crytek_sponza", "living_room_3", "crytek_sponza_rotated"]


def ratios(path, prefix, embree_kernels):
    """One run of one scene: (scene, [(ratio, tree, kernel) per column], packet ratio, (our wrong answers,
    Embree's wrong answers))."""
    data = json.load(open(path))
    scene = data["scenes"][0]
    name = os.path.basename(path).removeprefix(prefix + "_").removesuffix(".json")
    rows = scene["rows"]
    ours = [r for r in rows if not r["builder"].startswith("embree")]
    single = next(r for r in rows if r["builder"] == "embree-high" and "Intersect1/" in r["kernel"])
    packets = next(r for r in rows if r["builder"] == "embree-high" and "Intersect16" in r["kernel"])
    cells = []
    for kind, field in COLUMNS:
        embree = packets if embree_kernels and kind == "primary" else single
        best = max(ours, key=lambda r: r[kind][field])
        cells.append((best[kind][field] / embree[kind][field], best["builder"].split(" ")[0], best[kind]["kernel"]))
    packet_rows = [r for r in ours if r["kernel"].startswith("packet")]
    packet_ratio = None
    if packet_rows:
        best_packet = max(packet_rows, key=lambda r: r["primary"]["closest_mrays"])
        packet_ratio = best_packet["primary"]["closest_mrays"] / packets["primary"]["closest_mrays"]

    def wrong_in(selected):
        return sum(r[kind].get("wrong", 0) for r in selected for kind in ("random", "primary", "diffuse"))

    embree = [r for r in rows if r["builder"].startswith("embree")]
    return name, cells, packet_ratio, (wrong_in(ours), wrong_in(embree))


def median_cell(runs, column):
    """The median over runs of one column's ratio, with the tree and kernel of the median run."""
    ordered = sorted(run[1][column] for run in runs)
    ratio, tree, kernel = ordered[len(ordered) // 2]
    spread = f", runs {ordered[0][0]:.2f}-{ordered[-1][0]:.2f}" if len(runs) > 1 else ""
    return ratio, tree, kernel, spread


def table_row(runs, embree_kernels):
    """Runs of one scene: each cell is the median ratio over the runs (each ratio measured within one
    run), with the tree and kernel of the median run and, for several runs, the range."""
    name = runs[0][0]
    goals = (1.0,) * 6 if embree_kernels else PEER_RATIOS.get(name, (1.0,) * 6)
    cells = []
    for column, peer in enumerate(goals):
        ratio, tree, kernel, spread = median_cell(runs, column)
        goal = max(1.0, peer)
        if embree_kernels:
            mark = "**" if ratio < goal else ""
            cells.append(f"{mark}{ratio:.2f}{mark} ({tree}, {kernel}{spread})")
        else:
            cells.append(f"{ratio:.2f} ({tree}, {kernel}; goal {goal:.2f}{spread})")
    ours = sum(run[3][0] for run in runs)
    embree = sum(run[3][1] for run in runs)
    if embree_kernels:
        return f"| {name} | " + " | ".join(cells) + f" | {ours} | {embree} |"
    packet = sorted(run[2] for run in runs if run[2] is not None)
    packet_cell = (
        f"{packet[len(packet) // 2]:.2f}" + (f" ({packet[0]:.2f}-{packet[-1]:.2f})" if len(runs) > 1 else "")
        if packet
        else "-"
    )
    return f"| {name} | " + " | ".join(cells) + f" | {packet_cell} | {ours} | {embree} |"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--embree-kernels",
        action="store_true",
        help="primary rays against rtcIntersect16/rtcOccluded16, the rest against rtcIntersect1/rtcOccluded1, goal 1.0",
    )
    parser.add_argument("--prefix", default="best", help="JSON file prefix: PREFIX_SCENE.json")
    parser.add_argument("paths", nargs="+", help="JSON files (one run) or directories (one run each)")
    args = parser.parse_args()
    if all(os.path.isdir(p) for p in args.paths):
        by_scene = {}
        for directory in args.paths:
            for file in sorted(glob.glob(os.path.join(directory, f"{args.prefix}_*.json"))):
                run = ratios(file, args.prefix, args.embree_kernels)
                by_scene.setdefault(run[0], []).append(run)
        groups = [by_scene[name] for name in SCENE_ORDER if name in by_scene]
    else:
        groups = [[ratios(path, args.prefix, args.embree_kernels)] for path in args.paths]
    runs = len(groups[0]) if groups else 0
    if args.embree_kernels:
        print(
            f"{runs} run(s); cell = median over runs of our fastest row / Embree HIGH's kernel for the ray kind "
            "(rtcIntersect1/rtcOccluded1; primary: rtcIntersect16/rtcOccluded16), bold below 1.0"
        )
        print()
        print(
            "| scene | random closest | random occl. | primary closest (/ rtcIntersect16) |"
            " primary occl. (/ rtcOccluded16) | diffuse closest | diffuse occl. | our wrong answers"
            " | Embree's wrong answers |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    else:
        print(f"{runs} run(s); cell = median over runs of our fastest row / Embree HIGH single rays")
        print()
        print(
            "| scene | random closest | random occl. | primary closest | primary occl. | diffuse closest |"
            " diffuse occl. | packets / rtcIntersect16 (primary) | our wrong answers | Embree's wrong answers |"
        )
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for scene_runs in groups:
        print(table_row(scene_runs, args.embree_kernels))


if __name__ == "__main__":
    main()
