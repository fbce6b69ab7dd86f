#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The table of bench/ab_binaries.sh: per scene and ray kind (random, primary and diffuse rays, closest
hit and occlusion), the median over repetitions of our row's speed / Embree HIGH's own kernel's speed in the
same process, for binary A and binary B, and B / A of those medians."""

import collections
import json
import statistics
import sys
from pathlib import Path

KINDS = [(kind, query) for kind in ("random", "primary", "diffuse") for query in ("closest", "occlusion")]


def ratios(path: Path) -> dict:
    """Ours / Embree's rtcIntersect1/rtcOccluded1 per (kind, query) in one compare JSON."""
    rows = json.loads(path.read_text())["scenes"][0]["rows"]
    embree = next(r for r in rows if "rtcIntersect1" in r["kernel"])
    ours = next(r for r in rows if "Embree" not in r["kernel"])
    return {(k, q): ours[k][q + "_mrays"] / embree[k][q + "_mrays"] for k, q in KINDS}


def main(folder: str) -> None:
    cells = collections.defaultdict(list)  # (stem, side, kind, query) -> ratios over repetitions
    stems = []
    for path in sorted(Path(folder).glob("*.json")):
        stem, side, _ = path.name[: -len(".json")].rsplit(".", 2)
        if stem not in stems:
            stems.append(stem)
        for key, value in ratios(path).items():
            cells[(stem, side) + key].append(value)
    if not stems:
        sys.exit(f"no results in {folder}")
    print("| scene | " + " | ".join(f"{k} {q}: A, B (B/A)" for k, q in KINDS) + " |")
    print("|---|" + "---:|" * len(KINDS))
    for stem in stems:
        line = []
        for k, q in KINDS:
            a, b = (statistics.median(cells[(stem, side, k, q)]) for side in "AB")
            line.append(f"{a:.2f}, {b:.2f} ({b / a:.3f})")
        print(f"| {stem} | " + " | ".join(line) + " |")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: summarize_ab.py FOLDER   (the JSON of bench/ab_binaries.sh, bench/out/ab by default)")
    main(sys.argv[1])
