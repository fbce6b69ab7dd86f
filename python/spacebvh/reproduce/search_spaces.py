# SPDX-License-Identifier: MIT
"""The search spaces: the CBVH split against the exhaustive optimum, the grid search space, recursive cost
evaluation, and the full and kd search spaces against CBVH."""

from __future__ import annotations

from .experiment import PROFILES, Analysis, Experiment, compare_params, each_row, fmt, majority, ratio_text, row_wrong
from .results import RAY_KINDS, speed_ratio

# The grid search space's two resolutions. The slides use G = R N^(1/6) with R = 64 and R = 4K; this
# build enumerates every configuration of a G^3 grid exactly (~26 G^6 per node, G <= 16), which at
# those R would put every node at the cap; these are the nearest that finish in minutes.
GRID_RESOLUTIONS = (("grid R=1", "grid=1;gridmax=8"), ("grid R=2", "grid=2;gridmax=8"))


class Optimum(Experiment):
    SPACES = (
        "object (cbvh sweep)",
        "binned",
        "grid, no splitting",
        "spatial (kd planes)*",
        "grid + splitting*",
        "full: object+spatial+grid*",
    )

    def params(self, scene, triangles, profile):
        p = PROFILES[profile]
        return {"nodes": p["optimum_nodes"], "min_refs": 8, "max_refs": p["optimum_max_refs"]}

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 100000.0

    def analyse(self, jobs):
        rows, plot, flags, worst_all, medians = [], {"scenes": [], "ratios": {}}, [], 0.0, []
        for scene, record in jobs:
            nodes = record["outputs"][0].get("scene", {}).get("nodes", 0)
            spaces = record["outputs"][0].get("scene", {}).get("search_spaces", {})
            plot["scenes"].append(scene.label)
            for name in self.SPACES:
                s = spaces.get(name)
                if s is None:
                    continue
                ratios = s.get("ratios", [])
                plot["ratios"].setdefault(name, []).append(ratios)
                n = len(ratios) or max(1, nodes - s["infeasible"])
                rows.append(
                    [
                        scene.label,
                        name,
                        n,
                        fmt(s["median_ratio"], 3),
                        fmt(s["mean_ratio"], 3),
                        fmt(s["max_ratio"], 3),
                        f"{100 * s['at_optimum'] / n:.0f}%",
                        f"{100 * s['below_optimum'] / n:.0f}%",
                        s["infeasible"],
                    ]
                )
            cbvh = spaces.get(self.SPACES[0])
            if cbvh:
                worst_all = max(worst_all, cbvh["max_ratio"])
                medians.append(cbvh["median_ratio"])
                flags.append(cbvh["max_ratio"] >= 3.5)
        if not jobs:
            return Analysis([], [], "no data", "no job finished")
        above = sum(
            1
            for _, r in jobs
            for x in r["outputs"][0]["scene"]["search_spaces"][self.SPACES[0]].get("ratios", [])
            if x > 1 + 1e-6
        )
        total = sum(len(r["outputs"][0]["scene"]["search_spaces"][self.SPACES[0]].get("ratios", [])) for _, r in jobs)
        # The slide shows one node where CBVH is 7x the optimum; we ask how common such gaps are.
        verdict = "confirmed" if worst_all >= 3.5 else "partly confirmed" if above > 0 else "not confirmed"
        size = (
            "as large as the slides' example"
            if worst_all >= 3.5
            else "real but far smaller than the slides' example"
            if above
            else "absent: CBVH found the optimum every time"
        )
        summary = (
            f"On {total} small nodes (8-{self._max_refs(jobs)} triangles) of the scenes' cbvh trees, the CBVH "
            f"split costs {min(medians):.3f}-{max(medians):.3f}x the exhaustive optimum at the median (per scene) "
            f"and at worst {worst_all:.2f}x; it is above the optimum on {above} of {total} nodes. The slides' "
            f"example is about 7x (700 vs 100); on these nodes the gap is {size}."
        )
        return Analysis(
            ["scene", "search space", "nodes", "median x", "mean x", "max x", "at optimum", "below*", "infeasible"],
            rows,
            verdict,
            summary,
            plot,
        )

    @staticmethod
    def _max_refs(jobs):
        return jobs[0][1]["commands"][0]["argv"][jobs[0][1]["commands"][0]["argv"].index("--max-refs") + 1]


