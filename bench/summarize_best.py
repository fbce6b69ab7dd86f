#!/usr/bin/env python3
"""Issue #5's ratio table from `spacebvh compare --json` files (bench/best_shared_scenes.sh).

Per scene and ray kind: our fastest row (any builder, any kernel) / Embree HIGH rtcIntersect1 or
rtcOccluded1, next to the goal max(1.0, tinybvh / Embree at 2 threads from
../shared/research/peers-measured.md); and our best packet row / Embree HIGH rtcIntersect16 on
primary rays (goal 1.0). Every figure comes from one compare run per scene.
"""
import json
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


def summarize(path):
    data = json.load(open(path))
    scene = data["scenes"][0]
    name = path.rsplit("best_", 1)[-1].removesuffix(".json")
    rows = scene["rows"]
    ours = [r for r in rows if not r["builder"].startswith("embree")]
    single = next(r for r in rows if r["builder"] == "embree-high" and "Intersect1/" in r["kernel"])
    packets = next(r for r in rows if r["builder"] == "embree-high" and "Intersect16" in r["kernel"])
    goals = PEER_RATIOS.get(name, (1.0,) * 6)
    cells = []
    for (kind, field), peer in zip(COLUMNS, goals):
        best = max(ours, key=lambda r: r[kind][field])
        ratio = best[kind][field] / single[kind][field]
        tree = best["builder"].split(" ")[0]
        cells.append(f"{ratio:.2f} ({tree}, {best[kind]['kernel']}; goal {max(1.0, peer):.2f})")
    packet_rows = [r for r in ours if r["kernel"].startswith("packet")]
    best_packet = max(packet_rows, key=lambda r: r["primary"]["closest_mrays"])
    packet_ratio = best_packet["primary"]["closest_mrays"] / packets["primary"]["closest_mrays"]
    wrong = sum(r[kind].get("wrong", 0) for r in rows for kind in ("random", "primary", "diffuse"))
    return f"| {name} | " + " | ".join(cells) + f" | {packet_ratio:.2f} | {wrong} |"


print("| scene | random closest | random occl. | primary closest | primary occl. | diffuse closest | diffuse occl. |"
      " packets / rtcIntersect16 (primary) | wrong |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
for path in sys.argv[1:]:
    print(summarize(path))
