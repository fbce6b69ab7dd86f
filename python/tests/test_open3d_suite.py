# SPDX-License-Identifier: MIT
"""Open3D's own RaycastingScene tests, run against spacebvh's drop-in.

Open3D's ``python/test/t/geometry/test_raycasting_scene.py`` (with its helper ``open3d_test.py``) is
read from ../shared/peers/open3d (MIT, as published; never copied here) and run by pytest in a
subprocess with the plugin ``spacebvh_open3d_route``, which makes ``open3d.t.geometry.RaycastingScene``
ours. Skipped when ../shared or open3d (``open3d-cpu``, in the ``open3d-tests`` extra) is absent.
"""

import re

import pytest
from peer_suite import PEERS, run_peer_suite

pytest.importorskip("open3d")

SUITE = PEERS / "open3d" / "python" / "test" / "t" / "geometry" / "test_raycasting_scene.py"


@pytest.mark.skipif(not SUITE.exists(), reason=f"Open3D's test suite is not at {SUITE}")
def test_open3d_test_raycasting_scene_passes_with_spacebvh():
    result = run_peer_suite(SUITE, "spacebvh_open3d_route")
    assert result.returncode == 0, "Open3D's test_raycasting_scene.py failed against spacebvh (output above)"
    # All 18 of the published file (Open3D 0.20), none failed or skipped.
    assert re.search(r"^18 passed", result.stdout, re.MULTILINE), "not all of Open3D's 18 tests passed"
    assert " failed" not in result.stdout and "skipped" not in result.stdout
