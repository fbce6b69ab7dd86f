#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The best-trees ratio table from `spacebvh compare --json` files (bench/best_shared_scenes.sh).

Per scene and ray kind: our fastest row (any builder, any kernel) / Embree HIGH rtcIntersect1 or
rtcOccluded1, next to the goal max(1.0, tinybvh / Embree at 2 threads from
../shared/research/peers-measured.md); and our best packet row / Embree HIGH rtcIntersect16 on
primary rays (goal 1.0). Each ratio comes from one compare run per scene (rows side by side); given
several runs (directories), each cell is the median of its per-run ratios.
"""
import glob
import json
import os
import sys

# tinybvh / Embree HIGH, 2 threads (../shared/research/peers-measured.md): random, random occl.,
# primary, primary occl., diffuse, diffuse occl. Scenes it does not list have goal 1.0.
PEER_RATIOS = {
    "crytek_sponza": (0.97, 0.89, 0.96, 1.02, 0.78, 0.60),
    "crytek_sponza_rotated": (0.90, 0.70, 0.92, 0.71, 0.84, 0.50),
    "living_room_3": (1.10, 0.94, 1.41, 1.74, 1.03, 0.85),
    "coffee_maker": (1.21, 1.13, 1.58, 1.73, 1.18, 1.13),
}
COLUMNS = [(kind, field) for kind in ("random", "primary", "diffuse") for field in ("closest_mrays", "occlusion_mrays")]


def ratios(path):
    """One run of one scene: (scene, [(ratio, tree, kernel) per column], packet ratio, (our wrong answers,
    Embree's wrong answers))."""
    data = json.load(open(path))
    scene = data["scenes"][0]
    name = os.path.basename(path).removeprefix("best_").removesuffix(".json")
    rows = scene["rows"]
    ours = [r for r in rows if not r["builder"].startswith("embree")]
    single = next(r for r in rows if r["builder"] == "embree-high" and "Intersect1/" in r["kernel"])
    packets = next(r for r in rows if r["builder"] == "embree-high" and "Intersect16" in r["kernel"])
    cells = []
    for kind, field in COLUMNS:
        best = max(ours, key=lambda r: r[kind][field])
        cells.append((best[kind][field] / single[kind][field], best["builder"].split(" ")[0], best[kind]["kernel"]))
    packet_rows = [r for r in ours if r["kernel"].startswith("packet")]
    best_packet = max(packet_rows, key=lambda r: r["primary"]["closest_mrays"])
    packet_ratio = best_packet["primary"]["closest_mrays"] / packets["primary"]["closest_mrays"]
    def wrong_in(selected):
        return sum(r[kind].get("wrong", 0) for r in selected for kind in ("random", "primary", "diffuse"))
    embree = [r for r in rows if r["builder"].startswith("embree")]
    return name, cells, packet_ratio, (wrong_in(ours), wrong_in(embree))


def table_row(runs):
    """Runs of one scene: each cell is the median ratio over the runs (each ratio measured within one
    run), with the tree and kernel of the median run and, for several runs, the range."""
    name = runs[0][0]
    goals = PEER_RATIOS.get(name, (1.0,) * 6)
    cells = []
    for column, peer in enumerate(goals):
        ordered = sorted(run[1][column] for run in runs)
        ratio, tree, kernel = ordered[len(ordered) // 2]
        spread = f", runs {ordered[0][0]:.2f}-{ordered[-1][0]:.2f}" if len(runs) > 1 else ""
        cells.append(f"{ratio:.2f} ({tree}, {kernel}; goal {max(1.0, peer):.2f}{spread})")
    packet = sorted(run[2] for run in runs)
    packet_cell = f"{packet[len(packet) // 2]:.2f}" + (f" ({packet[0]:.2f}-{packet[-1]:.2f})" if len(runs) > 1 else "")
    ours = sum(run[3][0] for run in runs)
    embree = sum(run[3][1] for run in runs)
    return f"| {name} | " + " | ".join(cells) + f" | {packet_cell} | {ours} | {embree} |"


# Arguments: JSON files (one run) or directories (one run each, holding best_SCENE.json files).
paths = sys.argv[1:]
if all(os.path.isdir(p) for p in paths):
    by_scene = {}
    for directory in paths:
        for file in sorted(glob.glob(os.path.join(directory, "best_*.json"))):
            run = ratios(file)
            by_scene.setdefault(run[0], []).append(run)
    order = ["bunny", "sibenik", "coffee_maker", "crytek_sponza", "living_room_3", "crytek_sponza_rotated"]
    groups = [by_scene[name] for name in order if name in by_scene]
else:
    groups = [[ratios(path)] for path in paths]
print(f"{len(groups[0]) if groups else 0} run(s); cell = median over runs of our fastest row / Embree HIGH single rays")
print()
print("| scene | random closest | random occl. | primary closest | primary occl. | diffuse closest | diffuse occl. |"
      " packets / rtcIntersect16 (primary) | our wrong answers | Embree's wrong answers |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
for runs in groups:
    print(table_row(runs))
