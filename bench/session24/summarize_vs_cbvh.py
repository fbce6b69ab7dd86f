#!/usr/bin/env python3
"""Closest-hit Mrays/s of each tree / cbvh's under the same kernel, per run and the median over runs,
from `spacebvh compare --json` files of one scene (bench/RESULTS.md, "Issues #3 and #5, session 24").
Usage: python3 bench/session24/summarize_vs_cbvh.py bench/session24/sponza_vs_cbvh_*.json
"""
import collections
import json
import statistics
import sys


def main(paths):
    ratios = collections.defaultdict(list)
    for path in sorted(paths):
        rows = json.load(open(path))["scenes"][0]["rows"]
        cbvh = {row["kernel"]: row for row in rows if row["builder"].split(" ")[0] == "cbvh"}
        for row in rows:
            tree = row["builder"].split(" ")[0]
            if tree == "cbvh":
                continue
            for kind in ("random", "diffuse"):
                ratios[(tree, row["kernel"], kind)].append(
                    row[kind]["closest_mrays"] / cbvh[row["kernel"]][kind]["closest_mrays"])
    print("| tree | kernel | rays | per run | median |")
    print("|---|---|---|---|---:|")
    for (tree, kernel, kind), values in sorted(ratios.items()):
        print("| %s | %s | %s | %s | %.2f |" % (tree, kernel, kind, " ".join("%.2f" % v for v in values),
                                               statistics.median(values)))


if __name__ == "__main__":
    main(sys.argv[1:])
