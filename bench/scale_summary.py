# SPDX-License-Identifier: MIT
"""The table of bench/scale.sh: reads BUILDER_SIZE.json (spacebvh build --json), .time (peak RSS in
KiB from /usr/bin/time) and .log files from a directory and prints, per builder and size, the build
time, the time per triangle, the peak RSS and bytes per triangle (at the end of the build, as the
process reports it, and for the whole process, from /usr/bin/time), the memory estimate (scene +
the build's estimate) and the measured peak over it, the build time over Embree MEDIUM's at the same
size, then each builder's build-time exponent: the slope of log(time) over log(triangles) by least
squares over the sizes from 10^5 to 10^7 triangles.

    python3 bench/scale_summary.py DIR
"""

import json
import math
import pathlib
import sys

MIB = 1024.0 * 1024.0


def size_of(text):
    return int(float(text))


def load(directory):
    runs = []
    for log in sorted(directory.glob("*.log")):
        builder, _, size = log.stem.rpartition("_")
        run = {"builder": builder, "size": size_of(size), "log": log.read_text().strip()}
        json_path = log.with_suffix(".json")
        if json_path.exists():
            run["json"] = json.loads(json_path.read_text())
        time_path = log.with_suffix(".time")
        if time_path.exists():
            lines = [line for line in time_path.read_text().split() if line.isdigit()]
            if lines:
                run["time_rss"] = int(lines[-1]) * 1024
        runs.append(run)
    return runs


def exponent(points):
    """Least-squares slope of log(ms) on log(triangles)."""
    if len(points) < 2:
        return None
    xs = [math.log(n) for n, _ in points]
    ys = [math.log(ms) for _, ms in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx if sxx > 0 else None


def main():
    directory = pathlib.Path(sys.argv[1])
    runs = load(directory)
    order = ["binned", "cbvh", "spatial", "embree-medium", "embree-high"]
    runs.sort(
        key=lambda r: (order.index(r["builder"]) if r["builder"] in order else len(order), r["builder"], r["size"])
    )
    medium_ms = {r["size"]: r["json"]["build_ms"] for r in runs if r["builder"] == "embree-medium" and "json" in r}
    header = (
        "builder",
        "N",
        "triangles",
        "build s",
        "ns/tri",
        "x medium",
        "build RSS MiB",
        "B/tri",
        "process RSS MiB",
        "B/tri",
        "estimate MiB",
        "RSS/est",
    )
    rows = []
    fits = {}
    for run in runs:
        if "json" not in run:
            last = run["log"].splitlines()[-1] if run["log"] else "no output"
            rows.append((run["builder"], f"{run['size']:.0e}", "-", "not built: " + last[:110]))
            continue
        j = run["json"]
        n = j["triangles"]
        ms = j["build_ms"]
        build_rss = j["build_peak_rss_bytes"]
        process_rss = run.get("time_rss", j["peak_rss_bytes"])
        estimate = j["scene_bytes"] + j["estimated_build_bytes"]
        ratio = f"{ms / medium_ms[run['size']]:.2f}" if run["size"] in medium_ms else "-"
        rows.append(
            (
                run["builder"],
                f"{run['size']:.0e}",
                str(n),
                f"{ms / 1000:.2f}",
                f"{ms * 1e6 / n:.0f}",
                ratio,
                f"{build_rss / MIB:.0f}",
                f"{build_rss / n:.0f}",
                f"{process_rss / MIB:.0f}",
                f"{process_rss / n:.0f}",
                f"{estimate / MIB:.0f}",
                f"{build_rss / estimate:.2f}",
            )
        )
        if 1e5 <= run["size"] <= 1e7:
            fits.setdefault(run["builder"], []).append((n, ms))
    widths = [
        max(len(str(row[i])) for row in [header] + [r for r in rows if len(r) == len(header)])
        for i in range(len(header))
    ]
    print("  ".join(h.rjust(w) for h, w in zip(header, widths)))
    for row in rows:
        if len(row) == len(header):
            print("  ".join(str(c).rjust(w) for c, w in zip(row, widths)))
        else:
            print("  ".join(str(c).rjust(w) for c, w in zip(row[:3], widths)) + "  " + row[3])
    print()
    print("build-time exponent over 1e5..1e7 triangles (log-log least squares; 1 = linear):")
    for builder, points in fits.items():
        slope = exponent(points)
        text = f"{slope:.3f}" if slope is not None else "-"
        print(f"  {builder:14s} {text}  ({len(points)} sizes)")
    print()
    print("build RSS: peak resident set at the end of the build (the scene included); process RSS: the whole")
    print("command's peak (/usr/bin/time), with the tree's metrics and traversal layout after the build;")
    print("estimate: the scene's bytes + the build's estimate (spacebvh/memory_estimate.hpp); x medium: build")
    print("time over embree-medium's at the same size.")


if __name__ == "__main__":
    main()
