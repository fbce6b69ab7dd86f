# SPDX-License-Identifier: MIT
"""One matplotlib figure per experiment, written as SVG and PNG. Every builder has one colour in every
figure (BUILDER_COLOURS); Embree's own kernel is drawn in its tree's colour with a hatched or hollow
mark. Error bars span the timed runs (min to max of the per-run ratio)."""

from __future__ import annotations

import base64
import io
import math
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

plt.rcParams.update(
    {
        "svg.fonttype": "path",
        "font.size": 9,
        "axes.titlesize": 10,
        "axes.grid": True,
        "grid.alpha": 0.3,
        "figure.dpi": 110,
        "savefig.bbox": "tight",
        "svg.hashsalt": "spacebvh",
    }
)

BUILDER_COLOURS = {
    "cbvh": "#1f77b4",
    "classical (cbvh)": "#1f77b4",
    "object (cbvh sweep)": "#1f77b4",
    "binned": "#aec7e8",
    "kdbvh": "#2ca02c",
    "spatial (kd planes)*": "#2ca02c",
    "spatial": "#d62728",
    "sbvh": "#ff7f0e",
    "esc": "#8c564b",
    "evh": "#c49c94",
    "full": "#9467bd",
    "full: object+spatial+grid*": "#9467bd",
    "grid R=1": "#17becf",
    "grid, no splitting": "#17becf",
    "grid R=2": "#0b6e78",
    "grid + splitting*": "#0b6e78",
    "cbvh@lookahead=1": "#e377c2",
    "cbvh@lookahead=2": "#7b2d6b",
    "spatial@trays=4096;tsplit=0;topt=4": "#ff9896",
    "binned+opt": "#393b79",
    "embree-low": "#c7c7c7",
    "embree-medium": "#7f7f7f",
    "embree-high": "#222222",
}
KIND_MARKERS = {"random": "o", "primary": "s", "diffuse": "^"}
SCENE_MARKERS = "osD^vP*Xh<>"


def colour(label: str) -> str:
    base = label.replace(" (Embree kernel)", "").replace(" (Embree packets)", "")
    return BUILDER_COLOURS.get(label, BUILDER_COLOURS.get(base, "#bcbd22"))


def _errors(triples):
    return [[t[0] - t[1] for t in triples], [t[2] - t[0] for t in triples]]


def _save(fig, directory: Path, name: str) -> dict:
    directory.mkdir(parents=True, exist_ok=True)
    paths = {}
    for ext in ("svg", "png"):
        path = directory / f"{name}.{ext}"
        fig.savefig(
            path, format=ext, dpi=110 if ext == "png" else None, metadata={"Date": None} if ext == "svg" else None
        )
        paths[ext] = path
    plt.close(fig)
    return paths


def _grouped_bars(ax, scenes, series: dict, value, ylabel, title, baseline=1.0):
    """Bars per scene group, one bar per builder; value(entry) -> (median, min, max)."""
    names = list(series)
    width = 0.8 / max(1, len(names))
    for i, name in enumerate(names):
        triples = [value(e) for e in series[name]]
        xs = [j + (i - (len(names) - 1) / 2) * width for j in range(len(triples))]
        embree_kernel = "(Embree" in name  # Embree's own kernel: its tree's colour, hatched
        ax.bar(
            xs,
            [t[0] for t in triples],
            width,
            yerr=_errors(triples),
            capsize=2,
            color=colour(name),
            edgecolor="white" if embree_kernel else "black",
            linewidth=0.4,
            label=name,
            hatch="///" if embree_kernel else None,
        )
    ax.axhline(baseline, color="black", linewidth=0.8, linestyle="--")
    ax.set_xticks(range(len(scenes)))
    ax.set_xticklabels([s.replace(" rotated ", "\nrotated ") for s in scenes], rotation=20, ha="right")
    ax.set_ylabel(ylabel)
    ax.set_title(title)


