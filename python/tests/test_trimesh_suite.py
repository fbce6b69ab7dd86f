# SPDX-License-Identifier: MIT
"""trimesh's own ray tests, run against spacebvh's intersector.

trimesh's ``tests/test_ray.py`` and the models it needs are read from ../shared/peers/trimesh (MIT,
as published; never copied here) and run by pytest in a subprocess with the plugin
``spacebvh_trimesh_route``, which routes trimesh's Embree backend to spacebvh. Skipped when
../shared or trimesh is absent.
"""

import pytest
from peer_suite import PEERS, run_peer_suite

pytest.importorskip("trimesh")

SUITE = PEERS / "trimesh" / "tests" / "test_ray.py"


@pytest.mark.skipif(not SUITE.exists(), reason=f"trimesh's test suite is not at {SUITE}")
def test_trimesh_test_ray_passes_with_spacebvh():
    result = run_peer_suite(SUITE, "spacebvh_trimesh_route")
    assert result.returncode == 0, "trimesh's test_ray.py failed against spacebvh (output above)"
    assert " passed" in result.stdout and " failed" not in result.stdout and "skipped" not in result.stdout
