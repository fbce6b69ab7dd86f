# SPDX-License-Identifier: MIT
"""Traversal work: child boxes per closest-hit and occlusion ray (early termination), and per-pixel heat
maps of traversal cost."""

from __future__ import annotations

from .experiment import PROFILES, Analysis, Experiment, compare_params, fmt, majority, ratio_text, row_wrong
from .results import RAY_KINDS, rows_by_label, speed_ratio


class Termination(Experiment):
    """Does space partitioning pay through early ray termination? Child boxes tested per closest-hit and per
    occlusion ray (an occlusion ray stops at the first hit it finds), and speed, on the same BVH8 kernel."""

    SAMPLED = "spatial@trays=4096;tsplit=0;topt=4"  # reinsertion priced by sampled first-hit segments
    BUILDERS = ("cbvh", "spatial", SAMPLED, "binned+opt", "embree-high")
    EMBREE_KERNEL = "embree-high (Embree kernel)"

    def params(self, scene, triangles, profile):
        return compare_params(profile, self.BUILDERS, kernels=("bvh8",), no_epo=True)

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 3000.0

    def analyse(self, jobs):
        rows, plot, flags = [], {"scenes": [], "boxes": {}, "speed": {}}, []
        for scene, record in jobs:
            by = rows_by_label(record["outputs"][0])
            plot["scenes"].append(scene.label)
            base = by["spatial"]
            for label in self.BUILDERS + (self.EMBREE_KERNEL,):
                row = by[label]
                speed = {k: {m: speed_ratio(row, base, k, m) for m in ("closest", "occlusion")} for k in RAY_KINDS}
                plot["speed"].setdefault(label, []).append(speed)
                boxes = {
                    k: (row[k]["nodes_per_ray"], row[k]["occlusion_nodes_per_ray"])
                    for k in RAY_KINDS
                    if "nodes_per_ray" in row[k]
                }
                if boxes:
                    plot["boxes"].setdefault(label, []).append(
                        {
                            k: (b[0] / base[k]["nodes_per_ray"], b[1] / base[k]["occlusion_nodes_per_ray"])
                            for k, b in boxes.items()
                        }
                    )
                cells = []
                for k in RAY_KINDS:
                    cells += [
                        f"{fmt(boxes[k][0], 1)} ({fmt(boxes[k][1], 1)})" if k in boxes else "-",
                        ratio_text(speed[k]["closest"]),
                        ratio_text(speed[k]["occlusion"]),
                    ]
                rows.append(
                    [scene.label, label, fmt(row.get("sah")), fmt(row["sah"] / base["sah"], 3) if "sah" in row else "-"]
                    + cells
                    + [row_wrong(row) if "sah" in row else "-"]
                )
            cbvh = by["cbvh"]
            flags += [base[k][q] < cbvh[k][q] for k in RAY_KINDS for q in ("nodes_per_ray", "occlusion_nodes_per_ray")]
        if not jobs:
            return Analysis([], [], "no data", "no job finished", plot)

        def diffuse_occlusion(label):
            return "; ".join(f"{s}: {b['diffuse'][1]:.2f}" for s, b in zip(plot["scenes"], plot["boxes"][label]))

        summary = (
            f"spatial tests fewer child boxes per ray than cbvh in {sum(flags)} of {len(flags)} (scene, ray kind, "
            "closest/occlusion) cells (BVH8 kernel). Child boxes per diffuse occlusion ray relative to spatial: "
            f"cbvh {diffuse_occlusion('cbvh')}; spatial with the sampled reinsertion ({self.SAMPLED}) "
            f"{diffuse_occlusion(self.SAMPLED)}; binned+opt {diffuse_occlusion('binned+opt')}; Embree HIGH's tree "
            f"{diffuse_occlusion('embree-high')}. Confirmed for a cell when spatial tests fewer boxes than cbvh."
        )
        columns = ["scene", "tree", "SAH", "SAH / spatial"]
        for k in RAY_KINDS:
            columns += [f"{k} boxes/ray (occl.)", f"{k} speed / spatial", f"{k} occl. speed / spatial"]
        return Analysis(columns + ["wrong"], rows, majority(flags), summary, plot)


class Heatmaps(Experiment):
    BUILDERS = ("cbvh", "spatial", "embree-high")

    def params(self, scene, triangles, profile):
        size = PROFILES[profile]["heat_size"]
        return {"builders": list(self.BUILDERS), "kernel": "binary", "quantity": "work", "width": size, "height": size}

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 30000.0

    def analyse(self, jobs):
        rows, plot, flags, ratios = [], {"scenes": []}, [], []
        for scene, record in jobs:
            outs = dict(zip(self.BUILDERS, record["outputs"]))
            plot["scenes"].append(
                {
                    "label": scene.label,
                    "slug": scene.slug,
                    "images": {b: o["png_base64"] for b, o in outs.items()},
                    "mean": {b: o["mean"] for b, o in outs.items()},
                    "scale": outs["cbvh"]["scale_max"],
                }
            )
            for b, o in outs.items():
                rows.append(
                    [
                        scene.label,
                        b,
                        fmt(o["mean"], 1),
                        o["max"],
                        fmt(o["mean"] / outs["cbvh"]["mean"], 3),
                        fmt(outs["cbvh"]["scale_max"], 1),
                    ]
                )
            ratios.append(
                (
                    scene.label,
                    outs["spatial"]["mean"] / outs["cbvh"]["mean"],
                    outs["embree-high"]["mean"] / outs["cbvh"]["mean"],
                )
            )
            flags.append(outs["spatial"]["mean"] < outs["cbvh"]["mean"])
        summary = (
            "Mean traversal work per pixel (binary kernel, nodes + triangles), relative to cbvh: "
            + "; ".join(f"{n}: spatial {s:.2f}, Embree's tree {e:.2f}" for n, s, e in ratios)
            + ". Confirmed for a scene when spatial's mean is below cbvh's."
        )
        return Analysis(
            ["scene", "builder", "mean work / pixel", "max", "mean / cbvh", "colour scale top"],
            rows,
            majority(flags),
            summary,
            plot,
        )
