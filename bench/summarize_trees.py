#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The space-subdivision trees' ratio table from `spacebvh compare --json` files (bench/trees_shared_scenes.sh).

Per scene and kernel, from rows measured side by side in one run: `spatial` (default settings) /
`embree-high` (Embree HIGH's binary tree under the same kernel), goal >= 1.05; `spatial` / the best of
`sbvh`, `esc`, `evh`, goal >= 1.0; `spatial` / `cbvh` (crytek_sponza goal >= 1.25 for random and
diffuse rays, rotated >= 2); closest hits for random, primary and diffuse rays, occlusion in brackets; a
closest-hit ratio below its goal is bold.
Then SAH (spatial below cbvh?), references / triangles (<= 1.3), and the wrong answers of all our rows
(both kernels, every tree) and of Embree's own kernel.
Usage: python3 bench/summarize_trees.py bench/out/trees_*.json
"""

import json
import os
import sys

KINDS = ("random", "primary", "diffuse")


def tree_name(row):
    return row["builder"].split(" ")[0]


def cell(numerator, denominator, kind):
    closest = numerator[kind]["closest_mrays"] / denominator[kind]["closest_mrays"]
    occlusion = numerator[kind]["occlusion_mrays"] / denominator[kind]["occlusion_mrays"]
    return closest, occlusion


def fmt(pair, goal):
    closest, occlusion = pair
    if closest >= goal:
        return f"{closest:.2f} ({occlusion:.2f})"
    return f"**{closest:.3f}** ({occlusion:.2f})"  # below the goal: three digits, so 1.049 reads as such


def main(paths):
    print(
        "| scene | kernel | spatial / embree-high tree: random, primary, diffuse | spatial / best of sbvh, esc, evh"
        " | spatial / cbvh | SAH spatial vs cbvh | refs / tris | our wrong answers (all rows)"
        " | Embree kernel's wrong answers |"
    )
    print("|---|---|---|---|---|---|---:|---:|---:|")
    for path in sorted(paths):
        data = json.load(open(path))
        scene = data["scenes"][0]
        name = os.path.basename(path).removeprefix("trees_").removesuffix(".json")
        rows = [r for r in scene["rows"] if not r["kernel"].startswith("Embree")]
        wrong = sum(r[k]["wrong"] for r in rows for k in KINDS if r[k].get("wrong") is not None)
        embree_wrong = sum(
            r[k]["wrong"]
            for r in scene["rows"]
            if r["kernel"].startswith("Embree")
            for k in KINDS
            if r[k].get("wrong") is not None
        )
        for kernel in sorted({r["kernel"] for r in rows}):
            by_tree = {tree_name(r): r for r in rows if r["kernel"] == kernel}
            spatial = by_tree["spatial"]
            embree = by_tree["embree-high"]
            cbvh = by_tree["cbvh"]
            versus_embree = ", ".join(fmt(cell(spatial, embree, kind), 1.05) for kind in KINDS)
            peers = []
            for kind in KINDS:
                best = max((by_tree[p] for p in ("sbvh", "esc", "evh")), key=lambda r: r[kind]["closest_mrays"])
                peers.append(fmt(cell(spatial, best, kind), 1.0) + " vs " + tree_name(best))
            cbvh_goal = 2.0 if name.endswith("rotated") else (1.25 if name == "crytek_sponza" else 0.0)
            versus_cbvh = ", ".join(fmt(cell(spatial, cbvh, kind), cbvh_goal) for kind in KINDS)
            sah = "{:.2f} vs {:.2f}".format(spatial["sah"], cbvh["sah"])
            refs = "%.2f" % (spatial["references"] / scene["triangles"])
            print(
                f"| {name} | {kernel} | {versus_embree} | {'; '.join(peers)} | {versus_cbvh} | {sah} | {refs} "
                f"| {wrong} | {embree_wrong} |"
            )


if __name__ == "__main__":
    main(sys.argv[1:])
