# SPDX-License-Identifier: MIT
"""Wrong-answer summary of bench/soak_shared_scenes.sh: one line per scene, builder and kernel with
the rays checked per kind and the answers the exact arbiter rejects (closest hit + occlusion).

Usage: python3 bench/summarize_soak.py bench/out/soak
Ends with the coverage: per builder, the (kernel, scene) cells present out of every kernel and scene
seen in the run, naming the missing ones. Exits 1 when any row of ours has a wrong answer (Embree's
own rows are listed apart: Embree is not watertight and is expected to be wrong now and then)."""

import json
import pathlib
import sys

KINDS = ("random", "primary", "diffuse")


def main() -> int:
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "bench/out/soak")
    files = sorted(root.rglob("*.json"))
    if not files:
        print(f"no results under {root}")
        return 0
    ours_wrong = 0
    answers = 0
    fewest = None  # the fewest rays of any kind in any row of ours
    print("| scene | builder | kernel | " + " | ".join(f"{k} rays" for k in KINDS) + " | wrong (ours) |")
    print("|---|---|---|" + "---:|" * (len(KINDS) + 1))
    embree_lines = []
    cells = {}  # builder -> {(kernel, scene)}: what the run covered
    for path in files:
        report = json.loads(path.read_text())
        for scene in report["scenes"]:
            counts = [scene["rays"][k] for k in KINDS]
            for row in scene["rows"]:
                if any("wrong" not in row[k] for k in KINDS):
                    raise SystemExit(f"{path}: row {row['builder']} was not verified (Embree missing?)")
                wrong = sum(row[k]["wrong"] for k in KINDS)
                line = f"| {scene['scene']} | {row['builder']} | {row['kernel']} | " + " | ".join(map(str, counts))
                if row["builder"].startswith("embree"):
                    embree_lines.append(f"{line} | {wrong} |")
                    continue
                ours_wrong += wrong
                cells.setdefault(row["builder"].split(" (C_o=")[0], set()).add((row["kernel"], scene["scene"]))
                answers += 2 * sum(counts)
                fewest = min(counts) if fewest is None else min(fewest, min(counts))
                print(f"{line} | {wrong} |")
    print()
    print(
        f"ours: {answers} answers checked (closest + occlusion), {ours_wrong} wrong; "
        f"fewest rays of one kind in a row: {fewest}"
    )
    if embree_lines:
        print()
        print("Embree HIGH's own rows, checked against our first row (Embree is not watertight):")
        print()
        print("\n".join(sorted(set(embree_lines))))
    kernels = sorted({k for covered in cells.values() for k, _ in covered})
    scenes = sorted({s for covered in cells.values() for _, s in covered})
    print()
    print(f"Coverage: {len(kernels)} kernels x {len(scenes)} scenes per builder")
    print()
    for builder, covered in sorted(cells.items()):
        missing = [f"{k} on {s}" for k in kernels for s in scenes if (k, s) not in covered]
        print(
            f"- {builder}: {len(covered)} of {len(kernels) * len(scenes)}"
            + (f"; missing: {', '.join(missing)}" if missing else "")
        )
    return 1 if ours_wrong else 0


if __name__ == "__main__":
    sys.exit(main())
