# SPDX-License-Identifier: MIT
"""trimesh's own ray tests, run against spacebvh's intersector.

trimesh's ``tests/test_ray.py`` and the models it needs are read from ../shared/peers/trimesh (MIT,
as published; never copied here) and run by pytest in a subprocess with the plugin
``spacebvh_trimesh_route``, which routes trimesh's Embree backend to spacebvh. Skipped when
../shared or trimesh is absent.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("trimesh")

HERE = Path(__file__).resolve().parent
# The repository root is two levels up; ../shared sits beside it.
SUITE = HERE.parent.parent.parent / "shared" / "peers" / "trimesh" / "tests" / "test_ray.py"


@pytest.mark.skipif(not SUITE.exists(), reason=f"trimesh's test suite is not at {SUITE}")
def test_trimesh_test_ray_passes_with_spacebvh():
    env = dict(os.environ)
    # The plugin module lives beside this file; the child pytest finds it through PYTHONPATH.
    env["PYTHONPATH"] = str(HERE) + os.pathsep + env.get("PYTHONPATH", "")
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "spacebvh_trimesh_route",
            "-p",
            "no:cacheprovider",
            "--rootdir",
            str(SUITE.parent),
            str(SUITE),
        ],
        cwd=str(SUITE.parent),
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    print(result.stdout[-6000:])
    print(result.stderr[-3000:])
    assert result.returncode == 0, "trimesh's test_ray.py failed against spacebvh (output above)"
    assert " passed" in result.stdout and " failed" not in result.stdout and "skipped" not in result.stdout