def fig_optimum(plot, out: Path) -> dict:
    spaces = list(plot["ratios"])
    scenes = plot["scenes"]
    fig, ax = plt.subplots(figsize=(max(6.5, 1.6 * len(scenes) + 2), 4.2))
    width = 0.8 / max(1, len(spaces))
    for i, name in enumerate(spaces):
        data = [r if r else [float("nan")] for r in plot["ratios"][name]]
        positions = [j + (i - (len(spaces) - 1) / 2) * width for j in range(len(data))]
        parts = ax.boxplot(
            data,
            positions=positions,
            widths=width * 0.9,
            patch_artist=True,
            whis=(0, 100),
            medianprops={"color": "black"},
            manage_ticks=False,
        )
        for box in parts["boxes"]:
            box.set_facecolor(colour(name))
        ax.plot([], [], "s", color=colour(name), label=name)
    ax.axhline(1.0, color="black", linewidth=0.8)
    ax.axhline(7.0, color="#d62728", linewidth=1.0, linestyle=":", label="slides' example: 700 / 100 = 7x")
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.yaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax.set_ylim(top=9)
    ax.set_ylabel("best local split cost / exhaustive optimum (ratio, log)")
    ax.set_xticks(range(len(scenes)))
    ax.set_xticklabels(scenes, rotation=20, ha="right")
    ax.set_title("Small nodes of each scene's cbvh tree: each search space against the optimum (whiskers: min-max)")
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    return _save(fig, out, "optimum")


def fig_grid(plot, out: Path) -> dict:
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    _grouped_bars(
        a,
        plot["scenes"],
        plot["bars"],
        lambda e: e["speed"],
        "random-ray speed / classical BVH (ratio)",
        "Random rays, closest hit (BVH8 kernel)",
    )
    _grouped_bars(
        b,
        plot["scenes"],
        plot["bars"],
        lambda e: (e["sah_ratio"],) * 3,
        "tree SAH / classical BVH (ratio)",
        "SAH cost (lower is better)",
    )
    a.legend(fontsize=7)
    return _save(fig, out, "grid")


def fig_lookahead(plot, out: Path) -> dict:
    fig, axes = plt.subplots(1, 3, figsize=(12, 4), sharey=True)
    scenes = plot["scenes"]
    for ax, kind in zip(axes, ("random", "primary", "diffuse")):
        for label, points in plot["points"].items():
            for p in points:
                m = SCENE_MARKERS[scenes.index(p["scene"]) % len(SCENE_MARKERS)]
                t = p[kind]
                ax.errorbar(
                    [p["sah_ratio"]],
                    [t[0]],
                    yerr=_errors([t]),
                    fmt=m,
                    color=colour(label),
                    capsize=2,
                    markeredgecolor="black",
                    markeredgewidth=0.4,
                )
        ax.axhline(1.0, color="black", linewidth=0.8, linestyle="--")
        ax.axvline(1.0, color="black", linewidth=0.8, linestyle="--")
        ax.set_xlabel("tree SAH / greedy cbvh (ratio; left = lower cost)")
        ax.set_title(f"{kind} rays, closest hit")
    axes[0].set_ylabel("speed / greedy cbvh (ratio; up = faster)")
    for label in plot["points"]:
        axes[0].plot([], [], "s", color=colour(label), label=label)
    for i, s in enumerate(scenes):
        axes[0].plot([], [], SCENE_MARKERS[i % len(SCENE_MARKERS)], color="white", markeredgecolor="black", label=s)
    axes[0].legend(fontsize=7)
    return _save(fig, out, "lookahead")


def fig_search_spaces(plot, out: Path) -> dict:
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    _grouped_bars(
        a,
        plot["scenes"],
        plot["bars"],
        lambda e: e["random"],
        "speed / CBVH (ratio)",
        "Random rays (BVH8 single-ray kernel)",
    )
    _grouped_bars(
        b,
        plot["scenes"],
        plot["bars"],
        lambda e: e["primary"],
        "speed / CBVH (ratio)",
        "Primary rays, frustum traversal (8x8 packets)",
    )
    a.legend(fontsize=7)
    return _save(fig, out, "search_spaces")


def fig_presplit(plot, out: Path) -> dict:
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), sharey=True)
    for ax, kind in zip(axes, ("random", "primary", "diffuse")):
        _grouped_bars(
            ax,
            plot["scenes"],
            plot["bars"],
            lambda e, k=kind: e[k],
            "speed / cbvh (ratio)" if kind == "random" else "",
            f"{kind} rays, closest hit",
        )
    axes[0].legend(fontsize=7)
    return _save(fig, out, "presplit")


