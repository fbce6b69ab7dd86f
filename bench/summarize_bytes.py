# SPDX-License-Identifier: MIT
"""Bytes per triangle of every row of `compare` JSON files: our layouts (nodes + leaf triangle data)
and what Embree's commit allocated for its own tree, one line per scene.

Usage: python3 bench/summarize_bytes.py COMPARE.json..."""

import json
import sys


def main() -> None:
    print("| scene | " + "layout bytes per triangle (row: bytes) |")
    print("|---|---|")
    for path in sys.argv[1:]:
        for scene in json.load(open(path))["scenes"]:
            cells = {}
            for row in scene["rows"]:
                value = row.get("layout_bytes_per_triangle", row.get("allocated_bytes_per_triangle"))
                if value is not None:
                    cells.setdefault(f"{row['builder']} {row['kernel']}", value)
            text = ", ".join(f"{name}: {value:.1f}" for name, value in cells.items())
            print(f"| {scene['scene']} | {text} |")


if __name__ == "__main__":
    main()
