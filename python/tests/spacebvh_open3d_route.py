# SPDX-License-Identifier: MIT
"""A pytest plugin that routes Open3D's ``RaycastingScene`` to spacebvh's.

Used to run Open3D's own tests (../shared/peers/open3d/python/test/t/geometry/test_raycasting_scene.py)
against ``spacebvh.open3d.RaycastingScene``: load it with ``-p spacebvh_open3d_route`` (see
test_open3d_suite.py). ``open3d.t.geometry.RaycastingScene`` is then ours.
"""

import open3d

import spacebvh.open3d


def pytest_configure(config):
    open3d.t.geometry.RaycastingScene = spacebvh.open3d.RaycastingScene


def pytest_report_header(config):
    return "open3d.t.geometry.RaycastingScene routed to spacebvh.open3d.RaycastingScene"
