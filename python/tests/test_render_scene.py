# SPDX-License-Identifier: MIT
"""spacebvh.RenderScene (docs/scenes.md): two levels of instances from NumPy 3x4 and 4x4 transforms
(rotations, a mirror, non-uniform scales) against test_module's NumPy brute force over the flattened
scene (every instance's triangles taken to world space in double), ids and masks as arrays, refit, and
the errors."""

import numpy as np
import pytest
from test_module import brute_force

import spacebvh


def placed(axis, degrees, scale, shift, mirror=False):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    r = np.eye(3) * c + s * k + (1 - c) * np.outer(a, a)
    if mirror:
        r = r @ np.diag([-1.0, 1.0, 1.0])
    m = np.zeros((3, 4))
    m[:, :3] = np.diag(scale) @ r
    m[:, 3] = shift
    return m.astype(np.float32)


def organic(count):
    triangles = spacebvh.load_scene("builtin:organic").triangles()[:count]
    return triangles, spacebvh.mesh(triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3))


def world(transforms, triangles):
    """The triangles through the transforms (top level first), in double."""
    w = triangles.astype(np.float64)
    for m in reversed(transforms):
        w = w @ m[:, :3].astype(np.float64).T + m[:, 3].astype(np.float64)
    return w


@pytest.fixture(scope="module")
def two_levels():
    triangles, mesh = organic(1500)
    size = float(np.linalg.norm(triangles.reshape(-1, 3).max(0) - triangles.reshape(-1, 3).min(0)))
    leaf = spacebvh.RenderScene("spatial", name="leaf")
    leaf.attach_mesh(mesh)
    leaf.commit()
    middle = spacebvh.RenderScene(name="middle")
    a = placed([1, 2, 3], 37, [1, 1, 1], [size, 0, 0])
    b = placed([0, 1, 0], 90, [2.0, 0.5, 1.0], [0, size, 0], mirror=True)
    ids_mid = [middle.attach_instance(leaf, a), middle.attach_instance(leaf, np.vstack([b, [0, 0, 0, 1]]), mask=2)]
    middle.commit()
    top = spacebvh.RenderScene(name="top")
    c = placed([1, 1, 0], 60, [0.5, 0.7, 0.5], [0, -size, 0])
    d = placed([0, 0, 1], 200, [1.0, 1.0, 3.0], [-size, size, 0], mirror=True)
    ids_top = [top.attach_instance(middle, c), top.attach_instance(middle, d)]
    top.commit()
    parts = []  # (instance path, transforms, mask of the middle instance)
    for it, mt in zip(ids_top, [c, d]):
        for im, mm, mask in zip(ids_mid, [a, b], [0xFFFFFFFF, 2]):
            parts.append(((it, im), [mt, mm], mask))
    return top, triangles, parts


