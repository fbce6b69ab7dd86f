# SPDX-License-Identifier: MIT
"""One job: one experiment on one scene, run whole on one worker by calling the `spacebvh` CLI.

This module imports only the standard library, so a Dask worker that lacks the package can run it
(the client ships it by value). A job never measures anything itself: every number comes from the
CLI's own JSON, and every speed figure from one `compare` invocation (its round-robin timing), so the
ratios between rows stay honest whatever else the worker does between jobs.
"""

from __future__ import annotations

import base64
import json
import os
import platform
import random
import shutil
import socket
import subprocess
import tempfile
import time
from pathlib import Path

# Raised into the result's "error" when the CLI fails; the client records it and the report shows it.
CLI_TIMEOUT_S = 3600


def find_cli(hint: str | None = None) -> str:
    """The `spacebvh` executable: $SPACEBVH_CLI, else `hint` (the client's) when it exists here, else the
    command installed with the package (spacebvh.cli.executable: beside the interpreter, whether or not
    that folder is on PATH, then PATH), else <repo>/build/spacebvh next to this source tree. A worker
    given this module alone has no package: there PATH stands in for the package's lookup."""
    env = os.environ.get("SPACEBVH_CLI")
    if env:
        return env
    if hint and Path(hint).is_file():
        return hint
    try:
        from spacebvh.cli import executable
    except ImportError:
        found = shutil.which("spacebvh")
    else:
        try:
            found = executable()
        except FileNotFoundError:
            found = None
    if found:
        return found
    here = Path(__file__).resolve()
    if len(here.parents) > 3 and (here.parents[3] / "build" / "spacebvh").is_file():  # a checkout's build
        return str(here.parents[3] / "build" / "spacebvh")
    raise FileNotFoundError(
        "spacebvh CLI not found: set SPACEBVH_CLI, put spacebvh on PATH, or build it (scripts/build.sh)"
    )


def _run(cli: str, args: list[str], workdir: Path, record: dict) -> dict:
    """Runs `spacebvh ARGS --json FILE` and returns the parsed JSON; the command (with `spacebvh` for the
    executable) and its stdout go into `record`."""
    json_path = workdir / f"out{len(record['commands'])}.json"
    argv = [cli, *args, "--json", str(json_path)]
    shown = ["spacebvh", *args, "--json", json_path.name]
    start = time.perf_counter()
    completed = subprocess.run(argv, capture_output=True, text=True, timeout=CLI_TIMEOUT_S, cwd=workdir)
    seconds = time.perf_counter() - start
    record["commands"].append({"argv": shown, "wall_s": round(seconds, 3), "returncode": completed.returncode})
    record["stdout"].append(completed.stdout)
    if completed.returncode != 0:
        raise RuntimeError(f"{' '.join(shown)} failed ({completed.returncode}): {completed.stderr.strip()[-2000:]}")
    with open(json_path) as f:
        return json.load(f)


def _scene_args(scene: dict, workdir: Path, camera: bool = False) -> list[str]:
    """The scene operand and its transform flags; with `camera`, also what finds its camera (--manifest)."""
    return [_materialize(scene, workdir), *scene.get("flags", []), *(scene.get("camera_flags", []) if camera else [])]


def _thread_args(spec: dict) -> list[str]:
    return ["--threads", str(spec["threads"])] if spec.get("threads") else []


def _compare_args(params: dict) -> list[str]:
    args = [
        "--builders",
        ",".join(params["builders"]),
        "--embree",
        ",".join(params.get("embree", ["high"])) or "none",
        "--embree-packets",
        ",".join(params.get("embree_packets", [])) or "none",
        "--kernel",
        ",".join(params.get("kernels", ["auto"])),
        "--random",
        str(params["random"]),
        "--width",
        str(params["width"]),
        "--height",
        str(params["height"]),
        "--runs",
        str(params["runs"]),
        "--build-runs",
        str(params["build_runs"]),
        "--seed",
        "1",
        "--quiet",
    ]
    if params.get("no_epo"):
        args.append("--no-epo")
    return args + list(params.get("extra", []))


def _job_compare(spec, cli, workdir, record):
    params = spec["params"]
    return [
        _run(
            cli,
            ["compare", *_scene_args(spec["scene"], workdir, camera=True), *_compare_args(params), *_thread_args(spec)],
            workdir,
            record,
        )
    ]


def _job_optimum(spec, cli, workdir, record):
    p = spec["params"]
    args = [
        "optimum",
        *_scene_args(spec["scene"], workdir),
        "--nodes",
        str(p["nodes"]),
        "--min-refs",
        str(p["min_refs"]),
        "--max-refs",
        str(p["max_refs"]),
        "--quiet",
        *p.get("extra", []),
        *_thread_args(spec),
    ]
    return [_run(cli, args, workdir, record)]


def _job_heatmap(spec, cli, workdir, record):
    """One render per builder of the same view; the first fixes the colour scale for the others so the
    pictures compare pixel for pixel."""
    p = spec["params"]
    outputs, scale = [], None
    for builder in p["builders"]:
        png = workdir / f"heat_{builder}.png"
        args = [
            "render",
            *_scene_args(spec["scene"], workdir, camera=True),
            "--builder",
            builder,
            "--heatmap",
            "--kernel",
            p["kernel"],
            "--quantity",
            p["quantity"],
            "--width",
            str(p["width"]),
            "--height",
            str(p["height"]),
            "-o",
            png.name,
            "--quiet",
            *_thread_args(spec),
        ]
        if scale is not None:
            args += ["--scale-max", repr(scale)]
        out = _run(cli, args, workdir, record)
        if scale is None:
            scale = out["scale_max"]
        out["png_base64"] = base64.b64encode(png.read_bytes()).decode()
        outputs.append(out)
    return outputs


