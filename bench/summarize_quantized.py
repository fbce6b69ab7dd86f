#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Tables of bench/quantized_nodes_shared_scenes.sh from its `compare --json` files.

Per scene and ray kind (random, diffuse): bvh8q / bvh8, bvh8q / Embree HIGH (rtcIntersect1 and
rtcOccluded1), bvh8 / Embree HIGH and bvh8q+moller / bvh8+moller, closest hit and occlusion, each the
median of its per-run ratios over the directories given (one compare run per scene and directory);
the wrong answers of our rows; then every layout's bytes per triangle (nodes + leaf triangle data;
Embree: what its commit allocated), from the first directory.
Usage: summarize_quantized.py DIR...   (each holding quantized_STEM.json)
"""

import glob
import json
import os
import statistics
import sys

LAYOUTS = ["binary", "bvh4", "bvh4+moller", "bvh8", "bvh8+moller", "bvh8q", "bvh8q+moller"]
PAIRS = [("bvh8q", "bvh8"), ("bvh8q", "embree"), ("bvh8", "embree"), ("bvh8q+moller", "bvh8+moller")]


def by_layout(path):
    """A scene's rows keyed by layout ("bvh8q+moller": the node test dropped), Embree's as "embree"."""
    rows = {}
    for row in json.load(open(path))["scenes"][0]["rows"]:
        if row["builder"].startswith("embree"):
            rows["embree"] = row
            continue
        kernel = row["kernel"]
        base, _, leaf = kernel.partition("+")
        rows[base.split("-")[0] + ("+" + leaf if leaf else "")] = row
    return rows


def main(dirs):
    stems = sorted(
        {
            os.path.basename(p)[len("quantized_") : -len(".json")]
            for p in glob.glob(os.path.join(dirs[0], "quantized_*.json"))
        }
    )
    header = [f"{a} / {b} {what}" for a, b in PAIRS for what in ("closest", "occl.")]
    print("| scene | rays | " + " | ".join(header) + " |")
    print("|---|---|" + "---:|" * len(header))
    wrong = 0
    for stem in stems:
        runs = [by_layout(os.path.join(d, f"quantized_{stem}.json")) for d in dirs]
        for kind in ("random", "diffuse"):
            cells = []
            for a, b in PAIRS:
                for measure in ("closest_mrays", "occlusion_mrays"):
                    ratios = [run[a][kind][measure] / run[b][kind][measure] for run in runs if a in run and b in run]
                    cells.append(f"{statistics.median(ratios):.2f}" if ratios else "-")
            print(f"| {stem} | {kind} | " + " | ".join(cells) + " |")
        for run in runs:
            wrong += sum(
                row[kind].get("wrong", 0)
                for name, row in run.items()
                if name != "embree"
                for kind in ("random", "primary", "diffuse")
            )
    print(f"\nWrong answers of our rows, all runs: {wrong}\n")
    print("| scene | " + " | ".join(LAYOUTS) + " | Embree HIGH |")
    print("|---|" + "---:|" * (len(LAYOUTS) + 1))
    for stem in stems:
        rows = by_layout(os.path.join(dirs[0], f"quantized_{stem}.json"))
        cells = [
            f"{rows[k].get('layout_bytes_per_triangle', rows[k].get('allocated_bytes_per_triangle')):.1f}"
            if k in rows
            else "-"
            for k in LAYOUTS + ["embree"]
        ]
        print(f"| {stem} | " + " | ".join(cells) + " |")
    return 0 if wrong == 0 else 1


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1:]))
