#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The C_o sweep tables from bench/co_sweep.sh.

Reads `spacebvh compare --json` files, one per run and scene, found by a pattern with `{scene}` in it
(default: bench/out/co_sweep_SCENE_N.json, as bench/co_sweep.sh writes them), and
prints per scene and row the SAH, EPO, references and the median over runs of the row's Mrays/s
divided by the first row's in the same run (random, primary, diffuse; closest hit, then occlusion).
"""

import glob
import json
import os
import statistics
import sys

SCENES = ["living_room_3", "coffee_maker", "crytek_sponza", "crytek_sponza_rotated", "bunny", "sibenik"]
KINDS = ["random", "primary", "diffuse"]
FIELDS = ["closest_mrays", "occlusion_mrays"]


def tree_rows(run):
    """The rows of our trees (Embree's own kernel rows have no SAH), by builder name."""
    return {row["builder"]: row for row in run["scenes"][0]["rows"] if "sah" in row}


def main():
    pattern = (
        sys.argv[1]
        if len(sys.argv) > 1
        else os.path.join(os.path.dirname(__file__), "out", "co_sweep_{scene}_[0-9]*.json")
    )
    for scene in SCENES:
        files = sorted(glob.glob(pattern.format(scene=scene)))
        if not files:
            continue
        runs = [tree_rows(json.load(open(path))) for path in files]
        names = list(runs[0])
        baseline = names[0]
        print(f"{scene} ({len(runs)} runs; median of per-run ratios to {baseline})")
        for name in names:
            ratios = []
            for kind in KINDS:
                for field in FIELDS:
                    per_run = [rows[name][kind][field] / rows[baseline][kind][field] for rows in runs]
                    ratios.append(f"{statistics.median(per_run):.3f}")
            first = runs[0][name]
            epo = f"{first['epo']:6.2f}" if first.get("epo") is not None else "     -"
            print(
                f"  {name:<26} SAH {first['sah']:6.2f} EPO {epo} refs {first['references']:7d}  "
                f"random {ratios[0]} {ratios[1]}  primary {ratios[2]} {ratios[3]}  diffuse {ratios[4]} {ratios[5]}"
            )


if __name__ == "__main__":
    main()