# ---- growing subsets (build time against N) -------------------------------------------------------


def _obj_faces(path: Path):
    """Vertex lines and triangles (1-based vertex indices, fan-triangulated, negative indices resolved)."""
    vertex_lines, triangles = [], []
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                vertex_lines.append(line if line.endswith("\n") else line + "\n")
            elif line.startswith("f "):
                ids = []
                for token in line.split()[1:]:
                    i = int(token.split("/")[0])
                    ids.append(i if i > 0 else len(vertex_lines) + 1 + i)
                for k in range(1, len(ids) - 1):
                    triangles.append((ids[0], ids[k], ids[k + 1]))
    return vertex_lines, triangles


GENERATOR_VERSION = 1  # part of a generated scene's hash: bump when its triangles change


def generated_scene(source: str):
    """`generated:terrain:SIZE`: a bumpy height field of 2 SIZE^2 triangles with thin walls standing on it
    (long slivers, where centroids mislead object partitioning), deterministic for SIZE. Vertex lines and
    1-based triangles."""
    kind, size = source.split(":")[1], int(source.split(":")[2])
    if kind != "terrain" or size < 2:
        raise ValueError(f"unknown generated scene '{source}' (generated:terrain:SIZE, SIZE >= 2)")
    rng = random.Random(size)
    bumps = [(rng.random(), rng.random(), 0.05 + 0.2 * rng.random(), rng.random() - 0.3) for _ in range(24)]
    vertex_lines = []
    for j in range(size + 1):
        for i in range(size + 1):
            x, z = i / size, j / size
            y = sum(h * max(0.0, 1 - ((x - bx) ** 2 + (z - bz) ** 2) / r**2) for bx, bz, r, h in bumps)
            vertex_lines.append(f"v {x:.6f} {y:.6f} {z:.6f}\n")
    triangles = []
    for j in range(size):
        for i in range(size):
            a = j * (size + 1) + i + 1
            triangles += [(a, a + 1, a + size + 1), (a + 1, a + size + 2, a + size + 1)]
    for _ in range(max(2, size // 4)):  # walls: strips of long thin triangles across the field
        x0, z0, x1, z1 = (rng.random() for _ in range(4))
        for k in range(size):
            t0, t1 = k / size, (k + 1) / size
            first = len(vertex_lines) + 1
            for t in (t0, t1):
                px, pz = x0 + (x1 - x0) * t, z0 + (z1 - z0) * t
                vertex_lines += [f"v {px:.6f} -0.2 {pz:.6f}\n", f"v {px:.6f} 0.6 {pz:.6f}\n"]
            triangles += [(first, first + 2, first + 1), (first + 1, first + 2, first + 3)]
    return vertex_lines, triangles


def _write_obj(path: Path, vertex_lines, triangles):
    with open(path, "w") as f:
        f.writelines(vertex_lines)
        f.writelines(f"f {a} {b} {c}\n" for a, b, c in triangles)


def _materialize(scene: dict, workdir: Path) -> str:
    """The path the CLI reads: the scene's own, or a generated scene written into the job's folder."""
    if not scene["source"].startswith("generated:"):
        return scene["source"]
    path = workdir / (scene["source"].replace(":", "_") + ".obj")
    if not path.exists():
        _write_obj(path, *generated_scene(scene["source"]))
    return path.name


def _job_scaling(spec, cli, workdir, record):
    """Every k-th triangle of the scene for each k, so each subset spans the whole scene; one `compare`
    per subset (its builders side by side, build time the median of build_runs)."""
    p = spec["params"]
    scene = spec["scene"]
    if scene["source"].startswith("generated:"):
        vertex_lines, triangles = generated_scene(scene["source"])
    else:
        vertex_lines, triangles = _obj_faces(Path(scene["source"]))
    outputs = []
    for k in p["strides"]:
        subset = triangles[::k]
        path = workdir / f"subset_{k}.obj"
        _write_obj(path, vertex_lines, subset)
        args = ["compare", path.name, *scene.get("flags", []), *_compare_args(p), *_thread_args(spec)]
        out = _run(cli, args, workdir, record)
        out["stride"] = k
        outputs.append(out)
        path.unlink()
    return outputs


KINDS = {"compare": _job_compare, "optimum": _job_optimum, "heatmap": _job_heatmap, "scaling": _job_scaling}


def run_job(spec: dict) -> dict:
    """Runs one job and returns its record: the exact commands, their JSON outputs and stdout, where and
    how long. Failures come back as a record with "error" so one bad scene does not sink a run."""
    record = {
        "commands": [],
        "stdout": [],
        "host": socket.gethostname(),
        "platform": platform.platform(),
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }
    start = time.perf_counter()
    try:
        cli = find_cli(spec.get("cli"))
        with tempfile.TemporaryDirectory(prefix="spacebvh-reproduce-") as tmp:
            record["outputs"] = KINDS[spec["kind"]](spec, cli, Path(tmp), record)
    except Exception as error:  # noqa: BLE001 - reported, not hidden
        record["error"] = f"{type(error).__name__}: {error}"
    record["wall_s"] = round(time.perf_counter() - start, 3)
    return record
