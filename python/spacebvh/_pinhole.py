# SPDX-License-Identifier: MIT
"""Pinhole camera rays as Open3D's ``RaycastingScene.create_rays_pinhole`` makes them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def _matrix(value: Any, shape: tuple[int, int], name: str) -> np.ndarray:
    if hasattr(value, "numpy") and hasattr(value, "cpu") and not isinstance(value, np.ndarray):
        value = value.cpu().numpy()
    result = np.asarray(value, dtype=np.float64)
    if result.shape != shape or not np.isfinite(result).all():
        raise ValueError(f"{name} must be a finite {shape[0]}x{shape[1]} matrix, not {result.shape}")
    return result


def _size(value: Any, name: str) -> int:
    if int(value) < 1:
        raise ValueError(f"{name} must be >= 1, not {value}")
    return int(value)


def _from_matrices(intrinsic: Any, extrinsic: Any, width_px: Any, height_px: Any) -> np.ndarray:
    """Rays through the pixel centres (u + 0.5, v + 0.5) of a camera with intrinsic matrix K and the
    world-to-camera transform [R | t]: origin -R^T t, direction R^T K^-1 (u + 0.5, v + 0.5, 1)."""
    k = _matrix(intrinsic, (3, 3), "intrinsic_matrix")
    e = _matrix(extrinsic, (4, 4), "extrinsic_matrix")
    width, height = _size(width_px, "width_px"), _size(height_px, "height_px")
    u, v = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    pixels = np.stack([u, v, np.ones_like(u)], axis=-1)
    rotation, translation = e[:3, :3], e[:3, 3]
    directions = pixels @ np.linalg.inv(k).T @ rotation
    origin = -rotation.T @ translation
    rays = np.empty((height, width, 6), dtype=np.float32)
    rays[..., :3] = origin
    rays[..., 3:] = directions
    return rays


def _from_look_at(fov_deg: Any, center: Any, eye: Any, up: Any, width_px: Any, height_px: Any) -> np.ndarray:
    """The camera at ``eye`` looking at ``center`` with ``up`` and a horizontal field of view of
    ``fov_deg`` degrees, as intrinsic and extrinsic matrices."""
    width, height = _size(width_px, "width_px"), _size(height_px, "height_px")
    if not 0.0 < float(fov_deg) < 180.0:
        raise ValueError(f"fov_deg must be in (0, 180), not {fov_deg}")
    focal = 0.5 * width / math.tan(math.radians(float(fov_deg)) / 2.0)
    intrinsic = np.array([[focal, 0.0, 0.5 * width], [0.0, focal, 0.5 * height], [0.0, 0.0, 1.0]])
    center, eye, up = (
        _matrix(np.reshape(x, (1, 3)), (1, 3), n)[0] for x, n in ((center, "center"), (eye, "eye"), (up, "up"))
    )
    forward = center - eye
    right = np.cross(up, forward)
    down = np.cross(forward, right)
    if np.linalg.norm(forward) == 0.0 or np.linalg.norm(right) == 0.0:
        raise ValueError("eye must differ from center, and up must not be parallel to the view direction")
    rotation = np.stack([right / np.linalg.norm(right), down / np.linalg.norm(down), forward / np.linalg.norm(forward)])
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation
    extrinsic[:3, 3] = -rotation @ eye
    return _from_matrices(intrinsic, extrinsic, width, height)


def rays_pinhole(*args: Any, **kwargs: Any) -> np.ndarray:
    """Either form of ``create_rays_pinhole``, chosen by its first argument (a matrix or a number)."""
    first = args[0] if args else kwargs.get("intrinsic_matrix", kwargs.get("fov_deg"))
    if "intrinsic_matrix" in kwargs or (first is not None and np.ndim(_matrix_like(first)) == 2):
        return _from_matrices(*args, **kwargs)
    return _from_look_at(*args, **kwargs)


def _matrix_like(value: Any) -> Any:
    if hasattr(value, "numpy") and hasattr(value, "cpu") and not isinstance(value, np.ndarray):
        return value.cpu().numpy()
    return np.asarray(value)
