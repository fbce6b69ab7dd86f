# SPDX-License-Identifier: MIT
"""`python -m spacebvh.reproduce`: runs the paper's experiments as independent Dask jobs (one scene and
one experiment each, measured whole on one worker), keeps each job's result in a store keyed by its
inputs, and writes the report."""

from __future__ import annotations

import argparse
import hashlib
import importlib.util
import json
import os
import platform
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from . import jobs as jobs_module
from .experiments import BY_ID, EXPERIMENTS, PROFILES, count_wrong
from .scenes import (
    QUICK_SCENES,
    Scene,
    content_hash,
    default_full_scenes,
    parse_scene,
    scene_manifest,
    shared_scenes_dir,
)
from .store import Store, job_key

# Part of every job's key: bump when a job's meaning changes (what it runs or how it reads the CLI).
JOB_VERSION = 1
REPO = Path(__file__).resolve().parents[3]


def parse_args(argv=None):
    parser = argparse.ArgumentParser(
        prog="spacebvh-reproduce",
        description="Run the experiments of Popov et al. 2009 (slides in ../shared/seed) with spacebvh as Dask jobs "
        "and write a self-contained HTML report with figures, tables and raw JSON.",
    )
    parser.add_argument(
        "--quick", action="store_true", help="a reduced run on the built-in scenes (a few minutes on 2 cores)"
    )
    parser.add_argument(
        "--scenes",
        nargs="+",
        metavar="SCENE",
        help="scene files or builtin:NAME, each optionally with @rotate=x:45,y:45,z:45;scale=S;"
        "translate=X Y Z (default: the shared scenes of --scenes-dir and crytek_sponza rotated "
        "45/45/45)",
    )
    parser.add_argument(
        "--scenes-dir",
        type=Path,
        metavar="DIR",
        help="the shared scene folder of the default scenes (default: $SPACEBVH_SCENES, else "
        "../shared/scenes beside the checkout)",
    )
    parser.add_argument(
        "--manifest",
        type=Path,
        metavar="FILE",
        help="the scene collection's MANIFEST.md, whose camera table gives a scene file's camera "
        "(default: $SPACEBVH_SCENE_MANIFEST, else MANIFEST.md in the default scenes' folder)",
    )
    parser.add_argument(
        "--experiments",
        default=",".join(e.id for e in EXPERIMENTS),
        help="comma-separated experiments (default: all): " + ", ".join(e.id for e in EXPERIMENTS),
    )
    parser.add_argument("--out", default="reproduce-report", type=Path, help="report directory (default: %(default)s)")
    parser.add_argument(
        "--store",
        type=Path,
        help="result store, one JSON file per job: what reruns skip and --report-only reads; the "
        "report names its files but does not link them (default: OUT/jobs)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="send the jobs to this running Dask scheduler (default: an in-process cluster with one "
        "worker, one job at a time, so timings are undisturbed)",
    )
    parser.add_argument(
        "--threads", type=int, default=0, help="threads each job's spacebvh uses (default 0: all cores of its worker)"
    )
    parser.add_argument(
        "--library-version", help="what identifies the library in job keys (default: sha256 of the spacebvh executable)"
    )
    half = parser.add_mutually_exclusive_group()
    half.add_argument("--jobs-only", action="store_true", help="run the missing jobs, write no report")
    half.add_argument("--report-only", action="store_true", help="write the report from the store, run no job")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    unknown = set(args.experiments.split(",")) - set(BY_ID)
    if unknown:
        parser.error(f"unknown experiments: {', '.join(sorted(unknown))}")
    if args.threads < 0:
        parser.error("--threads must be >= 0")
    return args


def library_version(cli: str, override: str | None) -> str:
    if override:
        return override
    digest = hashlib.sha256(Path(cli).read_bytes()).hexdigest()
    return f"spacebvh-cli-sha256:{digest[:16]}"


def git_revision() -> str:
    try:
        rev = subprocess.run(
            ["git", "-C", str(REPO), "describe", "--always", "--dirty"], capture_output=True, text=True, timeout=10
        ).stdout.strip()
        return rev or "-"
    except (OSError, subprocess.SubprocessError):
        return "-"


def machine() -> dict:
    cpu = platform.processor() or "-"
    memory = 0.0
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                memory = int(line.split()[1]) / 2**20
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory_gib": memory,
        "platform": platform.platform(),
        "host": platform.node(),
    }


def versions() -> dict:
    out = {"python": platform.python_version()}
    for name in ("dask", "distributed", "matplotlib", "numpy", "tqdm"):
        try:
            out[name] = __import__(name).__version__
        except Exception:  # noqa: BLE001
            pass
    return out


def triangle_count(cli: str, scene: Scene, store: Store, scene_hash: str) -> int:
    """The scene's triangle count (what decides whether the costly experiments fit), cached by hash."""
    if scene.source.startswith("generated:"):
        return len(jobs_module.generated_scene(scene.source)[1])
    cache = store.root / "scene_info" / f"{scene_hash[:24]}.json"
    if cache.is_file():
        return json.loads(cache.read_text())["triangles"]
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "info.json"
        subprocess.run([cli, "info", scene.source, *scene.flags, "--json", str(out)], check=True, capture_output=True)
        info = json.loads(out.read_text())
    cache.parent.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(info))
    return info["triangles"]


