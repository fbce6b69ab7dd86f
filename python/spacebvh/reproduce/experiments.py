# SPDX-License-Identifier: MIT
"""The paper's experiments: which scenes each runs on, the job parameters, and the analysis that turns
the jobs' JSON into a table, numbers and a verdict on the slide's claim.

Every speed number is a ratio between rows of one `compare` run (round robin, same rays, same
machine), never times taken in different jobs. This module lists them; each family lives in a module
of its own (search_spaces, partitioning, build_cost, traversal) on the types of experiment.py."""

from __future__ import annotations

from .build_cost import BuildQuality, Scaling
from .experiment import PROFILES, Analysis, Experiment, count_wrong
from .partitioning import Overlap, Presplit
from .search_spaces import Grid, Lookahead, Optimum, SearchSpaces
from .traversal import Heatmaps, Termination

EXPERIMENTS = [
    Optimum(
        "optimum",
        "CBVH split vs the optimal partition of small nodes",
        'CBVH split: cost ≈ 700; optimal partition: cost ≈ 100 ("Can we do better?")',
        "Can We Do Better?",
        "optimum",
        "`spacebvh optimum`: small inner nodes (8 to N triangles) of each scene's cbvh tree (leaf size 1); each "
        "search space's best local split cost over the exhaustive optimum of all 2^(N-1)-1 partitions.",
    ),
    Grid(
        "grid",
        "Geometric partitioning on a grid vs the classical BVH",
        "Results: FPS random rays and SAH cost, classical BVH vs our method (R=64, R=4K); "
        'analysis: "Suspect: SAH - overlap + locally minimizing SAH has adverse effect"',
        "Results: FPS Random Rays / Surface Area Cost",
        "compare",
        "One `compare` per scene: cbvh (classical BVH) and cbvh with the grid search space added (object "
        "partitions only, --no-grid-splitting) at two resolutions.",
    ),
    Lookahead(
        "lookahead",
        "Recursive cost evaluation: tree cost vs measured speed",
        '"Use recursive cost evaluation - tree cost better than CBVH but slower FPS!"',
        "Result Analysis",
        "compare",
        "One `compare` per scene: cbvh greedy and with lookahead depth 1 and 2 (--lookahead, two candidates per "
        "axis and search space).",
    ),
    SearchSpaces(
        "search_spaces",
        "CBVH vs Full vs KDBVH: random rays and frustum traversal",
        "Results: FPS random rays and FPS frustum traversal, CBVH vs Full Search vs KDBVH (higher is better)",
        "Results: FPS Random Rays / FPS Frustum Traversal",
        "compare",
        "One `compare` per scene: cbvh, full (grid + kd planes + object sweep, C_o = inf) and kdbvh; random rays "
        "with the BVH8 single-ray kernel, primary rays with 8x8 packets (frustum culling).",
    ),
    Presplit(
        "presplit",
        "Comparison to pre-splitting (ESC, EVH) and SBVH",
        "Comparison to pre-splitting on Sponza and Sponza rotated (higher is better)",
        "Comparison to Pre-Splitting",
        "compare",
        "One `compare` per scene: cbvh, esc (early split clipping), evh (edge volume heuristic), sbvh and spatial.",
    ),
    Overlap(
        "overlap",
        "The role of the overlap penalty C_o",
        "Role of overlap penalty: C_o = 0 is the standard SAH, C_o → ∞ standard SAH with space partitioning; "
        '"SAH inadequate without space partitioning!"',
        "Role of Overlap Penalty",
        "compare",
        "One `compare` per scene: the spatial builder at each C_o (quick: 0, 1, inf).",
    ),
    BuildQuality(
        "build_quality",
        "Build time against tree quality, every builder and Embree",
        'Spatial build algorithm: "fast with near optimal results"',
        "Spatial Build Algorithm / Conclusion",
        "compare",
        "One `compare` per scene: every builder (full only on scenes within the grid experiment's size limit), "
        "Embree's MEDIUM/HIGH trees under our kernels and Embree's own LOW/MEDIUM/HIGH builds and kernel; build "
        "time the median of the build runs, bars their min-max.",
    ),
    Termination(
        "termination",
        "Early ray termination: boxes per ray of closest-hit and occlusion rays",
        '"Hypothesis: SA model needs space partitioning - Intuition: early ray termination"; future work: '
        '"research early termination aware cost function"',
        "Result Analysis / Conclusion & Future Work",
        "compare",
        "One `compare` per scene under the BVH8 kernel: cbvh, spatial, spatial with a reinsertion pass priced "
        "by 4096 sampled first-hit segments instead of by area, binned with the SAH reinsertion optimiser, "
        "Embree HIGH's tree under our kernel and Embree HIGH's own kernel; child boxes tested per ray for "
        "closest hits and for occlusion (any hit), speed relative to spatial.",
    ),
    Scaling(
        "scaling",
        "Build time against N",
        '"Choosing G = R N^(1/6) yields O(N^1.5)"',
        "Practical Considerations",
        "scaling",
        "Growing subsets (every k-th triangle, so each spans the whole scene); one `compare` per subset with the "
        "builders side by side; the exponent is a least-squares fit of log(build ms) on log(N).",
    ),
    Heatmaps(
        "heatmaps",
        "Heat maps of traversal cost: CBVH, spatial, Embree's tree",
        "The paper's thesis seen per pixel: enforcing space subdivision lowers traversal work (no slide shows heat "
        "maps)",
        "-",
        "heatmap",
        "`spacebvh render --heatmap` of the same camera for cbvh, spatial and Embree HIGH's tree (binary kernel); "
        "the first picture's colour scale is used for all three.",
    ),
]

BY_ID = {e.id: e for e in EXPERIMENTS}

__all__ = [
    "BY_ID",
    "EXPERIMENTS",
    "PROFILES",
    "Analysis",
    "BuildQuality",
    "Experiment",
    "Grid",
    "Heatmaps",
    "Lookahead",
    "Optimum",
    "Overlap",
    "Presplit",
    "Scaling",
    "SearchSpaces",
    "Termination",
    "count_wrong",
]
