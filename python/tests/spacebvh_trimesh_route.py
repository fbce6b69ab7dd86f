# SPDX-License-Identifier: MIT
"""A pytest plugin that routes trimesh's Embree backend to spacebvh's intersector.

Used to run trimesh's own ray tests (../shared/peers/trimesh/tests/test_ray.py) against
``spacebvh.trimesh.RayMeshIntersector``: load it with ``-p spacebvh_trimesh_route`` (see
test_trimesh_suite.py). Every ``trimesh.Trimesh`` made with ``use_embree=True`` then gets our
intersector, and ``trimesh.ray.ray_pyembree.RayMeshIntersector`` is ours.
"""

import spacebvh.trimesh


def pytest_configure(config):
    spacebvh.trimesh.patch()


def pytest_report_header(config):
    return "trimesh's Embree backend routed to spacebvh.trimesh.RayMeshIntersector"
