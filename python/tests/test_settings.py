# SPDX-License-Identifier: MIT
"""build()'s keywords are exactly the build settings (spacebvh.build_settings(): the table the command
line's flags and compare row keys are made from, tests/test_settings.cpp): each given a value other than
its default reaches the tree's recipe and nothing else; an unknown keyword is refused with the list;
docs/python.md lists every one; Quality, the memory limit and the termination-aware builds work."""

import math
import pathlib
import re

import numpy as np
import pytest

import spacebvh

REPOSITORY = pathlib.Path(__file__).resolve().parents[2]
SETTINGS = spacebvh.build_settings()
NAMES = [setting["name"] for setting in SETTINGS]
# Every build of these tests traces this many termination rays, so that the settings that need them
# (termination_optimize) are valid alone.
BASE = {"termination_rays": 100}


def as_python(setting):
    """The setting's example as a caller passes it (bytes as text: "64G")."""
    text, kind = setting["example"], setting["type"]
    if kind == "number":
        return float(text)
    if kind == "whole":
        return int(text)
    if kind == "flag":
        return text == "1"
    return text


def as_stored(setting):
    """The example as Bvh.settings reports it."""
    value = as_python(setting)
    if setting["type"] == "bytes":
        number, unit = re.fullmatch(r"([0-9.]+)([KMGT]?)", value).groups()
        return int(float(number) * 1024 ** (" KMGT".index(unit or " ")))
    return value


@pytest.fixture(scope="module")
def scene():
    """A few hundred random triangles: quick to build with any setting."""
    rng = np.random.default_rng(7)
    corners = rng.random((300, 1, 3)) * 10 + rng.random((300, 3, 3))
    return spacebvh.mesh(corners.reshape(-1, 3).astype(np.float32), np.arange(900).reshape(-1, 3))


@pytest.fixture(scope="module")
def base_settings(scene):
    return spacebvh.build(scene, "spatial", **BASE).settings


def test_the_settings_describe_themselves():
    assert NAMES and len(set(NAMES)) == len(NAMES)
    for setting in SETTINGS:
        assert setting["type"] in ("number", "whole", "flag", "search_spaces", "bytes"), setting
        assert setting["help"] and "{" not in setting["help"], setting
        assert setting["flag"].startswith("--"), setting
    defaults = {setting["name"]: setting["default"] for setting in SETTINGS}
    assert defaults["max_leaf_size"] == 8
    assert defaults["overlap_penalty"] is None  # the builder's own
    assert defaults["unsplitting"] is True


@pytest.mark.parametrize("setting", SETTINGS, ids=NAMES)
def test_every_setting_reaches_the_tree_alone(scene, base_settings, setting):
    bvh = spacebvh.build(scene, "spatial", **{**BASE, setting["name"]: as_python(setting)})
    changed = {name for name in NAMES if bvh.settings[name] != base_settings[name]}
    assert changed == {setting["name"]}
    stored, expected = bvh.settings[setting["name"]], as_stored(setting)
    if isinstance(expected, float):
        assert math.isclose(stored, expected, rel_tol=1e-6)
    else:
        assert stored == expected


def test_unknown_keywords_are_refused_with_the_known_ones(scene):
    with pytest.raises(TypeError, match="unexpected keyword argument 'overlap'") as error:
        spacebvh.build(scene, "spatial", overlap=2.0)
    for name in NAMES:
        assert name in str(error.value)


def test_values_of_the_wrong_type_or_range(scene):
    with pytest.raises(TypeError, match="max_leaf_size"):
        spacebvh.build(scene, max_leaf_size=2.5)
    with pytest.raises(TypeError, match="spatial_sweep"):
        spacebvh.build(scene, spatial_sweep=1)
    with pytest.raises(TypeError, match="overlap_penalty"):
        spacebvh.build(scene, overlap_penalty="inf")
    with pytest.raises(spacebvh.Error, match="max_leaf_size"):
        spacebvh.build(scene, max_leaf_size=-1)
    with pytest.raises(spacebvh.Error, match="max leaf size"):
        spacebvh.build(scene, max_leaf_size=0)
    # None is the default; NumPy numbers are numbers.
    default = spacebvh.build(scene, "spatial").cost_model
    assert spacebvh.build(scene, "spatial", overlap_penalty=None).cost_model == default
    numpy_values = spacebvh.build(scene, max_leaf_size=np.int64(2), overlap_penalty=np.float32(0.5))
    assert numpy_values.settings["max_leaf_size"] == 2


def test_quality_levels(scene):
    assert spacebvh.build(scene, quality=spacebvh.Quality.fast).builder == "binned"
    balanced = spacebvh.build(scene, quality="balanced")
    assert balanced.builder == "spatial" and balanced.settings["search"] == "binned+spatial"
    high = spacebvh.build(scene, quality="high", max_leaf_size=4)
    assert high.builder == "spatial+opt" and high.settings["max_leaf_size"] == 4
    with pytest.raises(spacebvh.Error, match="not both"):
        spacebvh.build(scene, "cbvh", quality="high")
    with pytest.raises(spacebvh.Error, match="medium"):
        spacebvh.build(scene, quality="medium")


def test_memory_limit(scene):
    with pytest.raises(spacebvh.Error, match="memory limit of 1 bytes"):
        spacebvh.build(scene, "spatial", memory_limit=1)
    if spacebvh.has_embree:  # Embree's trees are estimated too (a build without Embree cannot make them)
        with pytest.raises(spacebvh.Error, match="memory limit"):
            spacebvh.build(scene, "embree-high", memory_limit="1K")
    assert spacebvh.build(scene, memory_limit="64G").settings["memory_limit"] == 64 << 30


def test_termination_aware_builds(scene):
    # Rays traced on a quick tree choose the splits; the same recipe gives the same tree.
    chosen = spacebvh.build(scene, "spatial", termination_rays=2000)
    assert chosen.stats() == spacebvh.build(scene, "spatial", termination_rays=2000, threads=1).stats()
    # The two-pass build: rays traced on the built tree price its reinsertion.
    optimized = spacebvh.build(scene, "spatial", termination_rays=2000, termination_split=False, termination_optimize=4)
    assert optimized.builder == "spatial+topt"
    with pytest.raises(spacebvh.Error, match="termination_rays"):
        spacebvh.build(scene, "spatial", termination_optimize=4)
    with pytest.raises(spacebvh.Error, match="not to Embree's tree"):
        spacebvh.build(scene, "embree-high", termination_rays=10)


def test_docs_list_exactly_the_settings():
    text = (REPOSITORY / "docs" / "python.md").read_text()
    section = text.split("### Build settings", 1)[1].split("\n#", 1)[0]
    documented = re.findall(r"^\| `([a-z_]+)` \|", section, flags=re.MULTILINE)
    assert documented == NAMES
