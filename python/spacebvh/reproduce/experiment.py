# SPDX-License-Identifier: MIT
"""What every experiment shares: the run profiles, the Experiment and Analysis types, and the helpers
that read compare rows into table cells and verdicts."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .results import RAY_KINDS, rows_by_label, verified, wrong_total
from .scenes import Scene

# Ray and run settings per profile. quick: built-in scenes, a few minutes on 2 cores (the test suite);
# full: the shared scenes, about half an hour on 2 cores.
# limit_X: the largest scene (triangles) experiment X runs on, so the run keeps to its time.
PROFILES = {
    "quick": {
        "random": 5000,
        "width": 32,
        "height": 32,
        "runs": 3,
        "build_runs": 3,
        "optimum_nodes": 40,
        "optimum_max_refs": 12,
        "heat_size": 64,
        "limit_grid": 20000,
        "limit_full": 20000,
        "limit_lookahead": 20000,
        "limit_build": 20000,
        "limit_overlap": 10**9,
        "skip_rotated_overlap": True,
        "co_values": ("0", "1", "inf"),
        "scaling_strides": [1, 2, 4, 8],
        "scaling_build_runs": 3,
        "scaling_source": "generated:terrain:48",
    },
    "full": {
        "random": 100000,
        "width": 256,
        "height": 256,
        "runs": 5,
        "build_runs": 3,
        "optimum_nodes": 200,
        "optimum_max_refs": 16,
        "heat_size": 320,
        "limit_grid": 80000,
        "limit_full": 300000,
        "limit_lookahead": 300000,
        "limit_build": 300000,
        "limit_overlap": 300000,
        "skip_rotated_overlap": False,
        "co_values": ("0", "0.3", "1", "3", "inf"),
        "scaling_strides": [2, 4, 8, 16, 32],
        "scaling_build_runs": 2,
        "scaling_source": None,
    },
}


@dataclass
class Analysis:
    table_columns: list
    table_rows: list
    verdict: str  # "confirmed", "partly confirmed", "not confirmed", "no data"
    summary: str  # our numbers, one or two sentences
    plot: dict = field(default_factory=dict)  # what the figure draws
    wrong: int = 0  # our rows' wrong answers over the experiment's runs (0 expected)
    embree_wrong: int = 0  # Embree's own kernel's (not exact; reported, not a failure)
    verified_runs: int = 0
    notes: list = field(default_factory=list)


@dataclass
class Experiment:
    id: str
    title: str
    claim: str  # the slide's claim, in its words where it has any
    slide: str  # which slide
    kind: str  # job kind (jobs.KINDS)
    method: str  # what we run, for the report

    limit = ""  # PROFILES key of the largest scene it runs on (a class attribute, not a field)
    limit_reason = "its builds would not fit the run's time"

    def select(self, scenes: list[Scene], triangles: dict, profile: str) -> tuple[list[Scene], list[str]]:
        if not self.limit:
            return scenes, []
        limit = PROFILES[profile][self.limit]
        kept = [s for s in scenes if triangles[s] <= limit]
        return kept, [
            f"{s.label} ({triangles[s]} triangles) not run: this experiment is limited to {limit} "
            f"triangles in the {profile} run ({self.limit_reason})"
            for s in scenes
            if s not in kept
        ]

    def params(self, scene: Scene, triangles: int, profile: str) -> dict:
        raise NotImplementedError

    def weight(self, scene: Scene, triangles: int, profile: str) -> float:
        """Rough relative cost, for the progress bar's estimate of the time left."""
        return 1.0 + triangles / 20000.0

    def analyse(self, jobs: list[tuple[Scene, dict]]) -> Analysis:
        raise NotImplementedError


def compare_params(
    profile: str,
    builders,
    *,
    build_runs: int = 1,
    embree=("high",),
    embree_packets=(),
    kernels=("auto",),
    extra=(),
    no_epo=False,
) -> dict:
    p = PROFILES[profile]
    return {
        "builders": list(builders),
        "embree": list(embree),
        "embree_packets": list(embree_packets),
        "kernels": list(kernels),
        "random": p["random"],
        "width": p["width"],
        "height": p["height"],
        "runs": p["runs"],
        "build_runs": build_runs,
        "extra": list(extra),
        "no_epo": no_epo,
    }


def fmt(x: float, digits: int = 2) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.{digits}f}"


def ratio_text(r: tuple) -> str:
    return f"{r[0]:.2f} ({r[1]:.2f}-{r[2]:.2f})"


def count_wrong(jobs) -> tuple[int, int, int]:
    """(our rows' wrong answers, Embree's own rows' wrong answers, verified compare runs)."""
    wrong = embree = runs = 0
    for _, record in jobs:
        for output in record["outputs"]:
            if "scenes" in output:
                wrong += wrong_total(output)
                embree += wrong_total(output, ours=False)
                runs += verified(output)
    return wrong, embree, runs


def each_row(jobs, plot: dict, labels=None, base: str = "cbvh"):
    """(scene, label, row, base row, all rows by label) over each job's compare rows, in `labels` order
    (default: our rows, those with a tree); each scene is added to plot["scenes"]."""
    for scene, record in jobs:
        by = rows_by_label(record["outputs"][0])
        plot["scenes"].append(scene.label)
        for label in labels or [label for label, row in by.items() if "sah" in row]:
            yield scene, label, by[label], by[base], by


def row_wrong(row: dict) -> int:
    return sum(row[k].get("wrong", 0) for k in RAY_KINDS)


def majority(flags: list[bool]) -> str:
    if not flags:
        return "no data"
    share = sum(flags) / len(flags)
    return "confirmed" if share == 1 else "partly confirmed" if share >= 0.5 else "not confirmed"