def _co_axis(values):
    """C_o on a log axis with 0 and inf placed at its ends."""
    finite = [v for v in values if 0 < v < math.inf]
    lo, hi = min(finite) / 4, max(finite) * 4
    return [lo if v == 0 else hi if v == math.inf else v for v in values], lo, hi


def fig_overlap(plot, out: Path) -> dict:
    xs, lo, hi = _co_axis(plot["co"])
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    panels = [
        ("sah", "tree SAH / SAH at C_o=0 (ratio)", True),
        ("epo", "EPO / EPO at C_o=0 (ratio)", True),
        ("refs", "references / triangles", False),
        ("random", "random speed / C_o=0 (ratio)", False),
        ("primary", "primary speed / C_o=0 (ratio)", False),
        ("diffuse", "diffuse speed / C_o=0 (ratio)", False),
    ]
    for ax, (key, ylabel, normalise) in zip(axes.flat, panels):
        for i, (scene, series) in enumerate(plot["scenes"].items()):
            values = series[key]
            m = SCENE_MARKERS[i % len(SCENE_MARKERS)]
            if key in ("random", "primary", "diffuse"):
                ax.errorbar(
                    xs,
                    [t[0] for t in values],
                    yerr=_errors(values),
                    marker=m,
                    color=colour("spatial"),
                    alpha=0.85,
                    capsize=2,
                    label=scene,
                    markeredgecolor="black",
                    markeredgewidth=0.4,
                )
            else:
                ys = [v / values[0] for v in values] if normalise and values[0] else values
                ax.plot(
                    xs,
                    ys,
                    marker=m,
                    color=colour("spatial"),
                    alpha=0.85,
                    label=scene,
                    markeredgecolor="black",
                    markeredgewidth=0.4,
                )
        ax.set_xscale("log")
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_xticks(xs)
        ax.set_xticklabels(["0" if v == 0 else "∞" if v == math.inf else f"{v:g}" for v in plot["co"]])
        ax.set_xlabel("overlap penalty C_o (0 and ∞ at the ends)")
        ax.set_ylabel(ylabel)
        if key in ("random", "primary", "diffuse"):
            ax.axhline(1.0, color="black", linewidth=0.8, linestyle="--")
    axes[0][0].legend(fontsize=7)
    fig.suptitle("spatial builder against C_o (one marker per scene)")
    return _save(fig, out, "overlap")


def fig_build_quality(plot, out: Path) -> dict:
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.8))
    scenes = sorted({p["scene"] for ps in plot["points"].values() for p in ps})
    for label, points in plot["points"].items():
        own = label.endswith("(Embree kernel)") or label.endswith("(Embree packets)")
        for p in points:
            m = SCENE_MARKERS[scenes.index(p["scene"]) % len(SCENE_MARKERS)]
            kw = dict(color=colour(label), markeredgecolor="black", markeredgewidth=0.4, capsize=2)
            if own:
                kw.update(markerfacecolor="white", markeredgecolor=colour(label), markeredgewidth=1.5)
            x = p["build_rel"]
            if p["sah_ratio"] is not None:
                a.plot([x], [p["sah_ratio"]], m, **{k: v for k, v in kw.items() if k != "capsize"})
            s = p["speed"]
            b.errorbar([x], [s[0]], yerr=_errors([s]), fmt=m, **kw)
    for ax in (a, b):
        ax.set_xscale("log")
        ax.set_xlabel("build time / Embree HIGH's build (ratio, log; median of build runs)")
    a.set_ylabel("tree SAH / cbvh (ratio; lower is better)")
    a.set_title("Tree quality against build time")
    b.set_ylabel("random-ray speed / cbvh (ratio; higher is better)")
    b.set_title("Measured speed against build time (hollow: Embree's own kernel)")
    b.axhline(1.0, color="black", linewidth=0.8, linestyle="--")
    for label in plot["points"]:
        if not label.endswith(")"):
            a.plot([], [], "s", color=colour(label), label=label)
    for i, s in enumerate(scenes):
        a.plot([], [], SCENE_MARKERS[i % len(SCENE_MARKERS)], color="white", markeredgecolor="black", label=s)
    a.legend(fontsize=7, ncol=8, loc="upper center", bbox_to_anchor=(1.1, -0.14))  # below both panels, off the data
    return _save(fig, out, "build_quality")