class Job:
    def __init__(
        self, experiment, scene: Scene, scene_hash: str, params: dict, lib: str, threads: int, cli: str, weight: float
    ):
        self.experiment, self.scene, self.weight = experiment, scene, weight
        self.inputs = {
            "experiment": experiment.id,
            "kind": experiment.kind,
            "job_version": JOB_VERSION,
            "scene_hash": scene_hash,
            "scene_flags": scene.flags,
            "params": params,
            "library_version": lib,
            "threads": threads or None,
        }
        self.key = job_key(self.inputs)
        self.spec = {
            "kind": experiment.kind,
            "scene": scene.to_json(),
            "params": params,
            "threads": threads or None,
            "cli": cli,
        }
        self.name = f"{experiment.id}/{scene.slug}"


def plan(args, cli: str, lib: str, store: Store):
    profile = "quick" if args.quick else "full"
    notes = []
    if args.scenes:
        manifest = scene_manifest(args.manifest)
        scenes = [parse_scene(s, manifest) for s in args.scenes]
    elif args.quick:
        scenes = [parse_scene(s) for s in QUICK_SCENES]
    else:
        root = shared_scenes_dir(REPO, args.scenes_dir)
        scenes, notes = default_full_scenes(root, scene_manifest(args.manifest, root))
    hashes = {s: content_hash(s, lib) for s in scenes}
    triangles = {s: triangle_count(cli, s, store, hashes[s]) for s in scenes}
    selected_ids = args.experiments.split(",")
    planned, skipped = [], {}
    for experiment in EXPERIMENTS:
        if experiment.id not in selected_ids:
            continue
        chosen, why = experiment.select(scenes, triangles, profile)
        skipped[experiment.id] = why
        for scene in chosen:
            if scene not in hashes:
                hashes[scene] = content_hash(scene, lib)
                triangles[scene] = triangle_count(cli, scene, store, hashes[scene])
            n = triangles[scene]
            planned.append(
                Job(
                    experiment,
                    scene,
                    hashes[scene],
                    experiment.params(scene, n, profile),
                    lib,
                    args.threads,
                    cli,
                    experiment.weight(scene, n, profile),
                )
            )
    return profile, scenes, hashes, triangles, planned, skipped, notes


def run_jobs(pending: list[Job], store: Store, scheduler: str | None, progress: bool) -> tuple[list[str], list[str]]:
    """Runs the jobs through Dask, saving each result as it arrives; returns (done, failed) job names."""
    if not pending:
        return [], []
    import logging

    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    with tempfile.TemporaryDirectory() as folder:
        if scheduler:
            client, cluster = Client(scheduler), None
            run_job = ship_jobs_module(client, Path(folder))
        else:
            cluster = LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None)
            client, run_job = Client(cluster), jobs_module.run_job
        return _dispatch(client, cluster, run_job, pending, store, progress)


def ship_jobs_module(client, folder: Path):
    """Workers need no copy of this package: Dask's upload_file sends them the job code (standard library
    only) as a module named after its content, and the tasks refer to that module."""
    source = Path(jobs_module.__file__).read_bytes()
    name = "spacebvh_reproduce_jobs_" + hashlib.sha256(source).hexdigest()[:12]
    path = folder / f"{name}.py"
    path.write_bytes(source)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # so the client pickles run_job by this name
    spec.loader.exec_module(module)
    client.upload_file(str(path))
    return module.run_job


def _dispatch(client, cluster, run_job, pending, store, progress):
    from distributed import as_completed
    from tqdm import tqdm

    done, failed = [], []
    try:
        futures = {}
        for job in pending:
            future = client.submit(
                run_job, job.spec, key=f"reproduce-{job.name}-{job.key[:16]}-{time.time_ns()}", pure=False
            )
            futures[future] = job
        bar = tqdm(
            total=round(sum(j.weight for j in pending), 1),
            unit="work",
            disable=not progress,
            bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} [{elapsed}<{remaining}] {postfix}",
            file=sys.stderr,
        )
        for future in as_completed(futures):
            job = futures[future]
            try:
                record = future.result()
            except Exception as error:  # noqa: BLE001 - a lost worker, not the job's own error
                record = {"error": f"{type(error).__name__}: {error}", "commands": [], "wall_s": 0, "host": "-"}
            if "error" in record:
                failed.append(job.name)
                print(f"spacebvh-reproduce: job {job.name} failed: {record['error']}", file=sys.stderr)
            else:
                store.save(job.experiment.id, job.scene.slug, job.key, job.inputs, record)
                done.append(job.name)
            bar.set_postfix_str(job.name)
            bar.update(job.weight)
        bar.close()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return done, failed


