# SPDX-License-Identifier: MIT
"""Tests of the module's scenes, builders, tracers, rays, files and images against an independent
NumPy brute force (double-precision Moller-Trumbore over every triangle). Run with pytest against
the installed package (scripts/test.sh installs it into a fresh virtual environment)."""

import math
import os
import pathlib
import subprocess
import tempfile
import unittest

import numpy as np

import spacebvh

# Rays whose NumPy answer is decided by less than this (barycentric margin or relative t gap to the
# next candidate) are left out of the comparison: there float rounding of the brute force itself,
# not our exact arbiter, would decide.
MARGIN = 1e-6


def brute_force(vertices, origins, directions, tmin, tmax):
    """Closest hit per ray, in double: (t, primitive, decided). `decided` is False where the hit
    or miss is too close to call (near an edge, or two hits at almost the same distance)."""
    v0, v1, v2 = (vertices[:, k, :].astype(np.float64) for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    n_rays = origins.shape[0]
    best_t = np.full(n_rays, np.inf)
    best_prim = np.full(n_rays, -1, dtype=np.int64)
    decided = np.ones(n_rays, dtype=bool)
    for i in range(n_rays):
        o = origins[i].astype(np.float64)
        d = directions[i].astype(np.float64)
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        valid = np.abs(det) > 1e-30
        inv = np.where(valid, 1.0 / np.where(valid, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        w = 1.0 - u - v
        inside = valid & (u >= 0) & (v >= 0) & (w >= 0) & (t >= tmin) & (t <= tmax)
        near_edge = valid & (np.minimum(np.minimum(u, v), w) > -MARGIN) & (np.minimum(np.minimum(u, v), w) < MARGIN)
        near_range = valid & (np.abs(t - tmin) <= MARGIN * (1 + abs(tmin)))
        if math.isfinite(tmax):
            near_range |= valid & (np.abs(t - tmax) <= MARGIN * (1 + abs(tmax)))
        # Within range of the candidates: anything near an edge or the ends makes the ray undecided.
        if np.any((near_edge | near_range) & (t >= tmin - MARGIN) & (t <= tmax + MARGIN)):
            decided[i] = False
        if np.any(inside):
            ts = np.where(inside, t, np.inf)
            order = np.argsort(ts, kind="stable")
            best_t[i] = ts[order[0]]
            best_prim[i] = order[0]
            if np.count_nonzero(inside) > 1 and ts[order[1]] - ts[order[0]] <= MARGIN * max(1.0, ts[order[0]]):
                decided[i] = False  # two hits at nearly the same distance: either is right
    return best_t, best_prim, decided


def triangles_of(vertices, indices):
    return vertices[indices]


class SceneTests(unittest.TestCase):
    def test_builtin_scenes_load(self):
        names = spacebvh.builtin_scenes()
        self.assertIn("interior", names)
        scene = spacebvh.load_scene("builtin:organic")
        self.assertGreater(scene.triangle_count, 0)
        lo, hi = scene.bounds
        self.assertTrue(all(low <= high for low, high in zip(lo, hi)))

    def test_load_time_transform_and_primary_rays(self):
        plain = spacebvh.load_scene("builtin:organic")
        moved = spacebvh.load_scene("builtin:organic", scale=2.0, translate=(10, 0, 0))
        self.assertEqual(moved.triangle_count, plain.triangle_count)
        (lo, hi), (mlo, mhi) = plain.bounds, moved.bounds
        np.testing.assert_allclose(np.array(mlo), 2 * np.array(lo) + [10, 0, 0], rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(np.array(mhi), 2 * np.array(hi) + [10, 0, 0], rtol=1e-5, atol=1e-5)
        rotated = spacebvh.load_scene("builtin:interior", rotate="x:45,y:45,z:45")
        self.assertNotEqual(rotated.bounds, spacebvh.load_scene("builtin:interior").bounds)
        with self.assertRaises(spacebvh.Error):
            spacebvh.load_scene("builtin:organic", rotate="w:45")
        with self.assertRaisesRegex(spacebvh.Error, "scale"):
            spacebvh.load_scene("builtin:organic", scale=0.0)
        origins, directions = spacebvh.primary_rays(plain, 16, 8)
        self.assertEqual(origins.shape, (128, 3))
        np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, rtol=1e-5)
        self.assertTrue(np.all(origins == origins[0]))  # one eye
        eye, _ = spacebvh.primary_rays(plain, 4, 4, camera="0,0,5,0,0,0,0,1,0,60")
        np.testing.assert_array_equal(eye[0], [0, 0, 5])
        # The centre pixel looks at the target.
        _, look = spacebvh.primary_rays(plain, 1, 1, camera="0,0,5,0,0,0,0,1,0,60")
        np.testing.assert_allclose(look[0], [0, 0, -1], atol=1e-6)
        with self.assertRaises(spacebvh.Error):
            spacebvh.primary_rays(plain, 0, 4)

    def test_mesh_from_arrays_and_bad_input(self):
        vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
        scene = spacebvh.mesh(vertices, np.array([[0, 1, 2], [0, 0, 1]]))
        self.assertEqual(scene.triangle_count, 2)
        self.assertEqual(scene.degenerate_count, 1)
        with self.assertRaisesRegex(spacebvh.Error, "triangle 0 uses vertex 3"):
            spacebvh.mesh(vertices, np.array([[0, 1, 3]]))
        with self.assertRaisesRegex(spacebvh.Error, "no triangles"):
            spacebvh.mesh(vertices, np.zeros((0, 3), dtype=np.int64))
        bad = vertices.copy()
        bad[1, 2] = np.nan
        with self.assertRaisesRegex(spacebvh.Error, "vertex 1"):
            spacebvh.mesh(bad, np.array([[0, 1, 2]]))
        with self.assertRaisesRegex(spacebvh.Error, r"shape \(n, 3\)"):
            spacebvh.mesh(vertices.reshape(-1), np.array([[0, 1, 2]]))
        with self.assertRaisesRegex(spacebvh.Error, "unknown builder"):
            spacebvh.build(scene, "no-such-builder")
        with self.assertRaises(spacebvh.Error):
            spacebvh.build(scene, "binned", max_leaf_size=0)
        with self.assertRaises(spacebvh.Error):
            spacebvh.load_scene("/no/such/file.obj")


class TracingTests(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        # A random soup of 400 triangles: small enough for the NumPy brute force over every pair.
        rng = np.random.default_rng(7)
        centers = rng.uniform(-1, 1, size=(400, 1, 3))
        cls.vertices = (centers + rng.normal(scale=0.15, size=(400, 3, 3))).astype(np.float32)
        flat = cls.vertices.reshape(-1, 3)
        cls.scene = spacebvh.mesh(flat, np.arange(flat.shape[0]).reshape(-1, 3), "soup400")
        cls.origins, cls.directions = spacebvh.random_rays(cls.scene, 1500, seed=3)
        cls.expected_t, cls.expected_prim, cls.decided = brute_force(
            cls.vertices, cls.origins, cls.directions, 0.0, math.inf
        )
        # The comparison must be about something: most rays decided, many of them hits.
        assert cls.decided.mean() > 0.9
        assert np.count_nonzero(cls.expected_prim[cls.decided] >= 0) > 200

    def check_against_brute_force(self, tracer):
        t, prim, u, v = tracer.intersect(self.origins, self.directions)
        d = self.decided
        np.testing.assert_array_equal(prim[d], self.expected_prim[d], err_msg=tracer.kernel)
        hit = d & (self.expected_prim >= 0)
        np.testing.assert_allclose(t[hit], self.expected_t[hit], rtol=1e-5, err_msg=tracer.kernel)
        self.assertTrue(np.all(np.isinf(t[prim < 0])))
        self.assertTrue(
            np.all((u[prim >= 0] >= -1e-6) & (v[prim >= 0] >= -1e-6) & (u[prim >= 0] + v[prim >= 0] <= 1 + 1e-5))
        )
        # Occlusion within [0, tmax]: blocked exactly where the closest hit lies within it.
        blocked = tracer.occluded(self.origins, self.directions, 0.0, 1.0)
        clear = d & (np.abs(self.expected_t - 1.0) > 1e-5)  # no hit too close to tmax to call
        np.testing.assert_array_equal(blocked[clear], (self.expected_t <= 1.0)[clear], err_msg=tracer.kernel)
        # Every ray with a closest hit is occluded over [0, inf).
        self.assertTrue(np.all(tracer.occluded(self.origins[prim >= 0], self.directions[prim >= 0], 0.0, math.inf)))

    def test_every_builder_and_kernel_equals_brute_force(self):
        kernels = [k for k in ("binary", "bvh4", "bvh8", "packet8") if k in spacebvh.kernels()]
        self.assertIn("binary", kernels)
        for builder in ("cbvh", "binned", "kdbvh", "spatial", "sbvh", "esc", "evh"):
            bvh = spacebvh.build(self.scene, builder)
            self.assertGreaterEqual(bvh.reference_count, self.scene.triangle_count - self.scene.degenerate_count)
            for kernel in kernels:
                with self.subTest(builder=builder, kernel=kernel):
                    self.check_against_brute_force(spacebvh.Tracer(bvh, kernel))

    @unittest.skipUnless(spacebvh.has_embree, "this build of spacebvh has no Embree (the self-contained wheel)")
    def test_embree_trees_and_kernels_equal_brute_force(self):
        self.assertIn("embree-high", spacebvh.builders())
        # Embree's binary trees under our kernels: exact answers, like our own trees.
        for builder in ("embree-medium", "embree-high"):
            bvh = spacebvh.build(self.scene, builder, optimize=4)
            self.assertEqual(bvh.builder.split("+")[0], builder)
            for kernel in ("binary", "bvh8"):
                with self.subTest(builder=builder, kernel=kernel):
                    self.check_against_brute_force(spacebvh.Tracer(bvh, kernel))
        # Embree's own kernel, single rays and packets. It is not watertight, but on rays the brute
        # force calls decided (no edge or near-tie within 1e-6) it must agree.
        for quality in ("low", "medium", "high"):
            for packets in (False, True):
                tracer = spacebvh.EmbreeTracer(self.scene, quality, packets=packets)
                self.assertTrue(tracer.kernel.startswith("embree-" + quality))
                self.assertGreater(tracer.memory_bytes, 0)
                with self.subTest(quality=quality, packets=packets):
                    self.check_against_brute_force(tracer)
        with self.assertRaisesRegex(spacebvh.Error, "quality 'best'"):
            spacebvh.EmbreeTracer(self.scene, "best")
        with self.assertRaisesRegex(spacebvh.Error, "not to Embree's tree"):
            spacebvh.build(self.scene, "embree-high", search="binned,spatial")
        with self.assertRaisesRegex(spacebvh.Error, "ray 2"):
            bad = self.directions[:4].copy()
            bad[2] = np.nan
            spacebvh.EmbreeTracer(self.scene).intersect(self.origins[:4], bad)

    def test_options_reach_the_builder(self):
        plain = spacebvh.build(self.scene, "spatial", overlap_penalty=0.0)
        disjoint = spacebvh.build(self.scene, "spatial", overlap_penalty=math.inf)
        self.assertIn("C_o=0", plain.cost_model)
        self.assertIn("C_o=inf", disjoint.cost_model)
        optimized = spacebvh.build(self.scene, "binned", optimize=16)
        self.assertEqual(optimized.builder, "binned+opt")
        self.assertLessEqual(optimized.sah, spacebvh.build(self.scene, "binned").sah + 1e-9)
        stats = spacebvh.build(self.scene, "cbvh", max_leaf_size=2).stats(epo=True)
        self.assertEqual(stats["distinct_primitives"], self.scene.triangle_count - self.scene.degenerate_count)
        self.assertGreaterEqual(stats["epo"], 0.0)
        self.check_against_brute_force(spacebvh.Tracer(disjoint, "bvh8" if "bvh8" in spacebvh.kernels() else "binary"))
        # The fast spatial variant (binned object search) and the spatial gate: other trees, same answers.
        fast = spacebvh.build(self.scene, "spatial", search="binned,spatial")
        self.assertNotEqual(fast.stats(), spacebvh.build(self.scene, "spatial").stats())
        self.check_against_brute_force(spacebvh.Tracer(fast, "binary"))
        # alpha = 1 asks for object overlap of the root's whole area: few spatial splits remain.
        gated = spacebvh.build(self.scene, "spatial", spatial_gate=1.0)
        ungated = spacebvh.build(self.scene, "spatial", spatial_gate=0.0)
        self.assertLess(gated.reference_count, ungated.reference_count)
        self.assertNotEqual(
            spacebvh.build(self.scene, "spatial", spatial_gate=0.0, spatial_bins=4).stats(), ungated.stats()
        )
        # object_bins is --bins: the binned builder's bins (the CLI's tree, to the last digit).
        coarse = spacebvh.build(self.scene, "binned", object_bins=4)
        self.assertNotEqual(coarse.sah, spacebvh.build(self.scene, "binned").sah)
        self.assertEqual(coarse.stats(), spacebvh.build(self.scene, "binned", object_bins=4, threads=1).stats())
        self.check_against_brute_force(spacebvh.Tracer(coarse, "binary"))
        with self.assertRaisesRegex(spacebvh.Error, "bins"):
            spacebvh.build(self.scene, "binned", object_bins=1)
        with self.assertRaisesRegex(spacebvh.Error, "sideways"):
            spacebvh.build(self.scene, "spatial", search="sideways")
        with self.assertRaisesRegex(spacebvh.Error, "gate"):
            spacebvh.build(self.scene, "spatial", spatial_gate=math.nan)
        # lookahead_top is --lookahead-top: never above the greedy tree's SAH, same answers.
        looked_ahead = spacebvh.build(self.scene, "spatial", lookahead_top=0.25)
        self.assertLessEqual(looked_ahead.sah, spacebvh.build(self.scene, "spatial").sah * (1 + 1e-6))
        self.check_against_brute_force(spacebvh.Tracer(looked_ahead, "binary"))
        with self.assertRaisesRegex(spacebvh.Error, "lookahead top share"):
            spacebvh.build(self.scene, "spatial", lookahead_top=3.0)
        with self.assertRaisesRegex(spacebvh.Error, "lookahead_top"):
            spacebvh.build(self.scene, "embree-high", lookahead_top=0.5)

    def test_same_tree_and_answers_for_any_thread_count(self):
        one = spacebvh.build(self.scene, "spatial", threads=1)
        two = spacebvh.build(self.scene, "spatial", threads=2)
        self.assertEqual(one.stats(), two.stats())
        a = spacebvh.Tracer(one, "binary", threads=1).intersect(self.origins, self.directions)
        b = spacebvh.Tracer(two, "binary", threads=2).intersect(self.origins, self.directions)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)

    def test_per_ray_ranges(self):
        tracer = spacebvh.Tracer(
            spacebvh.build(self.scene, "spatial"), "bvh8" if "bvh8" in spacebvh.kernels() else "binary"
        )
        n = self.origins.shape[0]
        tmax = np.where(np.arange(n) % 2 == 0, 1.0, np.inf).astype(np.float32)
        t, prim, _, _ = tracer.intersect(self.origins, self.directions, 0.0, tmax)
        # The closest hit within [0, tmax] is the closest hit overall when that lies within, else none.
        with np.errstate(invalid="ignore"):  # inf - inf where both are infinite: never close to call
            clear = self.decided & ~(np.abs(self.expected_t - tmax) <= 1e-5)
        within = (self.expected_prim >= 0) & (self.expected_t <= tmax)
        self.assertGreater(np.count_nonzero(clear & within & (self.expected_prim >= 0)), 100)
        self.assertGreater(np.count_nonzero(clear & ~within), 100)
        np.testing.assert_array_equal(prim[clear], np.where(within, self.expected_prim, -1)[clear])
        np.testing.assert_array_equal(tracer.occluded(self.origins, self.directions, 0.0, tmax)[clear], within[clear])
        # A NumPy scalar is the same as a number; arrays of the wrong length are refused.
        np.testing.assert_array_equal(
            tracer.intersect(self.origins, self.directions, np.float32(0), np.float32(1.0))[1],
            tracer.intersect(self.origins, self.directions, 0.0, 1.0)[1],
        )
        with self.assertRaisesRegex(spacebvh.Error, "one per ray"):
            tracer.intersect(self.origins, self.directions, 0.0, tmax[:-1])
        bad = tmax.copy()
        bad[5] = -1.0
        with self.assertRaisesRegex(spacebvh.Error, "ray 5"):
            tracer.occluded(self.origins, self.directions, 0.0, bad)

    def test_diffuse_rays_follow_the_spec(self):
        # A floor of two triangles and a slanted triangle above it, seen from above: every primary
        # hit's normal is known here, independently of the module.
        vertices = np.array(
            [[-4, 0, -4], [4, 0, -4], [4, 0, 4], [-4, 0, 4], [-1, 1, -1], [1, 1, -1], [0, 2, 1]], dtype=np.float32
        )
        indices = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6]])
        scene = spacebvh.mesh(vertices, indices)
        tracer = spacebvh.Tracer(spacebvh.build(scene, "cbvh"))
        origins, directions = spacebvh.primary_rays(scene, 24, 24, camera="0,6,3,0,0,0,0,1,0,70")
        t, prim, _, _ = tracer.intersect(origins, directions)
        hit = prim >= 0
        self.assertGreater(np.count_nonzero(hit), 100)
        self.assertGreater(np.count_nonzero(~hit), 0)
        self.assertGreater(np.count_nonzero(prim == 2), 10)

        org, dirs = spacebvh.diffuse_rays(scene, origins, directions, t, prim, seed=3)
        self.assertEqual(org.shape, (np.count_nonzero(hit), 3))
        tri = vertices[indices[prim[hit]]].astype(np.float64)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        facing = np.einsum("ij,ij->i", normal, directions[hit]) > 0
        normal[facing] *= -1  # turned against the primary ray
        lo, hi = np.array(scene.bounds)
        epsilon = 1e-4 * np.linalg.norm(hi - lo)
        surface = origins[hit].astype(np.float64) + directions[hit] * t[hit][:, None]
        np.testing.assert_allclose(org, surface + normal * epsilon, rtol=0, atol=1e-5)
        np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, rtol=1e-5)
        self.assertTrue(np.all(np.einsum("ij,ij->i", dirs, normal) >= -1e-6))  # leaves the surface
        # Cosine distributed: the mean cosine to the normal is 2/3 (about 400 rays: within 0.06).
        self.assertAlmostEqual(float(np.mean(np.einsum("ij,ij->i", dirs, normal))), 2.0 / 3.0, delta=0.06)

        again, again_dirs = spacebvh.diffuse_rays(scene, origins, directions, t, prim, seed=3)
        np.testing.assert_array_equal(again, org)
        np.testing.assert_array_equal(again_dirs, dirs)
        _, other_dirs = spacebvh.diffuse_rays(scene, origins, directions, t, prim, seed=4)
        self.assertFalse(np.array_equal(other_dirs, dirs))
        offset, _ = spacebvh.diffuse_rays(scene, origins, directions, t, prim, seed=3, epsilon=0.5)
        np.testing.assert_allclose(offset, surface + normal * 0.5, rtol=0, atol=1e-5)

        with self.assertRaisesRegex(spacebvh.Error, "primary rays but"):
            spacebvh.diffuse_rays(scene, origins, directions, t[:-1], prim[:-1])
        bad = prim.copy()
        bad[np.argmax(hit)] = 3
        with self.assertRaisesRegex(spacebvh.Error, "names triangle 3"):
            spacebvh.diffuse_rays(scene, origins, directions, t, bad)
        bad_t = t.copy()
        bad_t[np.argmax(hit)] = np.inf
        with self.assertRaisesRegex(spacebvh.Error, "finite t"):
            spacebvh.diffuse_rays(scene, origins, directions, bad_t, prim)
        for epsilon in (-1.0, np.nan, np.inf):
            with self.assertRaisesRegex(spacebvh.Error, "epsilon"):
                spacebvh.diffuse_rays(scene, origins, directions, t, prim, epsilon=epsilon)

    def test_diffuse_rays_equal_the_command_line_tools(self):
        # The same spec, two front ends: `spacebvh rays --kind diffuse` and diffuse_rays() over the
        # module's own primary hits give the same rays, bit for bit. pip installs the command with the package.
        try:
            cli = spacebvh.cli_executable()
        except FileNotFoundError:
            self.skipTest("the spacebvh command is not installed beside the package")
        with tempfile.TemporaryDirectory() as folder:
            primary_path, diffuse_path = os.path.join(folder, "p.rays"), os.path.join(folder, "d.rays")
            for kind, path in (("primary", primary_path), ("diffuse", diffuse_path)):
                subprocess.run(
                    [
                        cli,
                        "rays",
                        "builtin:organic",
                        "--kind",
                        kind,
                        "--seed",
                        "5",
                        "--width",
                        "64",
                        "--height",
                        "48",
                        "-o",
                        path,
                        "-q",
                    ],
                    check=True,
                    capture_output=True,
                )
            origins, directions, _, _ = spacebvh.read_rays(primary_path)
            expected_origins, expected_directions, _, _ = spacebvh.read_rays(diffuse_path)
        scene = spacebvh.load_scene("builtin:organic")
        t, prim, _, _ = spacebvh.Tracer(spacebvh.build(scene, "binned")).intersect(origins, directions)
        diffuse_origins, diffuse_directions = spacebvh.diffuse_rays(scene, origins, directions, t, prim, seed=5)
        self.assertGreater(len(expected_origins), 100)
        np.testing.assert_array_equal(diffuse_origins, expected_origins)
        np.testing.assert_array_equal(diffuse_directions, expected_directions)

    def test_render_and_heat_map(self):
        scene = spacebvh.load_scene("builtin:organic")
        tracer = spacebvh.Tracer(spacebvh.build(scene, "binned"), "bvh8")
        camera = "0,0,14,0,0,0,0,1,0,60"  # the mesh fills about a sixth of the view
        image = tracer.render(40, 30, camera)
        self.assertEqual(image.shape, (30, 40, 3))
        self.assertEqual(image.dtype, np.uint8)
        # Pixel by pixel as primary_rays() and intersect() see it: a hit is lit by the headlight (a warm
        # white scaled by 0.12 + 0.88 |cos|, so never darker than 0.12 of it), a miss the background.
        origins, directions = spacebvh.primary_rays(scene, 40, 30, camera=camera)
        _, prim, _, _ = tracer.intersect(origins, directions)
        hit = (prim >= 0).reshape(30, 40)
        self.assertGreater(np.count_nonzero(hit), 50)
        self.assertGreater(np.count_nonzero(~hit), 50)
        background = image[~hit]
        self.assertTrue(np.all(background == background[0]))
        lit = image[hit].astype(int)
        self.assertTrue(np.all((lit[:, 0] >= lit[:, 1]) & (lit[:, 1] >= lit[:, 2]) & (lit[:, 0] >= 30)))
        self.assertFalse(np.any(np.all(lit == background[0], axis=1)))
        self.assertGreater(lit[:, 0].max() - lit[:, 0].min(), 50)  # shading varies over the curved mesh

        heat, info = tracer.render(40, 30, camera, heatmap=True)
        self.assertEqual(heat.shape, (30 + info["legend_height"], 40, 3))
        self.assertGreater(info["legend_height"], 0)
        self.assertGreater(info["nodes_visited"], 1200)  # every pixel tests at least the root's boxes
        self.assertGreater(info["max_value"], info["mean_value"])
        shared, shared_info = tracer.render(
            40, 30, camera, heatmap=True, quantity="nodes", scale_max=500.0, legend=False
        )
        self.assertEqual(shared.shape, (30, 40, 3))
        self.assertEqual(shared_info["scale_max"], 500.0)
        self.assertEqual(shared_info["triangles_tested"], info["triangles_tested"])
        for bad in ({"quantity": "time"}, {"percentile": 0.0}, {"scale_max": -1.0}):
            with self.assertRaises(spacebvh.Error):
                tracer.render(40, 30, camera, heatmap=True, **bad)
        with self.assertRaises(spacebvh.Error):
            tracer.render(0, 30, camera)

        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "view.png")
            spacebvh.write_png(path, image)
            self.assertEqual(pathlib.Path(path).read_bytes()[:8], b"\x89PNG\r\n\x1a\n")
            with self.assertRaisesRegex(spacebvh.Error, "height, width, 3"):
                spacebvh.write_png(path, image[:, :, :2])
            with self.assertRaisesRegex(spacebvh.Error, "nowhere"):
                spacebvh.write_png(os.path.join(folder, "nowhere", "x.png"), image)

    def test_ray_and_hit_files(self):
        tracer = spacebvh.Tracer(spacebvh.build(self.scene, "binned"), "binary")
        n = 200
        tmin = np.linspace(0.0, 0.5, n, dtype=np.float32)
        with tempfile.TemporaryDirectory() as folder:
            rays_path, hits_path = os.path.join(folder, "r.rays"), os.path.join(folder, "h.hits")
            spacebvh.write_rays(rays_path, self.origins[:n], self.directions[:n], tmin, np.inf)
            # The layout of docs/rays.md, read independently of the module.
            raw = pathlib.Path(rays_path).read_bytes()
            self.assertEqual(raw[:8], b"REFRAYS1")
            self.assertEqual(int.from_bytes(raw[8:16], "little"), n)
            records = np.frombuffer(raw[16:], dtype="<f4").reshape(n, 8)
            np.testing.assert_array_equal(records[:, 0:3], self.origins[:n])
            np.testing.assert_array_equal(records[:, 6], tmin)
            origins, directions, low, high = spacebvh.read_rays(rays_path)
            np.testing.assert_array_equal(origins, self.origins[:n])
            np.testing.assert_array_equal(directions, self.directions[:n])
            np.testing.assert_array_equal(low, tmin)
            self.assertTrue(np.all(np.isinf(high)))
            t, prim, _, _ = tracer.intersect(origins, directions, low, high)
            spacebvh.write_hits(hits_path, t, prim)
            raw = pathlib.Path(hits_path).read_bytes()
            self.assertEqual(raw[:8], b"REFHITS1")
            records = np.frombuffer(raw[16:], dtype=[("t", "<f4"), ("primitive", "<u4")])
            np.testing.assert_array_equal(records["t"], t)
            np.testing.assert_array_equal(records["primitive"], np.where(prim < 0, 0xFFFFFFFF, prim))
            t_read, prim_read = spacebvh.read_hits(hits_path)
            np.testing.assert_array_equal(t_read, t)
            np.testing.assert_array_equal(prim_read, prim)
            with self.assertRaisesRegex(spacebvh.Error, "out of range"):
                spacebvh.write_hits(hits_path, t, np.full(n, -2))
            pathlib.Path(rays_path).write_bytes(b"REFRAYS1" + (5).to_bytes(8, "little") + bytes(40))
            with self.assertRaisesRegex(spacebvh.Error, "r.rays"):
                spacebvh.read_rays(rays_path)

    def test_bad_rays_are_refused(self):
        tracer = spacebvh.Tracer(spacebvh.build(self.scene, "binned"))
        o, d = self.origins[:4].copy(), self.directions[:4].copy()
        d[2] = 0
        with self.assertRaisesRegex(spacebvh.Error, "ray 2"):
            tracer.intersect(o, d)
        with self.assertRaisesRegex(spacebvh.Error, "differ in length"):
            tracer.intersect(self.origins[:3], self.directions[:4])
        with self.assertRaisesRegex(spacebvh.Error, "tmin"):
            tracer.occluded(self.origins[:4], self.directions[:4], 2.0, 1.0)
        with self.assertRaises(spacebvh.Error):
            spacebvh.Tracer(spacebvh.build(self.scene, "binned"), "no-such-kernel")