def rays(scene, count, seed, targets=None):
    """Origins in the scene's box; directions random, or half of them towards random `targets`."""
    lo, hi = (np.array(b) for b in scene.bounds)
    rng = np.random.default_rng(seed)
    origins = lo + rng.random((count, 3)) * (hi - lo)
    directions = rng.normal(size=(count, 3))
    if targets is not None:
        aimed = targets[rng.integers(0, len(targets), count // 2)]
        directions[: count // 2] = aimed - origins[: count // 2]
    return origins.astype(np.float32), directions.astype(np.float32)


@pytest.mark.parametrize("mask", [0xFFFFFFFF, 1, 2])
def test_two_levels_match_the_flattened_brute_force(two_levels, mask):
    top, triangles, parts = two_levels
    centroids = np.concatenate([world(transforms, triangles) for _, transforms, _ in parts]).mean(axis=1)
    origins, directions = rays(top, 300, 1, centroids)
    visible = [p for p in parts if p[2] & mask]
    flat = np.concatenate([world(transforms, triangles) for _, transforms, _ in visible])
    t_ref, k_ref, decided = brute_force(flat, origins, directions, 0.0, np.inf)
    t, primitive, u, v, geometry, instance = top.intersect(origins, directions, mask=mask)
    assert instance.shape == (300, 4) and geometry.shape == (300,)
    hit = np.isfinite(t_ref)
    assert decided.sum() > 250 and (hit & decided).sum() > 30
    d = decided
    assert np.array_equal(np.isfinite(t[d]), hit[d])
    assert np.allclose(t[d & hit], t_ref[d & hit], rtol=1e-4)
    n = len(triangles)
    assert np.array_equal(primitive[d & hit], k_ref[d & hit] % n)
    paths = np.array([p[0] for p in visible])[k_ref[d & hit] // n]
    assert np.array_equal(instance[d & hit][:, :2], paths)
    assert (instance[:, 2:] == -1).all() and (geometry[np.isfinite(t)] == 0).all()
    assert ((primitive == -1) == ~np.isfinite(t)).all()
    occluded = top.occluded(origins, directions, mask=mask)
    assert np.array_equal(occluded[d], hit[d])


def test_per_ray_masks(two_levels):
    top, _, _ = two_levels
    origins, directions = rays(top, 200, 2)
    masks = np.where(np.arange(200) % 2 == 0, 1, 2).astype(np.uint32)
    t_all = top.intersect(origins, directions, mask=masks)[0]
    for m in (1, 2):
        rows = masks == m
        assert np.array_equal(t_all[rows], top.intersect(origins[rows], directions[rows], mask=m)[0])
    assert not top.occluded(origins, directions, mask=0).any()


def test_refit_answers_as_a_fresh_build():
    triangles, mesh = organic(1200)
    rotation = placed([0, 0, 1], 30, [1, 1, 1], [0, 0, 0])
    moved_triangles = (triangles @ rotation[:, :3].T).astype(np.float32)
    moved = spacebvh.mesh(moved_triangles.reshape(-1, 3), np.arange(3 * len(triangles)).reshape(-1, 3))

    def scenes(m):
        leaf = spacebvh.RenderScene("spatial", name="leaf")
        gid = leaf.attach_mesh(m)
        leaf.commit()
        top = spacebvh.RenderScene()
        top.attach_instance(leaf, placed([1, 0, 0], 45, [1, 2, 1], [0, 0, 0], mirror=True))
        top.commit()
        return leaf, gid, top

    leaf, gid, top = scenes(mesh)
    _, _, fresh = scenes(moved)
    leaf.refit(gid, moved)
    centroids = world([placed([1, 0, 0], 45, [1, 2, 1], [0, 0, 0], mirror=True)], moved_triangles).mean(axis=1)
    with pytest.raises(spacebvh.Error, match="refitted since"):
        top.intersect(*rays(fresh, 10, 3))
    top.refit()
    origins, directions = rays(fresh, 400, 3, centroids)
    ours, theirs = top.intersect(origins, directions), fresh.intersect(origins, directions)
    assert np.isfinite(ours[0]).sum() > 20
    assert np.allclose(ours[0], theirs[0], rtol=1e-5) and np.array_equal(ours[1], theirs[1])


def test_errors_name_the_input():
    _, mesh = organic(10)
    leaf = spacebvh.RenderScene(name="leaf")
    gid = leaf.attach_mesh(mesh)
    with pytest.raises(spacebvh.Error, match="not committed"):
        leaf.intersect(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    leaf.commit()
    top = spacebvh.RenderScene(name="top")
    with pytest.raises(spacebvh.Error, match=r"shape \(3, 3\)"):
        top.attach_instance(leaf, np.eye(3))
    with pytest.raises(spacebvh.Error, match="singular"):
        top.attach_instance(leaf, np.zeros((3, 4)))
    with pytest.raises(spacebvh.Error, match="last row"):
        top.attach_instance(leaf, np.ones((4, 4)))
    with pytest.raises(spacebvh.Error, match="not finite"):
        top.attach_instance(leaf, np.array([[1, 0, 0, np.nan], [0, 1, 0, 0], [0, 0, 1, 0]]))
    with pytest.raises(spacebvh.Error, match="32-bit"):
        top.attach_instance(leaf, np.eye(4), mask=-1)
    with pytest.raises(spacebvh.Error, match="32-bit"):
        top.attach_instance(leaf, np.eye(4), mask=2**32)
    with pytest.raises(spacebvh.Error, match="no geometry with id 5"):
        top.detach(5)
    top.attach_instance(leaf, np.eye(4))
    top.commit()
    with pytest.raises(spacebvh.Error, match="cannot detach"):
        leaf.detach(gid)
    o, d = np.zeros((3, 3), np.float32), np.ones((3, 3), np.float32)
    with pytest.raises(spacebvh.Error, match="2 masks for 3 rays"):
        top.intersect(o, d, mask=np.array([1, 2]))
    with pytest.raises(spacebvh.Error, match="outside"):
        top.occluded(o, d, mask=np.array([1, -2, 3]))
    with pytest.raises(TypeError):
        top.occluded(o, d, mask=np.array([1.0, 2.0, 3.0]))
    with pytest.raises(spacebvh.Error, match="float64"):
        leaf2 = spacebvh.RenderScene()
        leaf2.attach_mesh(spacebvh.mesh(np.eye(3) + 1000.0, np.array([[0, 1, 2]])))
    with pytest.raises(spacebvh.Error, match="cannot trace scenes"):
        spacebvh.RenderScene(kernel="packet8")


def test_attach_instances_matches_attaching_one_by_one():
    triangles, mesh = organic(300)
    leaf = spacebvh.RenderScene(name="leaf")
    leaf.attach_mesh(mesh)
    leaf.commit()
    square = spacebvh.RenderScene(name="square")
    square.attach_mesh(
        spacebvh.mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32), [[0, 1, 2], [0, 2, 3]])
    )
    square.commit()
    rng = np.random.default_rng(3)
    count = 200
    transforms = np.stack(
        [
            placed(
                rng.normal(size=3) + [0, 0, 0.1],
                rng.uniform(0, 360),
                rng.uniform(0.5, 2, 3),
                rng.uniform(-3, 3, 3),
                k % 3 == 0,
            )
            for k in range(count)
        ]
    )
    which = np.arange(count) % 4 == 1
    masks = np.where(np.arange(count) % 5 == 2, 2, 0xFFFFFFFF)
    one = spacebvh.RenderScene(name="one")
    ids_one = [one.attach_instance(square if w else leaf, t, mask=int(m)) for t, w, m in zip(transforms, which, masks)]
    batch = spacebvh.RenderScene(name="batch")
    ids = batch.attach_instances([leaf, square], transforms, scene_index=which.astype(np.int64), masks=masks)
    assert ids.tolist() == ids_one
    one.commit()
    batch.commit()
    lo, hi = (np.array(b) for b in one.bounds)
    origins = rng.uniform(lo, hi, (4000, 3)).astype(np.float32)
    directions = rng.normal(size=(4000, 3)).astype(np.float32)
    for mask in (0xFFFFFFFF, 2):
        a, b = one.intersect(origins, directions, mask=mask), batch.intersect(origins, directions, mask=mask)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(
            one.occluded(origins, directions, mask=mask), batch.occluded(origins, directions, mask=mask)
        )
    assert (a[4] >= 0).sum() > 100  # the rays reach the instances
    # 4x4 transforms too; one scene given alone.
    four = np.concatenate([transforms[:3], np.tile([[[0, 0, 0, 1]]], (3, 1, 1))], axis=1)
    assert batch.attach_instances(leaf, four).tolist() == [count, count + 1, count + 2]


def test_attach_instances_errors_name_the_entry():
    leaf = spacebvh.RenderScene(name="leaf")
    leaf.attach_mesh(organic(10)[1])
    leaf.commit()
    top = spacebvh.RenderScene(name="top")
    good = np.tile(np.eye(3, 4, dtype=np.float32), (6, 1, 1))
    bad = good.copy()
    bad[4, 1, 1] = 0.0
    bad[4, 1, :3] = 0.0
    with pytest.raises(spacebvh.Error, match=r"placements\[4\] \(would be geometry 4\): transform is singular"):
        top.attach_instances(leaf, bad)
    four = np.concatenate([good, np.tile([[[0, 0, 0, 1]]], (6, 1, 1))], axis=1).astype(np.float32)
    four[2, 3, 2] = 1.0
    with pytest.raises(spacebvh.Error, match=r"transforms\[2\]: transform: the last row"):
        top.attach_instances(leaf, four)
    with pytest.raises(spacebvh.Error, match=r"scene_index\[3\]: 1, not in \[0, 1\)"):
        top.attach_instances([leaf], good, scene_index=[0, 0, 0, 1, 0, 0])
    with pytest.raises(spacebvh.Error, match=r"masks: transform 5 has -1"):
        top.attach_instances(leaf, good, masks=np.array([1, 1, 1, 1, 1, -1]))
    with pytest.raises(spacebvh.Error, match=r"masks: 2 masks for 6 transforms"):
        top.attach_instances(leaf, good, masks=np.array([1, 1]))
    with pytest.raises(spacebvh.Error, match=r"\(n, 3, 4\) or \(n, 4, 4\)"):
        top.attach_instances(leaf, good[0])
    assert top.geometry_count == 0  # nothing attached by the failed calls
    assert top.attach_instances(leaf, good).tolist() == list(range(6))