def fig_termination(plot, out: Path) -> dict:
    """Rows: child boxes per closest-hit ray, per occlusion ray, then closest-hit and occlusion speed, all
    relative to spatial; columns: the ray kinds."""
    panels = (
        ("boxes", 0, "closest-hit boxes / spatial"),
        ("boxes", 1, "occlusion boxes / spatial"),
        ("speed", "closest", "closest-hit speed / spatial"),
        ("speed", "occlusion", "occlusion speed / spatial"),
    )
    fig, axes = plt.subplots(len(panels), 3, figsize=(13, 13), sharex=True)
    for r, (quantity, which, ylabel) in enumerate(panels):
        for c, kind in enumerate(("random", "primary", "diffuse")):
            series = plot["boxes" if quantity == "boxes" else "speed"]

            def value(e, k=kind, w=which, boxes=quantity == "boxes"):
                return (e[k][w],) * 3 if boxes else e[k][w]

            _grouped_bars(
                axes[r][c], plot["scenes"], series, value, ylabel if c == 0 else "", f"{kind} rays" if r == 0 else ""
            )
    axes[0][0].legend(fontsize=7)
    axes[2][0].legend(fontsize=7)  # the speed rows add Embree's own kernel
    fig.suptitle(
        "Early ray termination: child boxes tested per ray (BVH8 kernel; lower is better) and speed "
        "(higher is better), relative to spatial"
    )
    return _save(fig, out, "termination")


def fig_scaling(plot, out: Path) -> dict:
    fig, ax = plt.subplots(figsize=(7.5, 5))
    for label, series in plot["series"].items():
        ns = [n for n, _ in series]
        triples = [b for _, b in series]
        e = plot["exponents"].get(label)
        name = label.replace("(Embree kernel)", "(Embree's own build)")
        ax.errorbar(
            ns,
            [t[0] for t in triples],
            yerr=_errors(triples),
            marker="o",
            color=colour(label),
            capsize=2,
            label=f"{name} (e = {e:.2f})" if e is not None else name,
            markerfacecolor="white" if label.endswith(")") else colour(label),
        )
    if plot["series"]:
        ns = sorted({n for s in plot["series"].values() for n, _ in s})
        first = next(iter(plot["series"].values()))
        y0 = first[-1][1][0]
        ax.plot(ns, [y0 * (n / ns[-1]) ** 1.5 for n in ns], color="black", linestyle=":", label="slope 1.5 (O(N^1.5))")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("triangles N (log)")
    ax.set_ylabel("build time, ms (log; median, bars min-max of build runs)")
    ax.set_title(f"Build time against N: subsets of {plot['scene']}")
    ax.legend(fontsize=7)
    return _save(fig, out, "scaling")


def fig_heatmaps(plot, out: Path) -> dict:
    scenes = plot["scenes"]
    builders = list(scenes[0]["images"]) if scenes else []
    fig, axes = plt.subplots(
        max(1, len(scenes)),
        max(1, len(builders)),
        figsize=(3.2 * max(1, len(builders)), 3.4 * max(1, len(scenes))),
        squeeze=False,
    )
    for r, scene in enumerate(scenes):
        for c, b in enumerate(builders):
            image = plt.imread(io.BytesIO(base64.b64decode(scene["images"][b])), format="png")
            ax = axes[r][c]
            ax.imshow(image)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.grid(False)
            ax.set_title(f"{b}: mean {scene['mean'][b]:.1f}", color=colour(b) if b != "embree-high" else "black")
            if c == 0:
                ax.set_ylabel(f"{scene['label']}\n(colour scale 0 to {scene['scale']:.0f})")
    fig.suptitle(
        "Traversal work per pixel (nodes + triangles tested, binary kernel); one colour scale per row, "
        "set by cbvh's 99th percentile"
    )
    return _save(fig, out, "heatmaps")


FIGURES = {
    "optimum": fig_optimum,
    "grid": fig_grid,
    "lookahead": fig_lookahead,
    "search_spaces": fig_search_spaces,
    "presplit": fig_presplit,
    "overlap": fig_overlap,
    "build_quality": fig_build_quality,
    "termination": fig_termination,
    "scaling": fig_scaling,
    "heatmaps": fig_heatmaps,
}