def timing_spread(records) -> float | None:
    """The run's timing noise: the median over every (row, ray kind) of a compare run of the width of its
    per-run ratio to the first row, (max - min) / median. Differences smaller than this are not resolved."""
    import statistics

    from .results import RAY_KINDS, speed_ratio

    widths = []
    for record in records:
        for output in record.get("outputs", []):
            for scene in output.get("scenes", []):
                base = scene["rows"][0]
                for row in scene["rows"][1:]:
                    for kind in RAY_KINDS:
                        med, lo, hi = speed_ratio(row, base, kind)
                        if med > 0 and lo != hi:
                            widths.append((hi - lo) / med)
    return statistics.median(widths) if widths else None


def main(argv=None) -> int:
    args = parse_args(argv)
    start = time.perf_counter()
    cli = jobs_module.find_cli()
    lib = library_version(cli, args.library_version)
    out = args.out.resolve()
    store = Store((args.store or out / "jobs").resolve())
    profile, scenes, hashes, triangles, planned, skipped, notes = plan(args, cli, lib, store)

    cached = [j for j in planned if store.load(j.experiment.id, j.scene.slug, j.key) is not None]
    pending = [j for j in planned if j not in cached]
    print(
        f"spacebvh-reproduce: {len(planned)} jobs, {len(cached)} in the store, {len(pending)} to run"
        + (" (--report-only: none run)" if args.report_only else ""),
        file=sys.stderr,
    )
    done, failed = ([], []) if args.report_only else run_jobs(pending, store, args.scheduler, not args.no_progress)

    command = "python -m spacebvh.reproduce " + " ".join(
        shlex.quote(a) for a in (argv if argv is not None else sys.argv[1:])
    )
    if done:  # the runs that produced the store's results, for the report (a --report-only run adds none)
        history = store.root / "runs.json"
        runs = json.loads(history.read_text()) if history.is_file() else []
        runs.append(
            {
                "command": command,
                "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
                "jobs_run": len(done),
                "jobs_failed": len(failed),
                "wall_s": round(time.perf_counter() - start, 1),
                "host": platform.node(),
                "scheduler": args.scheduler or "local",
            }
        )
        store.root.mkdir(parents=True, exist_ok=True)
        history.write_text(json.dumps(runs, indent=1))
    out.mkdir(parents=True, exist_ok=True)
    run_log = {
        "jobs_total": len(planned),
        "jobs_cached": [j.name for j in cached],
        "jobs_run": done,
        "jobs_failed": failed,
        "wall_s": round(time.perf_counter() - start, 1),
    }
    if args.jobs_only:
        (out / "run.json").write_text(json.dumps(run_log, indent=1))
        return 1 if failed else 0

    from .report import write_report

    entries = []
    for experiment in EXPERIMENTS:
        if experiment.id not in args.experiments.split(","):
            continue
        found, missing = [], []
        for job in (j for j in planned if j.experiment is experiment):
            stored = store.load(experiment.id, job.scene.slug, job.key)
            if stored is None:
                missing.append(job.scene.label)
            else:
                found.append((job.scene, stored["result"], store.path(experiment.id, job.scene.slug, job.key)))
        analysis = experiment.analyse([(s, r) for s, r, _ in found]) if found else None
        if analysis is None:
            from .experiments import Analysis

            analysis = Analysis([], [], "no data", "no job of this experiment has a result in the store")
        analysis.wrong, analysis.embree_wrong, analysis.verified_runs = count_wrong([(s, r) for s, r, _ in found])
        job_notes = list(skipped.get(experiment.id, [])) + [
            f"{m}: no result in the store (job missing or failed)" for m in missing
        ]
        entries.append((experiment, analysis, found, job_notes))

    spread = timing_spread([r for _, _, found, _ in entries for _, r, _ in found])
    hosts = sorted({r["host"] for _, a, found, _ in entries for _, r, _ in found})
    environment = {
        "command": command,
        "profile": profile,
        "library_version": lib,
        "git": git_revision(),
        "cli": cli,
        "store": os.path.relpath(store.root, out),
        "machine": machine(),
        "job_hosts": hosts,
        "versions": versions(),
        "scheduler": args.scheduler or "in-process LocalCluster, 1 worker, 1 thread",
        "threads_per_job": args.threads or "all cores of the worker",
        "profile_settings": PROFILES[profile],
        "scenes": [
            {
                "label": s.label,
                "source": s.source,
                "flags": s.flags,
                "manifest": s.manifest or None,
                "sha256": hashes[s],
                "triangles": triangles[s],
            }
            for s in scenes
        ],
        "jobs_total": len(planned),
        "jobs_run": len(done),
        "jobs_cached": len(cached),
        "jobs_failed": failed,
        "notes": notes,
        "job_runs": json.loads((store.root / "runs.json").read_text()) if (store.root / "runs.json").is_file() else [],
        "timing_spread": spread,
        "wall_s": time.perf_counter() - start,
    }
    index = write_report(out, entries, environment, store.root)
    run_log["wall_s"] = round(time.perf_counter() - start, 1)
    (out / "run.json").write_text(json.dumps(run_log, indent=1))
    print(
        f"spacebvh-reproduce: report {index} ({run_log['wall_s']:.0f} s; {len(done)} jobs run, {len(failed)} failed)",
        file=sys.stderr,
    )
    return 1 if failed else 0
