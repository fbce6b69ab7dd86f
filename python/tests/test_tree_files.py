# SPDX-License-Identifier: MIT
"""Tree files and pickling from Python: a saved or pickled tree answers exactly as the tree it came
from, and damaged or mismatched files raise spacebvh.Error naming the file."""

import pickle

import numpy as np
import pytest

import spacebvh


def _rays(scene, count=20000):
    return spacebvh.random_rays(scene, count, seed=7)


@pytest.fixture(scope="module")
def scene():
    return spacebvh.load_scene("builtin:interior")


@pytest.mark.parametrize("builder", ["binned", "spatial"])
def test_saved_tree_answers_as_the_built_one(tmp_path, scene, builder):
    bvh = spacebvh.build(scene, builder)
    path = tmp_path / "tree.sbvh"
    bvh.save(str(path))
    loaded = spacebvh.load_bvh(str(path), scene)
    assert loaded.builder == bvh.builder and loaded.node_count == bvh.node_count and loaded.sah == bvh.sah
    origins, directions = _rays(scene)
    t0, p0, _, _ = spacebvh.Tracer(bvh).intersect(origins, directions)
    t1, p1, _, _ = spacebvh.Tracer(loaded).intersect(origins, directions)
    np.testing.assert_array_equal(p0, p1)
    np.testing.assert_array_equal(t0, t1)


def test_pickled_tree_and_scene_round_trip(scene):
    bvh = spacebvh.build(scene, "spatial")
    copy = pickle.loads(pickle.dumps(bvh))
    assert copy.scene.triangle_count == scene.triangle_count and copy.sah == bvh.sah
    origins, directions = _rays(scene)
    np.testing.assert_array_equal(
        spacebvh.Tracer(bvh).occluded(origins, directions), spacebvh.Tracer(copy).occluded(origins, directions)
    )


def test_damaged_and_mismatched_files_are_refused(tmp_path, scene):
    bvh = spacebvh.build(scene, "binned")
    path = tmp_path / "tree.sbvh"
    bvh.save(str(path))
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x10
    damaged = tmp_path / "damaged.sbvh"
    damaged.write_bytes(bytes(data))
    with pytest.raises(spacebvh.Error, match="damaged.sbvh"):
        spacebvh.load_bvh(str(damaged), scene)
    truncated = tmp_path / "truncated.sbvh"
    truncated.write_bytes(path.read_bytes()[:100])
    with pytest.raises(spacebvh.Error, match="truncated.sbvh"):
        spacebvh.load_bvh(str(truncated), scene)
    other = spacebvh.load_scene("builtin:organic")
    with pytest.raises(spacebvh.Error, match="geometry"):
        spacebvh.load_bvh(str(path), other)