class Grid(Experiment):
    limit = "limit_grid"

    def params(self, scene, triangles, profile):
        builders = ["cbvh"] + [f"cbvh@search=object+grid;{setting}" for _, setting in GRID_RESOLUTIONS]
        return compare_params(profile, builders, extra=["--no-grid-splitting"], no_epo=True)

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 2000.0

    @staticmethod
    def label_of(builder: str) -> str:
        for label, setting in GRID_RESOLUTIONS:
            if builder.endswith(setting):
                return label
        return "classical (cbvh)" if builder == "cbvh" else builder

    def analyse(self, jobs):
        rows, plot, flags_cost, flags_speed = [], {"scenes": [], "bars": {}}, [], []
        for scene, label, row, base, _ in each_row(jobs, plot):
            name = self.label_of(label)
            speed = speed_ratio(row, base, "random")
            sah = row["sah"] / base["sah"]
            plot["bars"].setdefault(name, []).append({"speed": speed, "sah": row["sah"], "sah_ratio": sah})
            rows.append(
                [
                    scene.label,
                    name,
                    fmt(row["sah"]),
                    fmt(sah, 3),
                    fmt(row["random"]["closest_mrays"]),
                    ratio_text(speed),
                    row_wrong(row),
                ]
            )
            if name != "classical (cbvh)":
                flags_cost.append(sah < 0.999)
                flags_speed.append(speed[2] < 1.0 or speed[0] < 1.02)
        both = [c and s for c, s in zip(flags_cost, flags_speed)]
        verdict = majority(both)
        summary = (
            f"Grid rows with lower SAH than cbvh: {sum(flags_cost)} of {len(flags_cost)}; of those not faster on "
            f"random rays (median ratio < 1.02): {sum(both)}. Resolutions: "
            + ", ".join(f"{label} (G = ceil(R N^(1/6)) <= 8)" for label, _ in GRID_RESOLUTIONS)
            + "; the slides' R = 64 and R = 4K are beyond this build's exact grid enumeration."
        )
        return Analysis(
            ["scene", "builder", "SAH", "SAH / cbvh", "random Mrays/s", "random speed / cbvh (min-max)", "wrong"],
            rows,
            verdict,
            summary,
            plot,
        )


class Lookahead(Experiment):
    BUILDERS = ("cbvh", "cbvh@lookahead=1", "cbvh@lookahead=2")

    limit = "limit_lookahead"

    def params(self, scene, triangles, profile):
        return compare_params(profile, self.BUILDERS, no_epo=True)

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 8000.0

    def analyse(self, jobs):
        rows, plot, flags = [], {"scenes": [], "points": {}}, []
        for scene, label, row, base, _ in each_row(jobs, plot, self.BUILDERS):
            point = {"scene": scene.label, "sah_ratio": row["sah"] / base["sah"]}
            for kind in RAY_KINDS:
                point[kind] = speed_ratio(row, base, kind)
            plot["points"].setdefault(label, []).append(point)
            rows.append(
                [scene.label, label, fmt(row["sah"]), fmt(point["sah_ratio"], 3)]
                + [ratio_text(point[k]) for k in RAY_KINDS]
                + [row_wrong(row)]
            )
            if label != "cbvh":
                flags.append(point["sah_ratio"] < 0.999 and point["random"][0] < 1.0)
        lower = [p for label in self.BUILDERS[1:] for p in plot["points"].get(label, []) if p["sah_ratio"] < 0.999]
        slower = [p for p in lower if p["random"][0] < 1.0]
        summary = (
            f"Recursive cost evaluation lowered the tree SAH in {len(lower)} of {2 * len(jobs)} trees; "
            f"{len(slower)} of those traced random rays slower than cbvh (median per-run ratio < 1)."
        )
        return Analysis(
            ["scene", "builder", "SAH", "SAH / cbvh"] + [f"{k} speed / cbvh" for k in RAY_KINDS] + ["wrong"],
            rows,
            majority(flags),
            summary,
            plot,
        )


class SearchSpaces(Experiment):
    BUILDERS = ("cbvh", "full", "kdbvh")

    limit = "limit_full"

    def params(self, scene, triangles, profile):
        return compare_params(profile, self.BUILDERS, no_epo=True)

    def weight(self, scene, triangles, profile):
        return 1.0 + triangles / 4000.0

    def analyse(self, jobs):
        rows, plot, flags = [], {"scenes": [], "bars": {}}, []
        for scene, label, row, base, _ in each_row(jobs, plot, self.BUILDERS):
            random_ratio = speed_ratio(row, base, "random")
            packet_ratio = speed_ratio(row, base, "primary")
            plot["bars"].setdefault(label, []).append({"random": random_ratio, "primary": packet_ratio})
            rows.append(
                [
                    scene.label,
                    label,
                    row["primary"].get("kernel", ""),
                    fmt(row["sah"]),
                    fmt(row["random"]["closest_mrays"]),
                    ratio_text(random_ratio),
                    fmt(row["primary"]["closest_mrays"]),
                    ratio_text(packet_ratio),
                    row_wrong(row),
                ]
            )
            if label != "cbvh":
                flags += [random_ratio[0] > 1.0, packet_ratio[0] > 1.0]
        faster = sum(flags)
        summary = (
            f"Full and KDBVH against CBVH: faster in {faster} of {len(flags)} (builder, scene, ray kind) cells "
            "(random rays: BVH8 single-ray kernel; primary rays: 8x8 packets with frustum culling)."
        )
        return Analysis(
            [
                "scene",
                "builder",
                "packet kernel",
                "SAH",
                "random Mrays/s",
                "random / cbvh",
                "primary (packets) Mrays/s",
                "primary / cbvh",
                "wrong",
            ],
            rows,
            majority(flags),
            summary,
            plot,
        )
