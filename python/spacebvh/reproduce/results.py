# SPDX-License-Identifier: MIT
"""Reading the CLI's JSON: compare rows by builder, ratios between rows of one run with their spread over
the timed runs, and the deterministic part of a result (what two runs on different machines share)."""

from __future__ import annotations

import statistics

RAY_KINDS = ("random", "primary", "diffuse")


def row_label(row: dict) -> str:
    """Our rows are 'LABEL (C_o=..)'; Embree's own rows keep 'embree-Q' and get their kernel named, so
    they never clash with Embree's tree traced by our kernels (builder 'embree-Q')."""
    name = row["builder"]
    if "sah" in row:
        return name.split(" (C_o=")[0]
    return name + (" (Embree packets)" if "16" in row.get("kernel", "") else " (Embree kernel)")


def rows_by_label(output: dict) -> dict[str, dict]:
    """The first scene's rows of one compare output, by label (a job compares one scene)."""
    return {row_label(row): row for row in output["scenes"][0]["rows"]}


def wrong_total(output: dict, ours: bool = True) -> int:
    """Answers the exact arbiter rejected, over our rows (ours=True: 0 expected, exactness is the
    library's promise) or over Embree's own rows (float kernels, not exact)."""
    return sum(
        row.get(kind, {}).get("wrong", 0)
        for scene in output["scenes"]
        for row in scene["rows"]
        if ("sah" in row) == ours
        for kind in RAY_KINDS
    )


def verified(output: dict) -> bool:
    """Whether the run checked answers (it does whenever an Embree row is present)."""
    return any(
        "wrong" in row.get(kind, {}) for scene in output["scenes"] for row in scene["rows"] for kind in RAY_KINDS
    )


def speed_ratio(row: dict, base: dict, kind: str, which: str = "closest") -> tuple[float, float, float]:
    """Row's speed over base's on one ray kind: (median, min, max) over the timed runs of the per-run
    ratio base_ms / row_ms. Run i of every row ran back to back (round robin), so each run's ratio is an
    honest side-by-side measurement, and the spread over runs is the error bar."""
    mine = row[kind].get(f"{which}_ms_runs")
    theirs = base[kind].get(f"{which}_ms_runs")
    if mine and theirs and len(mine) == len(theirs):
        ratios = [b / m for b, m in zip(theirs, mine) if m > 0]
        return statistics.median(ratios), min(ratios), max(ratios)
    value = row[kind][f"{which}_mrays"] / base[kind][f"{which}_mrays"]  # a CLI without per-run times
    return value, value, value


def build_ms_spread(row: dict) -> tuple[float, float, float]:
    runs = row.get("build_ms_runs") or [row["build_ms"]]
    return statistics.median(runs), min(runs), max(runs)


# Keys whose values depend on the machine or the moment, not on the inputs.
TIMING_KEYS = {
    "build_ms",
    "build_ms_runs",
    "closest_mrays",
    "occlusion_mrays",
    "closest_ms_runs",
    "occlusion_ms_runs",
    "peak_rss_bytes",
    "wall_s",
    "load_ms",
    "host",
    "platform",
    "started",
    "threads",
    "stdout",
    "commands",
    "output",
    "png_base64",
    "allocated_bytes_per_triangle",
}


def deterministic(value):
    """The result without timings, host names and anything else that may differ between two correct
    runs of the same job (trees, SAH, EPO, references, wrong answers, optimum ratios, heat-map counts
    stay). Heat-map pictures are kept by their mean and max; stdout holds timings."""
    if isinstance(value, dict):
        return {k: deterministic(v) for k, v in value.items() if k not in TIMING_KEYS}
    if isinstance(value, list):
        return [deterministic(v) for v in value]
    if isinstance(value, float):
        return round(value, 9)
    return value
