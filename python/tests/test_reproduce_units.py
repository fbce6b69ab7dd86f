# SPDX-License-Identifier: MIT
"""The parts of spacebvh.reproduce that need no CLI: scene specifications, job keys, the store, the
ratios between rows and the deterministic view of a result."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import pytest

PYTHON_DIR = Path(__file__).resolve().parents[1]
# An installed package (pip install .) is used as it is; a checkout's python/ only when none has reproduce.
_installed = importlib.util.find_spec("spacebvh")
ON_PATH = _installed is not None and any(
    (Path(p) / "reproduce").is_dir() for p in (_installed.submodule_search_locations or [])
)
if not ON_PATH:
    sys.path.insert(0, str(PYTHON_DIR))

from spacebvh.reproduce.jobs import generated_scene  # noqa: E402
from spacebvh.reproduce.results import deterministic, row_label, speed_ratio  # noqa: E402
from spacebvh.reproduce.scenes import content_hash, default_full_scenes, parse_scene, scene_manifest, shared_scenes_dir  # noqa: E402
from spacebvh.reproduce.store import Store, job_key  # noqa: E402


def test_scene_specs_parse_transforms_into_cli_flags(tmp_path):
    obj = tmp_path / "room.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    scene = parse_scene(f"{obj}@rotate=x:45,y:45,z:45;translate=1 2 3")
    assert scene.source == str(obj.resolve())
    assert scene.flags == ["--rotate", "x:45,y:45,z:45", "--translate", "1", "2", "3"]
    assert scene.label == "room rotated x:45,y:45,z:45 moved 1 2 3"
    assert "/" not in scene.slug and "," not in scene.slug and scene.is_rotated
    assert parse_scene("builtin:interior").flags == []
    with pytest.raises(ValueError, match="rotate"):
        parse_scene("builtin:interior@spin=3")
    with pytest.raises(FileNotFoundError):
        parse_scene(str(tmp_path / "absent.obj"))


def test_content_hash_follows_the_bytes_and_the_transform(tmp_path):
    obj = tmp_path / "a.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    plain = content_hash(parse_scene(str(obj)), "lib1")
    assert plain == content_hash(parse_scene(str(obj)), "lib2")  # a file is its bytes
    assert plain != content_hash(parse_scene(f"{obj}@rotate=x:45"), "lib1")
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n")
    assert plain != content_hash(parse_scene(str(obj)), "lib1")
    builtin = parse_scene("builtin:interior")
    assert content_hash(builtin, "lib1") != content_hash(builtin, "lib2")  # built-ins are the library's


def test_scene_folder_and_manifest_are_arguments_or_environment_variables(tmp_path, monkeypatch):
    monkeypatch.delenv("SPACEBVH_SCENES", raising=False)
    monkeypatch.delenv("SPACEBVH_SCENE_MANIFEST", raising=False)
    scenes = tmp_path / "scenes"
    (scenes / "room").mkdir(parents=True)
    (scenes / "room" / "room.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    checkout = tmp_path / "elsewhere" / "checkout"
    assert shared_scenes_dir(checkout) is None  # nothing beside this checkout
    assert shared_scenes_dir(checkout, scenes) == scenes
    monkeypatch.setenv("SPACEBVH_SCENES", str(scenes))
    assert shared_scenes_dir(checkout) == scenes
    assert shared_scenes_dir(checkout, tmp_path / "absent") is None  # the argument wins over the variable

    assert scene_manifest(None, scenes) is None  # no MANIFEST.md in the folder
    manifest = scenes / "MANIFEST.md"
    manifest.write_text("| scene | camera |\n|---|---|\n| room | `0,0,5,0,0,0,0,1,0,50` |\n")
    assert scene_manifest(None, scenes) == str(manifest)
    with pytest.raises(FileNotFoundError):
        scene_manifest(tmp_path / "absent.md", scenes)
    monkeypatch.setenv("SPACEBVH_SCENE_MANIFEST", str(manifest))
    assert scene_manifest() == str(manifest)

    with_camera = parse_scene(str(scenes / "room" / "room.obj"), manifest)
    assert with_camera.camera_flags == ["--manifest", str(manifest.resolve())]
    assert parse_scene("builtin:interior", manifest).camera_flags == []  # built-in scenes carry their camera
    plain = parse_scene(str(scenes / "room" / "room.obj"))
    assert plain.camera_flags == [] and content_hash(plain, "lib") != content_hash(with_camera, "lib")
    before = content_hash(with_camera, "lib")
    manifest.write_text("| scene | camera |\n|---|---|\n| room | `0,0,6,0,0,0,0,1,0,50` |\n")
    assert content_hash(with_camera, "lib") != before  # another camera, other primary rays: another job

    monkeypatch.delenv("SPACEBVH_SCENE_MANIFEST")
    found, notes = default_full_scenes(None, None)
    assert found == [] and "SPACEBVH_SCENES" in notes[0]


def test_job_keys_are_canonical_and_the_store_round_trips(tmp_path):
    inputs = {"b": [1, 2], "a": {"y": 1, "x": 2}}
    assert job_key(inputs) == job_key({"a": {"x": 2, "y": 1}, "b": [1, 2]})
    assert job_key(inputs) != job_key({"a": {"x": 2, "y": 1}, "b": [2, 1]})
    store = Store(tmp_path)
    key = job_key(inputs)
    assert store.load("exp", "scene", key) is None
    path = store.save("exp", "scene", key, inputs, {"outputs": [1]})
    assert store.load("exp", "scene", key)["result"] == {"outputs": [1]}
    path.write_text(path.read_text()[:20])  # a write cut short: the job runs again
    assert store.load("exp", "scene", key) is None
    store.save("exp", "scene", key, inputs, {"error": "failed"})
    assert store.load("exp", "scene", key) is None  # failures are not results
    assert not list(tmp_path.rglob("*.tmp"))


def _row(name, ms, sah=None):
    row = {"builder": name, "kernel": "k", "random": {"closest_ms_runs": ms, "closest_mrays": 1.0 / ms[0]}}
    if sah is not None:
        row["sah"] = sah
    return row


def test_speed_ratios_pair_the_runs_of_one_round_robin():
    base, row = _row("cbvh (C_o=0.00)", [10.0, 20.0, 10.0], 1.0), _row("spatial (C_o=1.00)", [5.0, 20.0, 8.0], 1.0)
    assert speed_ratio(row, base, "random") == (1.25, 1.0, 2.0)  # per run 2.0, 1.0, 1.25
    assert row_label(base) == "cbvh"
    assert row_label(_row("embree-high", [1.0])) == "embree-high (Embree kernel)"


def test_deterministic_drops_timings_and_keeps_answers():
    result = [
        {
            "threads": 2,
            "scenes": [
                {
                    "rows": [
                        {
                            "builder": "cbvh",
                            "build_ms": 3.0,
                            "sah": 1.0 / 3,
                            "random": {"closest_mrays": 5.0, "wrong": 0},
                        }
                    ]
                }
            ],
        }
    ]
    kept = deterministic(result)
    assert kept == [{"scenes": [{"rows": [{"builder": "cbvh", "sah": round(1.0 / 3, 9), "random": {"wrong": 0}}]}]}]
    assert json.dumps(kept)


def test_generated_scene_is_deterministic_and_valid():
    vertices, triangles = generated_scene("generated:terrain:8")
    assert (vertices, triangles) == generated_scene("generated:terrain:8")
    assert len(triangles) > 2 * 8 * 8
    assert all(1 <= i <= len(vertices) for t in triangles for i in t)
    with pytest.raises(ValueError):
        generated_scene("generated:teapot:8")


def test_termination_counts_the_cells_where_spatial_tests_fewer_boxes_than_cbvh():
    from spacebvh.reproduce.experiments import Termination
    from spacebvh.reproduce.scenes import Scene

    def row(builder, boxes, occlusion_boxes, sah=None):
        kinds = {
            k: {
                "closest_ms_runs": [2.0, 2.0],
                "occlusion_ms_runs": [1.0, 1.0],
                "closest_mrays": 1.0,
                "occlusion_mrays": 2.0,
                "wrong": 0,
            }
            for k in ("random", "primary", "diffuse")
        }
        if sah is not None:
            for k in kinds:
                kinds[k].update(nodes_per_ray=boxes, occlusion_nodes_per_ray=occlusion_boxes)
        return {
            "builder": builder + (" (C_o=1.00)" if sah is not None else ""),
            "kernel": "bvh8",
            **({"sah": sah} if sah is not None else {}),
            **kinds,
        }

    rows = [
        row("cbvh", 20.0, 8.0, 12.0),
        row("spatial", 16.0, 10.0, 10.0),
        row(Termination.SAMPLED, 15.0, 9.0, 10.5),
        row("binned+opt", 14.0, 6.0, 9.0),
        row("embree-high", 17.0, 11.0, 11.0),
        row("embree-high", 0, 0),
    ]
    record = {"outputs": [{"scenes": [{"rows": rows}]}]}
    analysis = Termination("termination", "t", "c", "s", "compare", "m").analyse([(Scene("builtin:interior"), record)])
    # spatial beats cbvh on closest-hit boxes (16 < 20) of every kind, loses on occlusion boxes (10 > 8)
    assert analysis.verdict == "partly confirmed"
    assert "3 of 6" in analysis.summary
    assert analysis.plot["boxes"]["binned+opt"][0]["diffuse"] == (14.0 / 16.0, 6.0 / 10.0)
    assert (
        "embree-high (Embree kernel)" in analysis.plot["speed"]
        and "embree-high (Embree kernel)" not in analysis.plot["boxes"]
    )
    assert len(analysis.table_rows) == 6 and analysis.table_rows[1][3] == "1.000"
