# SPDX-License-Identifier: MIT
"""Space partitioning: the spatial builder against pre-splitting (ESC, EVH) and SBVH, and the role of the
overlap penalty C_o."""

from __future__ import annotations

from .experiment import PROFILES, Analysis, Experiment, compare_params, each_row, fmt, majority, ratio_text, row_wrong
from .results import RAY_KINDS, rows_by_label, speed_ratio


class Presplit(Experiment):
    BUILDERS = ("cbvh", "esc", "evh", "sbvh", "spatial")

    def select(self, scenes, triangles, profile):
        chosen = [s for s in scenes if "sponza" in s.base_name or "interior" in s.base_name]
        return (chosen or scenes), ([] if chosen else ["no Sponza-like scene given: run on every scene"])

    def params(self, scene, triangles, profile):
        return compare_params(profile, self.BUILDERS)

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 15000.0

    def analyse(self, jobs):
        rows, plot, flags = [], {"scenes": [], "bars": {}}, []
        for scene, label, row, base, by in each_row(jobs, plot, self.BUILDERS):
            ratios = {k: speed_ratio(row, base, k) for k in RAY_KINDS}
            plot["bars"].setdefault(label, []).append(ratios)
            rows.append(
                [scene.label, label, fmt(row["sah"]), fmt(row.get("epo")), row["references"]]
                + [ratio_text(ratios[k]) for k in RAY_KINDS]
                + [row_wrong(row)]
            )
            if label == self.BUILDERS[-1]:  # the scene's last row: spatial against the better pre-splitter
                best_presplit = max(speed_ratio(by[b], base, "random")[0] for b in ("esc", "evh"))
                flags.append(ratios["random"][0] > best_presplit)
        summary = "Random-ray speed of the spatial builder against the better of ESC and EVH: " + "; ".join(
            f"{s}: spatial {b['spatial'][i]['random'][0]:.2f}x, esc {b['esc'][i]['random'][0]:.2f}x, "
            f"evh {b['evh'][i]['random'][0]:.2f}x, sbvh {b['sbvh'][i]['random'][0]:.2f}x cbvh"
            for i, s in enumerate(plot["scenes"])
            for b in [plot["bars"]]
        )
        return Analysis(
            ["scene", "builder", "SAH", "EPO", "references"] + [f"{k} speed / cbvh" for k in RAY_KINDS] + ["wrong"],
            rows,
            majority(flags),
            summary,
            plot,
        )


class Overlap(Experiment):
    limit = "limit_overlap"

    def select(self, scenes, triangles, profile):
        kept, notes = super().select(scenes, triangles, profile)
        if PROFILES[profile]["skip_rotated_overlap"]:
            notes += [
                f"{s.label}: not in the quick run (its cbvh-like rows trace slowly)" for s in kept if s.is_rotated
            ]
            kept = [s for s in kept if not s.is_rotated]
        return kept, notes

    def params(self, scene, triangles, profile):
        return compare_params(profile, [f"spatial@co={c}" for c in PROFILES[profile]["co_values"]])

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 8000.0

    def analyse(self, jobs):
        co_values = [label.split("=", 1)[1] for label in rows_by_label(jobs[0][1]["outputs"][0]) if "@co=" in label]
        rows, plot, flags, best = [], {"co": [float(c) for c in co_values], "scenes": {}}, [], []
        for scene, record in jobs:
            output = record["outputs"][0]
            by = rows_by_label(output)
            triangles = output["scenes"][0]["triangles"]
            base = by[f"spatial@co={co_values[0]}"]
            series = {"sah": [], "epo": [], "refs": [], **{k: [] for k in RAY_KINDS}}
            for c in co_values:
                row = by[f"spatial@co={c}"]
                series["sah"].append(row["sah"])
                series["epo"].append(row.get("epo", float("nan")))
                series["refs"].append(row["references"] / triangles)
                for k in RAY_KINDS:
                    series[k].append(speed_ratio(row, base, k))
                rows.append(
                    [
                        scene.label,
                        c,
                        fmt(row["sah"]),
                        fmt(row.get("epo")),
                        row["references"],
                        fmt(row["references"] / triangles, 3),
                    ]
                    + [ratio_text(series[k][-1]) for k in RAY_KINDS]
                    + [row_wrong(row)]
                )
            plot["scenes"][scene.label] = series
            top = max(range(len(co_values)), key=lambda i: series["random"][i][0])
            best.append(f"{scene.label}: C_o = {co_values[top]} ({series['random'][top][0]:.2f}x)")
            flags.append(max(r[1] for r in series["random"][1:]) > 1.0)  # some C_o > 0 faster in every run
        summary = (
            "Fastest random rays relative to C_o = 0 (plain SAH with spatial splits): "
            + "; ".join(best)
            + ". Confirmed for a scene when some C_o > 0 is faster than C_o = 0 in every timed run."
        )
        return Analysis(
            ["scene", "C_o", "SAH", "EPO", "references", "refs / triangles"]
            + [f"{k} speed / C_o=0" for k in RAY_KINDS]
            + ["wrong"],
            rows,
            majority(flags),
            summary,
            plot,
        )
